#!/usr/bin/env python3
"""`ndsid compare`'s signed view on an effect outside the model library, against a clean twin.

The simulator's rear_stiffness_speed_pct (the rear axle stiffer with speed, as downforce makes it;
no effect of the library has that form) hides a gain that changes with speed. On the same seed
without it, the twin is clean. For each seed, the model the example config fits must show:
- with the effect: the a_y gain errors per speed band CHANGE WITH SPEED (chi-square), at least two
  judged bands flagged and flagged bands of both signs (the signature: a gain odd in a_y that the
  bias columns cancel);
- the clean twin: no flagged band and no speed dependence, for a_y and the yaw rate.
Catches: a view that flags noise or chunk-to-chunk scatter (a standard error that is not
clustered), a gain with the wrong sign, a view blind to a gain that depends on speed.
Usage: gain_view_test.py NDSID_EXE SOURCE_DIR OUT_DIR"""
import json
import os
import shutil
import sys

import desk_cli

exe, src, out = sys.argv[1], sys.argv[2], sys.argv[3]
config = os.path.join(src, "config", "example_vehicle.yaml")
SEEDS = (31, 32)
HOURS = "0.6"
shutil.rmtree(out, ignore_errors=True)
os.makedirs(out)
errors = []


def run(args):
    return desk_cli.run(exe, args)


def view(case, seed, effect):
    d = os.path.join(out, f"{case}_{seed}")
    args = ["simulate", "--hours", HOURS, "--seed", str(seed), "--out", d]
    run(args + (["--effect", effect] if effect else []))
    printed = run(["compare", "--config", config, "--log", os.path.join(d, "drive.log"), "--out", os.path.join(d, "cmp")])
    with open(os.path.join(d, "cmp", "summary.json")) as f:
        summary = json.load(f)
    print(f"--- {case}, seed {seed}\n" + printed[printed.find("signed view"):], flush=True)
    return {output: next(m for m in models if m["model"] == "model") for output, models in summary["gain_view"].items()}


for seed in SEEDS:
    fx = view("downforce", seed, "rear_stiffness_speed_pct=25")["a_y"]
    flagged = [b["gain"] for b in fx["bands"] if b["flagged"]]
    if not fx["speed_dependent"]:
        errors.append(f"seed {seed}: with the hidden effect the a_y gains do not change with speed (chi2 {fx['chi2']:.1f})")
    if len(flagged) < 2 or not (min(flagged) < 0 < max(flagged)):
        errors.append(f"seed {seed}: with the hidden effect flagged gains {flagged}: expected two or more, of both signs")
    for output, clean in view("clean", seed, None).items():
        bad = [(b["band_mps"], b["gain"]) for b in clean["bands"] if b["flagged"]]
        if clean["speed_dependent"] or bad:
            errors.append(f"seed {seed}: clean twin, {output}: speed dependent {clean['speed_dependent']} "
                          f"(chi2 {clean['chi2']:.1f}), flagged {bad}")
if errors:
    print("\n".join(errors))
    sys.exit(1)
print("the hidden speed-dependent gain shows in the signed view on every seed; the clean twins show none")
