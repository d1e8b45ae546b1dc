#!/usr/bin/env python3
"""Runs the built `ndsid decode` on a small candump log and checks its CSV and its stderr
summary against cantools' decode of the same frames (the oracle of cantools_crosscheck.py).

Cases: no filter; --bus/--messages/--signals together; an unknown message name (exit 78).
"""

import argparse
import math
import os
import re
import subprocess
import sys

import cantools

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cantools_crosscheck import Oracle  # noqa: E402

LINE = re.compile(r"^\((\d+\.\d{6})\) (\S+) ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})#(R\d?|[0-9A-Fa-f]*)$")


def expected_output(db, log, bus=None, messages=None, signals=None):
    """(rows {(t, message): {signal: value}}, counts) as `ndsid decode` should give them."""
    oracles = {(m.frame_id, m.is_extended_frame): Oracle(m) for m in db.messages}
    rows, counts = {}, dict(frames=0, decoded=0, unknown=0, short=0, not_data=0, other_bus=0, malformed=0)
    with open(log) as f:
        for line in f:
            m = LINE.match(line.strip())
            if not m:
                counts["malformed"] += 1
                continue
            t, frame_bus, id_text, data_text = m.groups()
            counts["frames"] += 1
            if bus and frame_bus != bus:
                counts["other_bus"] += 1
                continue
            if data_text.startswith("R"):
                counts["not_data"] += 1
                continue
            oracle = oracles.get((int(id_text, 16), len(id_text) == 8))
            if oracle is None or (messages and oracle.msg.name not in messages):
                counts["unknown"] += 1
                continue
            values, too_short = oracle.decode(bytes.fromhex(data_text))
            values = {k: v for k, v in values.items() if not signals or k in signals}
            counts["short" if too_short else "decoded"] += 1
            if values:
                rows[(t, oracle.msg.name)] = values
    return rows, counts


def run(ndsid, args):
    return subprocess.run([ndsid, "decode", *args], capture_output=True, text=True)


def check(ndsid, db, dbc, log, extra, bus=None, messages=None, signals=None):
    failures = []
    out = run(ndsid, ["--dbc", dbc, "--log", log, *extra])
    if out.returncode != 0:
        return [f"{extra}: exit {out.returncode}: {out.stderr}"]
    lines = out.stdout.splitlines()
    if not lines or lines[0] != "t,message,signal,value":
        return [f"{extra}: missing CSV header: {lines[:1]}"]
    got = {}
    for line in lines[1:]:
        t, message, signal, value = line.split(",")
        got.setdefault((t, message), {})[signal] = float(value)
    rows, counts = expected_output(db, log, bus, messages, signals)
    if set(got) != set(rows):
        failures.append(f"{extra}: frames ours-only {sorted(set(got) - set(rows))} cantools-only {sorted(set(rows) - set(got))}")
    for key in set(got) & set(rows):
        if set(got[key]) != set(rows[key]):
            failures.append(f"{extra}: {key}: signals ours {sorted(got[key])} cantools {sorted(rows[key])}")
        for sig in set(got[key]) & set(rows[key]):
            # %.10g on our side: 10 significant digits.
            if not math.isclose(got[key][sig], float(rows[key][sig]), rel_tol=1e-9, abs_tol=1e-12):
                failures.append(f"{extra}: {key} {sig}: ours {got[key][sig]} cantools {rows[key][sig]}")
    summary = (f"{counts['frames']} frames, {counts['decoded']} decoded, "
               f"{sum(len(v) for v in rows.values())} values; {counts['unknown']} unknown id, "
               f"{counts['short']} too short, {counts['not_data']} remote/error, "
               f"{counts['other_bus']} on other buses, {counts['malformed']} malformed lines")
    if summary not in out.stderr:
        failures.append(f"{extra}: stderr summary\n  expected: {summary}\n  got: {out.stderr}")
    print(f"{' '.join(extra) or '(no filter)'}: {len(lines) - 1} rows, summary: {summary}")
    return failures


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ndsid", required=True)
    ap.add_argument("--dbc", required=True)
    ap.add_argument("--log", required=True)
    a = ap.parse_args()
    db = cantools.database.load_file(a.dbc, strict=False)

    failures = check(a.ndsid, db, a.dbc, a.log, [])
    failures += check(a.ndsid, db, a.dbc, a.log,
                      ["--bus", "can0", "--messages", "VEHICLE_SPEED,VEHICLE_STATUS",
                       "--signals", "VehicleSpeed,StatusPage,Odometer"],
                      bus="can0", messages={"VEHICLE_SPEED", "VEHICLE_STATUS"},
                      signals={"VehicleSpeed", "StatusPage", "Odometer"})
    bad = run(a.ndsid, ["--dbc", a.dbc, "--log", a.log, "--messages", "NO_SUCH_MESSAGE"])
    if bad.returncode != 78 or "NO_SUCH_MESSAGE" not in bad.stderr:
        failures.append(f"unknown --messages name: exit {bad.returncode} (expected 78), stderr {bad.stderr!r}")
    for f in failures:
        print("FAIL: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
