#!/usr/bin/env python3
"""ndsid's log readers against python-can (BLF, ASC) and asammdf (MF4) on log files other
tools wrote: every *.blf, *.asc, *.asc.gz and *.mf4 under a folder (recursively), frame for
frame (log_oracles.py says how). The files are not part of the repository; point the test
at them with the CMake cache path NDSID_LOG_SAMPLES_DIR (or --samples / the environment
variable of the same name). Without them the test is skipped (exit 77) with a message.

Prints one table row per file: file, format as ndsid read it, frames equal / the oracle's
valid frames, and notes (records the oracle yields that no bus carries, extra error frames,
where reading stopped). Exit 1 when a file disagrees beyond the rules of log_oracles.py,
or when ndsid takes a file whose records are mostly malformed as complete.
"""
import argparse
import os
import sys
import time

os.environ["TZ"] = "UTC"  # ASC dates carry no zone: ndsid and python-can read them as UTC
time.tzset()
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import log_oracles  # noqa: E402

TOLERANCE_NS = 1000  # python-can and asammdf hand out float64 seconds (ulp 477 ns at 2.5e9 s)


def kind_of(path):
    name = path.lower()
    if name.endswith(".blf"):
        return "blf"
    if name.endswith(".asc") or name.endswith(".asc.gz"):
        return "asc"
    if name.endswith(".mf4"):
        return "mf4"
    return None


def sample_files(root):
    for folder, _, names in sorted(os.walk(root)):
        for name in sorted(names):
            path = os.path.join(folder, name)
            if kind_of(path) and os.path.getsize(path) > 0:
                yield path


def oracle(path, kind):
    try:
        if kind == "mf4":
            return log_oracles.asammdf_read(path), None
        return log_oracles.python_can_read(path, kind), None
    except Exception as e:  # noqa: BLE001  (the oracle's own refusal is a result too)
        return [], f"{type(e).__name__}: {e}"


def check(dump, path, kind, root):
    """(row, ok, comparison) for one file."""
    rc, ours, summary, err = log_oracles.ndsid_read(dump, path)
    theirs, oracle_error = oracle(path, kind)
    r = log_oracles.compare(ours, theirs, TOLERANCE_NS)
    malformed = int(log_oracles.summary_field(summary, "malformed") or 0)
    io_error = log_oracles.summary_field(summary, "io_error")
    notes, ok = [], True
    if rc not in (0, 65):
        notes.append(f"ndsid refuses the file (exit {rc}): {err.strip()[:160]}")
        ok = not theirs  # refused, and the oracle reads no frames either
    if oracle_error:  # nothing to compare with: say what ndsid made of it
        notes.append(f"the oracle fails ({oracle_error[:80]}); ndsid reads {len(ours)} frames, rejects {malformed} records")
        r = log_oracles.compare([], [], TOLERANCE_NS)
    if r["invalid"]:
        notes.append(f"the oracle yields {r['invalid']} records no CAN bus carries; ndsid rejects {malformed}")
        ok = ok and malformed >= r["invalid"]
    if r["unmatched"]:
        notes.append(f"{len(r['unmatched'])} differ, e.g. {log_oracles.describe(r['unmatched'][0])}")
        ok = False
    extra_other = len(r["extra"]) - r["extra_errors"]
    if r["extra_errors"]:
        notes.append(f"ndsid also reads {r['extra_errors']} error objects the oracle skips")
    if extra_other:
        notes.append(f"ndsid reads {extra_other} frames the oracle has not, e.g. {log_oracles.describe(r['extra'][0])}")
        ok = False
    if rc == 65:
        notes.append(f"reading stopped: {io_error}")
    elif malformed > len(ours):
        notes.append("most records malformed but no io_error")
        ok = False
    fmt = log_oracles.summary_field(summary, "format") or "-"
    row = f"| {os.path.relpath(path, root)} | {fmt} | {r['equal']} / {r['total']} | {'; '.join(notes) or '-'} |"
    return row, ok, r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dump", required=True, help="can_frame_log_dump")
    ap.add_argument("--samples", default=os.environ.get("NDSID_LOG_SAMPLES_DIR", ""))
    a = ap.parse_args()
    a.samples = a.samples or os.environ.get("NDSID_LOG_SAMPLES_DIR", "")
    if not a.samples or not os.path.isdir(a.samples):
        print("skip: no log samples folder (set the CMake cache path NDSID_LOG_SAMPLES_DIR, or "
              f"NDSID_LOG_SAMPLES_DIR, to a folder of BLF / ASC / MF4 files other tools wrote; got '{a.samples}')")
        return 77
    try:
        import asammdf  # noqa: F401
        import can  # noqa: F401
    except ImportError as e:
        print(f"skip: {e}")
        return 77
    print("| file | format | frames equal / total | notes |")
    print("|---|---|---|---|")
    failed, files, equal, total = 0, 0, 0, 0
    for path in sample_files(a.samples):
        row, ok, r = check(a.dump, path, kind_of(path), a.samples)
        files += 1
        equal += r["equal"]
        total += r["total"]
        print(row + ("" if ok else "  FAIL"))
        failed += 0 if ok else 1
    print(f"{files} files, {equal} / {total} frames equal, {failed} files disagree")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
