#!/usr/bin/env python3
"""`ndsid replay` prints the figures of its estimate.json rounded, never cut (the validation
RMSE used to be cut to 6 characters: 0.111255 -> "0.1112"; the steady-state EG likewise).
Usage: replay_summary_test.py NDSID_EXE SOURCE_DIR OUT_DIR"""
import json
import math
import os
import re
import subprocess
import sys

exe, src, out = sys.argv[1], sys.argv[2], sys.argv[3]
log = os.path.join(src, "replay", "steer_offset", "drive.log.gz")
run = subprocess.run([exe, "replay", "--log", log, "--final-only", "--report", out],
                     capture_output=True, text=True)
print(run.stdout)
if run.returncode not in (0, 1):
    print(run.stderr[-2000:])
    sys.exit(1)
j = json.load(open(os.path.join(out, "steer_offset-drive", "estimate.json")))
errors = []
expect_rmse = f"RMSE train {j['rmse_train_mps2']:.4f} m/s^2, validation {j['rmse_validation_mps2']:.4f} m/s^2"
if expect_rmse not in run.stdout:
    errors.append(f"expected '{expect_rmse}'")
eg_ss = j["steady_state"]["eg_rad_per_mps2"] * 180 / math.pi * 9.81
expect_ss = f"steady-state check: EG = {eg_ss:.4f} deg/g"
if j["steady_state"]["valid"] and expect_ss not in run.stdout:
    errors.append(f"expected '{expect_ss}'")
if errors:
    print("\n".join(errors))
    sys.exit(1)
print("summary figures are the JSON's, rounded")
