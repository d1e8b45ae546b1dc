#!/usr/bin/env python3
"""`ndsid study` on the bundled clean drives (4 drives, 0.5 gated h, truth known).

Catches: a study that mixes validation drives into the sets, loses a set size, or whose
all-data estimate is no better than a single drive's. Exit 0 pass, 1 fail, 77 skip."""
import csv
import os
import statistics
import subprocess
import sys
import tempfile

ndsid, source = sys.argv[1], sys.argv[2]
log = os.path.join(source, "replay", "clean", "drive.log.gz")
truth_file = os.path.join(source, "replay", "clean", "truth.yaml")
if not os.path.exists(log):
    print(f"skipped: {log} not found")
    sys.exit(77)
truth = None
for line in open(truth_file):
    if line.strip().startswith("self_steer_gradient_deg_per_g:"):
        truth = float(line.split(":")[1].split("#")[0])
with tempfile.TemporaryDirectory() as out:
    run = subprocess.run([ndsid, "study", "--log", log, "--hours", "0.06,0.12",  # a comma list, as the README writes it
                          "--truth", truth_file,
                          "--validation-fraction", "0.25", "--out", out], capture_output=True, text=True)
    print(run.stdout)
    if run.returncode != 0:
        print(run.stderr[-2000:])
        sys.exit(1)
    rows = list(csv.DictReader(open(os.path.join(out, "study.csv"))))
failures = []
kinds = [r["set"] for r in rows]
singles = [r for r in rows if r["set"] == "SD" and r["valid"] == "1"]
alls = [r for r in rows if r["set"] == "AD"]
if len(singles) != 3:  # 4 drives, one held out for validation
    failures.append(f"expected 3 single-drive sets, got {len(singles)}")
for size in ("H0.06", "H0.12"):
    if size not in kinds:
        failures.append(f"no {size} sets (--hours 0.06,0.12)")
if len(alls) != 1 or alls[0]["valid"] != "1":
    failures.append("expected one valid all-data set")
else:
    ad = alls[0]
    eg, se = float(ad["eg_deg_per_g"]), float(ad["eg_se_deg_per_g"])
    if abs(eg - truth) / truth > 0.05:
        failures.append(f"all-data EG {eg:.4f} more than 5 % from the truth {truth:.4f}")
    if not se < statistics.median(float(r["eg_se_deg_per_g"]) for r in singles):
        failures.append("all-data sigma not below the single drives' median")
    if sum(float(r["hours"]) for r in singles) > float(ad["hours"]) + 1e-6:
        failures.append("single drives hold more hours than all data together")
if "truth EG" not in run.stdout or "EG median" not in run.stdout:
    failures.append("terminal table or truth line missing")
for f in failures:
    print("FAIL:", f)
print(f"{len(rows)} sets checked, {len(failures)} failures")
sys.exit(1 if failures else 0)
