#!/usr/bin/env python3
"""Our ASC, BLF and MF4 readers against independent writers and readers.

Frames of a bundled candump log (a slice of replay/clean/drive.log.gz, re-based to a whole
millisecond, plus a remote frame, an error frame, CAN FD frames and a second bus) are written
  - as Vector ASC and BLF by python-can (ASCWriter, BLFWriter),
  - as ASAM MF4 bus logging by python-can's MF4Writer, which uses asammdf (three compression
    levels: plain DT, deflate DZ, transposed deflate DZ),
and read back by our reader (frame_log_dump). Each frame must equal the original: id,
extended flag, remote/error/FD flags, length, data, bus name, timestamp within the format's
resolution (ASC 1 us; BLF and MF4 0.5 us, as python-can hands the writers
float64 epoch seconds, whose step at 1.7e9 s is 240 ns). Timestamps are also checked
against python-can's own reader of the same file. Then layouts the writers do not produce, made from their
files (BLF object header version 2 and 10 us times, one container or stored ones; unfinalised
MF4 as a logger leaves it), each against python-can or asammdf frame for frame. Then `ndsid
decode` on every file must print the same CSV as on the candump original, and cut files must
make decode exit non-zero.
Exit 77 (skip) when python-can or asammdf are missing.
"""
import argparse
import gzip
import os
import subprocess
import sys
import tempfile
import time

os.environ["TZ"] = "UTC"  # ASC/MF4 dates carry no zone: our reader reads them as UTC
time.tzset()

try:
    import can
    from can.io.mf4 import MF4Writer
    import asammdf  # noqa: F401  (MF4Writer needs it)
except ImportError as e:  # pragma: no cover
    print(f"skip: {e}")
    sys.exit(77)

NS = 1_000_000_000

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import log_oracles  # noqa: E402
import make_blf_variants  # noqa: E402
import make_unfinalised_mf4  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "fuzz"))
import make_mf4_logger_seeds  # noqa: E402


def read_slice(path, count):
    """(ns, bus, id, extended, data) of the first `count` frames, re-based to a whole ms."""
    frames = []
    with gzip.open(path, "rt") as f:
        for line in f:
            if len(frames) >= count:
                break
            ts, bus, token = line.split()
            sec, frac = ts[1:-1].split(".")
            ns = int(sec) * NS + int(frac.ljust(9, "0"))
            cid, data = token.split("#")
            frames.append([ns, bus, int(cid, 16), len(cid) == 8, bytes.fromhex(data)])
    shift = frames[0][0] % 1_000_000
    for fr in frames:
        fr[0] -= shift
    return frames


def add_special_frames(frames):
    """Remote, error, CAN FD (with and without BRS) frames and frames on a second bus."""
    out = []
    for i, fr in enumerate(frames):
        out.append(dict(ns=fr[0], bus=fr[1], id=fr[2], ext=fr[3], data=fr[4], remote=False, error=False,
                        fd=False, brs=False))
        t = fr[0] + 137_000  # between this frame and the next (frames are >= 0.2 ms apart? no: keep order by sort)
        if i == 10:
            out.append(dict(ns=t, bus="can0", id=0x321, ext=False, data=b"", remote=True, error=False, fd=False,
                            brs=False, dlc=4))
        if i == 20:
            out.append(dict(ns=t, bus="can0", id=0, ext=False, data=b"", remote=False, error=True, fd=False,
                            brs=False))
        if i == 30:
            out.append(dict(ns=t, bus="can1", id=0x1ABCDE, ext=True, data=bytes(range(12)), remote=False,
                            error=False, fd=True, brs=True))
        if i == 40:
            out.append(dict(ns=t, bus="can1", id=0x7FF, ext=False, data=bytes(range(64)), remote=False,
                            error=False, fd=True, brs=False))
        if i == 50:
            out.append(dict(ns=t, bus="can1", id=0x123, ext=False, data=b"\x01\x02", remote=False, error=False,
                            fd=False, brs=False))
    out.sort(key=lambda f: f["ns"])
    return out


def to_message(f):
    return can.Message(timestamp=f["ns"] / NS, arbitration_id=f["id"], is_extended_id=f["ext"],
                       is_remote_frame=f["remote"], is_error_frame=f["error"], is_fd=f["fd"],
                       bitrate_switch=f["brs"], data=f["data"], dlc=f.get("dlc", len(f["data"])),
                       channel=int(f["bus"][3:]))


def write_candump(path, frames):
    with open(path, "w") as out:
        for f in frames:
            if f["error"] or f["remote"] or f["fd"] or f["bus"] != "can0":
                continue  # the decode comparison uses the plain data frames of can0
            sec, ns = divmod(f["ns"], NS)
            cid = f"{f['id']:08X}" if f["ext"] else f"{f['id']:03X}"
            out.write(f"({sec}.{ns // 1000:06d}) {f['bus']} {cid}#{f['data'].hex().upper()}\n")


def write_with(writer, frames):
    for f in frames:
        writer.on_message_received(to_message(f))
    writer.stop()


def dump(tool, path):
    """(exit code, frames, summary, stderr) of can_frame_log_dump (log_oracles.ndsid_read)."""
    return log_oracles.ndsid_read(tool, path)


def expected_flags(f):
    flags = 0
    if f["error"]:
        return 4
    if f["ext"]:
        flags |= 1
    if f["remote"]:
        flags |= 2
    if f["fd"]:
        flags |= 8 | (16 if f["brs"] else 0)
    return flags


def compare(name, frames, got, tolerance_ns, failures):
    if len(got) != len(frames):
        failures.append(f"{name}: {len(got)} frames, expected {len(frames)}")
        return
    worst = 0
    for i, (e, g) in enumerate(zip(frames, got)):
        worst = max(worst, abs(g["ns"] - e["ns"]))
        problems = []
        if abs(g["ns"] - e["ns"]) > tolerance_ns:
            problems.append(f"time {g['ns']} vs {e['ns']}")
        if g["bus"] != e["bus"]:
            problems.append(f"bus {g['bus']} vs {e['bus']}")
        if g["flags"] != expected_flags(e):
            problems.append(f"flags {g['flags']} vs {expected_flags(e)}")
        if not e["error"]:
            exp_len = e.get("dlc", len(e["data"])) if e["remote"] else len(e["data"])
            if g["id"] != e["id"] or g["len"] != exp_len or (not e["remote"] and g["data"] != e["data"]):
                problems.append(f"id/len/data {g['id']:X}/{g['len']}/{g['data'].hex()} vs "
                                f"{e['id']:X}/{exp_len}/{e['data'].hex()}")
        if problems:
            failures.append(f"{name}: frame {i}: " + "; ".join(problems))
            if len(failures) > 20:
                return
    print(f"{name}: {len(got)} frames equal, worst time difference {worst} ns (allowed {tolerance_ns})")


def python_can_times(path, reader_cls, **kw):
    with reader_cls(path, **kw) as r:
        return [round(m.timestamp * NS) for m in r]


def decode_csv(ndsid, dbc, path):
    out = subprocess.run([ndsid, "decode", "--dbc", dbc, "--log", path], capture_output=True, text=True)
    return out.returncode, out.stdout, out.stderr


def check_variants(dump, files, d, failures):
    """Layouts python-can's writers do not produce, made from their files: BLF with object
    header version 2, times in 10 us, CAN_MESSAGE2, in one container or in stored containers
    cut every 1000 bytes (make_blf_variants.py); MF4 as a logger that lost power leaves it
    (make_unfinalised_mf4.py: cycle counts and DT lengths unwritten, cut mid-record; DZ
    blocks under a DL whose last link was not written); the CANedge layouts written block by
    block (tests/fuzz/make_mf4_logger_seeds.py: VLSD channel group, virtual channels, tables).
    Each against its oracle (python-can, asammdf), frame for frame."""
    def write(data):
        return lambda p: open(p, "wb").write(data)

    variants = {  # name: (oracle, make(path), frames at least)
        "blf-v2-10us-one-container": ("blf", lambda p: make_blf_variants.write_variant(files["blf"], p), 20000),
        "blf-v2-10us-stored-1000": ("blf", lambda p: make_blf_variants.write_variant(files["blf"], p, stored=True), 20000),
        "mf4-unfinalised-dt-cut": ("mf4", lambda p: make_unfinalised_mf4.unfinalise(files["mf4-0"], p), 10000),
        "mf4-unfinalised-dz": ("mf4", lambda p: make_unfinalised_mf4.unfinalise(files["mf4-1"], p), 20000),
        "mf4-unfinalised-dz-dl": ("mf4", lambda p: make_unfinalised_mf4.unfinalise(files["mf4-2"], p, dl=True), 20000),
        "mf4-logger-vlsd-group": ("mf4", write(make_mf4_logger_seeds.first_firmware()), 7),
        "mf4-logger-virtual-channels": ("mf4", write(make_mf4_logger_seeds.newer_firmware()), 4),
    }
    for name, (kind, make, least) in variants.items():
        path = os.path.join(d, name)
        make(path)
        rc, ours, summary, err = log_oracles.ndsid_read(dump, path)
        theirs = log_oracles.asammdf_read(path) if kind == "mf4" else log_oracles.python_can_read(path, kind)
        r = log_oracles.compare(ours, theirs, 1000)
        if rc != 0 or "malformed=0" not in summary or r["unmatched"] or r["extra"] or r["invalid"] or r["total"] < least:
            failures.append(f"{name}: exit {rc} {summary} {err.strip()[:200]}; {r['equal']} / {r['total']} equal, "
                            f"{len(r['extra'])} extra, e.g. {[log_oracles.describe(f) for f in r['unmatched'][:2]]}")
        else:
            print(f"{name}: {r['equal']} / {r['total']} frames equal to {'asammdf' if kind == 'mf4' else 'python-can'}, "
                  f"worst time difference {r['worst_ns']} ns")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dump", required=True)
    ap.add_argument("--ndsid", required=True)
    ap.add_argument("--dbc", required=True)
    ap.add_argument("--log", required=True)
    ap.add_argument("--frames", type=int, default=20000)
    a = ap.parse_args()
    failures = []
    frames = add_special_frames(read_slice(a.log, a.frames))
    with tempfile.TemporaryDirectory() as d:
        files = {"asc": os.path.join(d, "x.asc"), "blf": os.path.join(d, "x.blf")}
        write_with(can.ASCWriter(files["asc"]), frames)
        write_with(can.BLFWriter(files["blf"]), frames)
        for level in (0, 1, 2):
            files[f"mf4-{level}"] = os.path.join(d, f"x{level}.mf4")
            write_with(MF4Writer(files[f"mf4-{level}"], compression_level=level), frames)
        # python-can hands its writers float64 epoch seconds (ulp 240 ns at 1.7e9 s); ASC keeps us
        tolerance = {"asc": 1000, "blf": 500, "mf4-0": 500, "mf4-1": 500, "mf4-2": 500}
        readers = {"asc": (can.ASCReader, {"relative_timestamp": False}), "blf": (can.BLFReader, {}),
                   "mf4-0": (can.io.mf4.MF4Reader, {}), "mf4-1": (can.io.mf4.MF4Reader, {}),
                   "mf4-2": (can.io.mf4.MF4Reader, {})}
        for name, path in files.items():
            rc, got, summary, err = dump(a.dump, path)
            print(f"{name}: {summary}")
            if rc != 0 or "malformed=0" not in summary:
                failures.append(f"{name}: exit {rc}, {summary} {err.strip()}")
            # progress: rises to the whole file; unknown (-1) for MF4 (interleaved data blocks)
            want_last = "last=-1.000000" if name.startswith("mf4") else "last=1.000000"
            if "monotonic=1" not in summary or want_last not in summary:
                failures.append(f"{name}: fraction_read must end at {want_last}: {summary}")
            compare(name, frames, got, tolerance[name], failures)
            # python-can's reader of the same file: the same times (its float seconds: 0.5 us)
            cls, kw = readers[name]
            theirs = python_can_times(path, cls, **kw)
            if name.startswith("mf4"):  # python-can's MF4Reader yields group by group: compare as sets
                theirs, ours = sorted(theirs), sorted(g["ns"] for g in got)
            else:
                ours = [g["ns"] for g in got]
            if name == "asc" and theirs:
                # python-can writes the start date's milliseconds unpadded (".4" for 4 ms) and
                # its reader takes ".4" as 400 ms; we read it as 4 ms (checked against the
                # original above). Compare the times relative to the first frame.
                theirs = [t - theirs[0] for t in theirs]
                ours = [t - ours[0] for t in ours]
            if len(theirs) != len(ours):
                failures.append(f"{name}: python-can reads {len(theirs)} frames, we {len(ours)}")
            else:
                worst = max(abs(x - y) for x, y in zip(theirs, ours))
                print(f"{name}: python-can's reader agrees within {worst} ns")
                if worst > 1000:
                    failures.append(f"{name}: python-can's times differ by up to {worst} ns")

        check_variants(a.dump, files, d, failures)

        # ndsid decode: the same CSV as on the candump original
        original = os.path.join(d, "x.log")
        write_candump(original, frames)
        rc, want, err = decode_csv(a.ndsid, a.dbc, original)
        if rc != 0:
            failures.append(f"decode candump: exit {rc}: {err}")
        rows = want.count("\n") - 1
        for name, path in files.items():
            rc, csv, err = decode_csv(a.ndsid, a.dbc, path)
            # the extra frames (can1, FD, remote, error) decode to nothing in this DBC, or to
            # rows with their own times: keep the rows of the can0 data frames' times only
            keep = set(line.split(",", 1)[0] for line in want.splitlines()[1:])
            lines = [want.splitlines()[0]] + [x for x in csv.splitlines()[1:] if x.split(",", 1)[0] in keep]
            if rc != 0 or "\n".join(lines) != want.rstrip("\n"):
                diff = [f"{x} | {y}" for x, y in zip(lines, want.splitlines()) if x != y][:3]
                failures.append(f"decode {name}: exit {rc}, CSV differs from the candump original: {diff} {err[-300:]}")
            else:
                print(f"decode {name}: {rows} rows identical to the candump original")

        # cut files: reading stops with a located message and decode exits non-zero
        for name in ("blf", "mf4-0", "mf4-2"):
            data = open(files[name], "rb").read()
            cut = os.path.join(d, f"cut-{name}")
            with open(cut, "wb") as f:
                f.write(data[: len(data) * 2 // 3] if name == "blf" else data[: len(data) // 3])
            rc, got, summary, err = dump(a.dump, cut)
            rc2, _, err2 = decode_csv(a.ndsid, a.dbc, cut)
            print(f"cut {name}: dump exit {rc} ({summary or err.strip()}), decode exit {rc2}")
            if rc == 0 or rc2 == 0:
                failures.append(f"cut {name}: accepted silently (dump exit {rc}, decode exit {rc2}): {summary} {err2}")

        # replay (the path of compare, diagnose and study too): a cut file stops it with the
        # located reason, an unsupported file is refused before any work (exit 78)
        config = os.path.join(os.path.dirname(a.dbc), "..", "config", "example_vehicle.yaml")
        pcap = os.path.join(d, "capture.pcap")
        with open(pcap, "wb") as f:
            f.write(b"\xd4\xc3\xb2\xa1" + bytes(40))
        for path, want_rc, want_text in ((os.path.join(d, "cut-blf"), 1, "reading stopped"),
                                         (pcap, 78, "looks like a pcap capture")):
            out = subprocess.run([a.ndsid, "replay", "--config", config, "--log", files["blf"], path,
                                  "--report", os.path.join(d, "report")], capture_output=True, text=True)
            print(f"replay with {os.path.basename(path)}: exit {out.returncode}")
            if out.returncode != want_rc or want_text not in out.stderr or path not in out.stderr:
                failures.append(f"replay {path}: exit {out.returncode} (want {want_rc}, '{want_text}'): {out.stderr[-400:]}")

    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
