"""The independent readers the log-format cross-checks hold ndsid to, and the comparison.

  python-can (BLFReader, ASCReader) for Vector BLF and ASC, asammdf (MDF, get) for ASAM MF4
  bus logging, each turned into frames of ndsid's form: time in ns, bus name, id, flags
  (1 extended, 2 remote, 4 error, 8 FD, 16 BRS, 32 ESI), length, data.

Rules of the comparison (the places where the oracles and ndsid differ by design):
  - A record the oracle yields that no CAN bus can carry (a standard id above 0x7FF, an
    extended one above 2^29 - 1, more than 8 bytes in a classic frame) must be rejected by
    ndsid as malformed: python-can builds such messages unchecked (vector_blf's unit-test
    files are fill patterns such as id 0x4444444 without the extended bit).
  - Error frames are compared by time, bus and the error flag (ndsid carries no Vector error
    codes); ndsid also reads BLF's CAN_ERROR and CAN_FD_ERROR_64 objects, which python-can
    skips: extra error frames are listed, not counted as differences.
  - Remote frames: id, extended, time, bus and length (the DLC, at most 8); an "FD remote"
    (ASC CANFD line with data length 0) is a classic remote frame (CAN FD has none).
  - Times within `tolerance_ns` (the oracles hand out float64 seconds).
"""
import gzip
import subprocess

NS = 1_000_000_000
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


def frame(ns, bus, cid=0, ext=False, remote=False, error=False, fd=False, brs=False, esi=False, data=b"", length=None):
    flags = 4 if error else (1 if ext else 0) | (2 if remote else 0) | (0 if remote else (8 if fd else 0) |
                                                                          (16 if fd and brs else 0) |
                                                                          (32 if fd and esi else 0))
    return dict(ns=int(ns), bus=bus, id=0 if error else int(cid), flags=flags,
                len=len(data) if length is None else int(length), data=b"" if (remote or error) else bytes(data))


def valid_can(f):
    """Whether a frame of the oracle is one a CAN bus can carry."""
    if f["flags"] & 4:
        return True
    limit = 0x1FFFFFFF if f["flags"] & 1 else 0x7FF
    if f["id"] > limit:
        return False
    if f["flags"] & 2:
        return f["len"] <= 8
    return f["len"] in FD_LENGTHS if f["flags"] & 8 else f["len"] <= 8


def ndsid_read(dump, path):
    """(exit code, frames, summary line, stderr) of can_frame_log_dump on `path`."""
    out = subprocess.run([dump, path], capture_output=True, text=True)
    frames, summary = [], ""
    for line in out.stdout.splitlines():
        if line.startswith("# format="):
            summary = line
            continue
        if line.startswith("# fraction_read"):
            summary += " " + line[2:]
            continue
        if line.startswith("#"):
            continue
        ns, bus, cid, flags, length, data = line.split()
        frames.append(dict(ns=int(ns), bus=bus, id=int(cid, 16), flags=int(flags), len=int(length),
                           data=b"" if data == "-" else bytes.fromhex(data)))
    return out.returncode, frames, summary, out.stderr


def summary_field(summary, key):
    if key == "format":  # two words ("Vector BLF")
        rest = summary.split("format=", 1)
        return rest[1].split(" frames=")[0] if len(rest) == 2 else None
    if key == "io_error":  # the last field of its line: the rest of it
        rest = summary.split(" io_error=", 1)
        return rest[1].split(" fraction_read ")[0] if len(rest) == 2 else None
    for part in summary.split():
        if part.startswith(key + "="):
            return part[len(key) + 1:]
    return None


def _python_can_frame(m):
    bus = f"can{max(m.channel, 0) if isinstance(m.channel, int) else 0}"
    ns = round(m.timestamp * NS)
    if m.is_error_frame:
        return frame(ns, bus, error=True)
    if m.is_remote_frame:
        return frame(ns, bus, m.arbitration_id, m.is_extended_id, remote=True, length=min(m.dlc, 8))
    return frame(ns, bus, m.arbitration_id, m.is_extended_id, fd=m.is_fd, brs=m.bitrate_switch,
                 esi=m.error_state_indicator, data=bytes(m.data))


def python_can_read(path, kind):
    """Frames of python-can's reader of a BLF or ASC file (gzip ASC decompressed first)."""
    import can
    if kind == "blf":
        reader = can.BLFReader(path)
    else:
        opener = gzip.open if open(path, "rb").read(2) == b"\x1f\x8b" else open
        reader = can.ASCReader(opener(path, "rt"), relative_timestamp=False)
    with reader as r:
        return [_python_can_frame(m) for m in r]


def _start_ns(mdf):
    abs_time = getattr(mdf.header, "abs_time", None)
    if abs_time is not None:
        return int(abs_time)
    return round(mdf.header.start_time.timestamp() * NS)


def asammdf_read(path):
    """Frames of the CAN bus-logging groups of an MF4 file, as asammdf reads them."""
    from asammdf import MDF
    mdf = MDF(path)
    try:
        start = _start_ns(mdf)
        frames = []
        for gi, group in enumerate(mdf.groups):
            names = {ch.name for ch in group.channels}
            for head in ("CAN_DataFrame", "CAN_RemoteFrame", "CAN_ErrorFrame"):
                if any(n.startswith(head + ".") for n in names):
                    frames += _asammdf_group(mdf, gi, head, names, start)
                    break
        return frames
    finally:
        mdf.close()


def _asammdf_group(mdf, gi, head, names, start):
    def get(leaf):
        name = f"{head}.{leaf}"
        return mdf.get(name, group=gi).samples if name in names else None

    times = mdf.get_master(gi)
    bus, cid, ide, dlc = get("BusChannel"), get("ID"), get("IDE"), get("DLC")
    length, data, edl, brs, esi = get("DataLength"), get("DataBytes"), get("EDL"), get("BRS"), get("ESI")
    out = []
    for i, t in enumerate(times):
        ns = start + round(float(t) * NS)
        b = f"can{int(bus[i]) if bus is not None else 0}"
        if head == "CAN_ErrorFrame":
            out.append(frame(ns, b, error=True))
            continue
        raw = int(cid[i])
        ext = bool(ide is not None and ide[i]) or bool(raw & 0x80000000)
        fd = bool(edl is not None and edl[i])
        d = int(dlc[i]) & 0xF if dlc is not None else None
        if head == "CAN_RemoteFrame":
            out.append(frame(ns, b, raw & 0x1FFFFFFF, ext, remote=True, length=min(d or 0, 8)))
            continue
        n = int(length[i]) if length is not None else (8 if d is None else FD_LENGTHS[d] if fd else min(d, 8))
        payload = bytes(bytearray(data[i][:n])) if data is not None else b""
        out.append(frame(ns, b, raw & 0x1FFFFFFF, ext, fd=fd, brs=bool(brs is not None and brs[i]),
                         esi=bool(esi is not None and esi[i]), data=payload, length=n))
    return out


def _same(a, b, tolerance_ns):
    if abs(a["ns"] - b["ns"]) > tolerance_ns or a["bus"] != b["bus"] or a["flags"] != b["flags"]:
        return False
    if a["flags"] & 4:
        return True
    same_data = a["flags"] & 2 or a["data"][:a["len"]] == b["data"][:b["len"]]  # remote: no data
    return a["id"] == b["id"] and a["len"] == b["len"] and same_data


def compare(ours, theirs, tolerance_ns, window=16):
    """Matches frames in time order (each of the oracle's valid frames to one of ours within a
    window of neighbours). Returns dict(equal, total, invalid, unmatched, extra, extra_errors,
    worst_ns): total = the oracle's valid frames, invalid = the oracle's frames no CAN bus
    carries, unmatched = the oracle's valid frames ndsid lacks or reads differently, extra =
    ndsid's frames the oracle does not have (extra_errors: how many of them are error frames)."""
    valid = [f for f in theirs if valid_can(f)]
    key = lambda f: (f["ns"], f["bus"], f["id"])  # noqa: E731
    a, b = sorted(ours, key=key), sorted(valid, key=key)
    used = [False] * len(a)
    equal, worst, unmatched = 0, 0, []
    j0 = 0
    for f in b:
        while j0 < len(a) and (used[j0] or a[j0]["ns"] < f["ns"] - tolerance_ns - 1):
            j0 += 1
        hit = None
        for j in range(max(0, j0 - window), min(len(a), j0 + window)):
            if not used[j] and _same(a[j], f, tolerance_ns):
                hit = j
                break
        if hit is None:
            unmatched.append(f)
            continue
        used[hit] = True
        equal += 1
        worst = max(worst, abs(a[hit]["ns"] - f["ns"]))
    extra = [a[j] for j in range(len(a)) if not used[j]]
    return dict(equal=equal, total=len(valid), invalid=len(theirs) - len(valid), unmatched=unmatched, extra=extra,
                extra_errors=sum(1 for f in extra if f["flags"] & 4), worst_ns=worst)


def describe(f):
    if f["flags"] & 4:
        return f"{f['ns']} {f['bus']} error frame"
    return f"{f['ns']} {f['bus']} {f['id']:X} flags={f['flags']} len={f['len']} {f['data'].hex()}"
