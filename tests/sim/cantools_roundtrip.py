#!/usr/bin/env python3
"""Independent oracle: cantools decodes the candump log `ndsid simulate` wrote, and every decoded
steering / lateral-acceleration / yaw-rate / speed value must equal the simulated measured signal
(signals.csv) within half a DBC resolution step. Catches encoder bugs our own decoder would share
(byte order, sign, factor) and ISO sign flips.

usage: cantools_roundtrip.py SOURCE_DIR WORK_DIR   (env NDSID_BIN: the ndsid binary)
"""
import csv
import gzip
import os
import re
import subprocess
import sys

import cantools
import numpy as np

src, work = sys.argv[1], sys.argv[2]
os.makedirs(work, exist_ok=True)
subprocess.run([os.environ["NDSID_BIN"], "simulate", "--drives", "1", "--seed", "12", "--gzip", "--signals-csv",
                "--dbc", os.path.join(src, "dbc", "ndsid_example.dbc"), "--out", work], check=True)
db = cantools.database.load_file(os.path.join(src, "dbc", "ndsid_example.dbc"))

rows = list(csv.DictReader(open(os.path.join(work, "signals.csv"))))
t0 = float(rows[0]["epoch_s"])
expected = {
    ("STEERING_SENSOR", "SteeringWheelAngle"): (np.array([float(r["steer_sw_meas_deg"]) for r in rows]), 0.1),
    ("ESP_DYNAMICS", "LateralAcceleration"): (np.array([float(r["a_y_meas_mps2"]) for r in rows]), 0.01),
    ("ESP_DYNAMICS", "YawRate"): (np.array([float(r["yaw_rate_meas_degps"]) for r in rows]), 0.01),
    ("VEHICLE_SPEED", "VehicleSpeed"): (np.array([float(r["speed_meas_kph"]) for r in rows]), 1 / 256),
}
valid = np.array([int(r["valid"]) for r in rows])

line_re = re.compile(r"^\((\d+\.\d+)\) (\S+) ([0-9A-F]+)#([0-9A-F]*)$")
first_tick = {}
counts = {}
max_err = {k: 0.0 for k in expected}
n_cmp = {k: 0 for k in expected}
with gzip.open(os.path.join(work, "drive.log.gz"), "rt") as f:
    for line in f:
        m = line_re.match(line.strip())
        assert m, line
        ts, _, ident, data = float(m.group(1)), m.group(2), m.group(3), bytes.fromhex(m.group(4))
        frame_id = int(ident, 16)
        msg = db.get_message_by_frame_id(frame_id)
        name = msg.name
        k = counts.get(name, 0)
        counts[name] = k + 1
        if k == 0:
            first_tick[name] = int((ts - t0) * 100 + 1e-6)  # the message's tick offset (phase < 10 ms)
        i = first_tick[name] + k * int(round(msg.cycle_time / 10))
        decoded = db.decode_message(frame_id, data, decode_choices=False)
        for (mname, sname), (values, lsb) in expected.items():
            if mname != name:
                continue
            if sname != "VehicleSpeed" and not valid[i]:
                continue
            err = abs(decoded[sname] - values[i])
            assert err <= 0.5 * lsb + 1e-6, f"{sname} sample {i}: cantools {decoded[sname]} vs simulated {values[i]}"
            max_err[(mname, sname)] = max(max_err[(mname, sname)], err)
            n_cmp[(mname, sname)] += 1
for key in expected:
    assert n_cmp[key] > 1000, f"too few comparisons for {key}"
    print(f"{key[0]}.{key[1]}: {n_cmp[key]} frames, max |cantools - simulated| = {max_err[key]:.5f} "
          f"(half LSB {0.5 * expected[key][1]:.5f})")
if "STEERING_SENSOR" in counts:
    print("cantools round trip OK")
