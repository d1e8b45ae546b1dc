#!/usr/bin/env python3
"""The loop on a shape outside the library: diagnose names it, its formula brings the error to
the floor.

The simulator's steer_deadband_deg (on-centre play: the road wheels follow d_sw - clip(d_sw, -b, b);
negative, a lead: d_sw + clip(d_sw, -|b|, |b|)),
steer_asymmetry_pct (the road wheels follow d_sw (1 + k sgn d_sw)) and accel_quadratic_pct (the
accelerometer reads q + k2 q^2/g) are not in the model library; nor is rear_steer_pct, a chassis
system (active rear steering, delta_h = k ((v/30)^2 - 1/4) delta), whose error is a gain that changes
with speed: its template offers a rear stiffness rising with v^2 and rear steering, and the ladder
must keep the rear steering (a formula of two parameters judged jointly). Their a_y error is an offset odd
(w(v) sgn d_sw) or even (w(v) |d_sw|, a_y^2) in the turn, not a gain; the two even ones are told
apart by the measured a_y - v r (the accelerometer's error stays in it, the steering's does not),
or, where that does not decide, both formulas are offered and the ladder judges them. For each
case (magnitudes, both signs, a play beside a library effect), on held-out drives and a clean twin
(same seed, no effect):
- `diagnose` from the library names the shape with a formula template (diagnosis.json,
  outside_library), one of the signatures the case accepts;
- the template, pasted as printed into the configuration and its formulas listed as hypotheses
  (`diagnose --candidates +name,...` from the starting effects), ends with the case's formula
  among the final effects (a library effect that stood in for part of it on the first pass is
  not added beside it); with the ladder's final effects the held-out RMSEs of a_y and of the yaw
  rate are within 15 % of the clean twin's, and `replay` publishes EG within 1 % of the truth,
  valid, and the formula's parameter near the truth (the play b, the lead c and the rear steering's
  c2 within 10 %, the asymmetry k within 0.01, the accelerometer's k2 within 15 %).
Catches: a signature that does not lead on its shape, a verdict that picks a gain instead or the
wrong one of the even shapes, a template that does not state the property (its sign, its unit,
the axle or the sensor it acts on).
Usage: steering_shape_test.py NDSID_EXE SOURCE_DIR OUT_DIR"""
import glob
import html
import json
import math
import os
import re
import shutil
import sys

import yaml

import desk_cli

exe, src, out = sys.argv[1], os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
HOURS = "0.6"
# (seed, the simulator's effects, the signatures accepted, the formula expected, its parameter and truth)
ODD, STEER, ACCEL, EITHER = "offset odd in the steering", "offset even in the steering", "accelerometer even in a_y", "even in the turn"
SPEED = "gain changes with speed"
CASES = (
    (41, ["steer_deadband_deg=2"], (ODD,), "steering_play", "b", math.radians(2)),
    (42, ["steer_deadband_deg=1"], (ODD,), "steering_play", "b", math.radians(1)),
    (31, ["steer_deadband_deg=1.5", "steer_offset_deg=1"], (ODD,), "steering_play", "b", math.radians(1.5)),
    (47, ["steer_deadband_deg=-1.5"], (ODD,), "steering_lead", "c", math.radians(1.5)),
    (43, ["steer_asymmetry_pct=4"], (STEER, EITHER), "steering_unequal", "k", 0.04),
    (32, ["steer_asymmetry_pct=-3"], (STEER, EITHER), "steering_unequal", "k", -0.03),
    (43, ["accel_quadratic_pct=15"], (ACCEL, EITHER), "accel_even", "k2", 0.15),
    (46, ["accel_quadratic_pct=-12"], (ACCEL, EITHER), "accel_even", "k2", -0.12),
    (48, ["rear_steer_pct=20"], (SPEED,), "rear_steer_with_speed", "c2", 0.20),
    (49, ["rear_steer_pct=-12"], (SPEED,), "rear_steer_with_speed", "c2", -0.12),
)
shutil.rmtree(out, ignore_errors=True)
os.makedirs(out)
errors = []


def run(args):
    return desk_cli.run(exe, args)


def write_config(d, name, effects=None, template=""):
    """The example config in d; with `effects` and the template's formula pasted as printed."""
    text = desk_cli.example_config(src, d)
    if effects is not None:
        text = desk_cli.with_model(text, effects, "".join(line + "\n" for line in template.splitlines()[1:]))
    path = os.path.join(d, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def compare(cfg, log, d):
    m, yaw = desk_cli.compare(exe, cfg, log, d)
    return m["rmse_validation_mps2"], yaw


for seed, effects, shapes, expected, param, truth in CASES:
    d = os.path.join(out, f"s{seed}_{effects[0].split('=')[0]}")
    os.makedirs(d)
    cfg = write_config(d, "example.yaml")
    run(["simulate", "--hours", HOURS, "--seed", str(seed), "--out", d] + sum((["--effect", e] for e in effects), []))
    twin = os.path.join(d, "twin")
    run(["simulate", "--hours", HOURS, "--seed", str(seed), "--out", twin])
    log = os.path.join(d, "drive.log")
    with open(os.path.join(d, "truth.yaml")) as f:
        eg_truth = float(re.search(r"self_steer_gradient_deg_per_g: ([0-9.eE+-]+)", f.read()).group(1))
    run(["diagnose", "--config", cfg, "--log", log, "--out", os.path.join(d, "diag")])
    with open(os.path.join(d, "diag", "diagnosis.json")) as f:
        diag = json.load(f)
    a_y = next(v for v in diag["verdicts"] if v["output"] == "a_y")
    outside = {o["output"]: o for o in diag["outside_library"]}.get("a_y", {})
    print(f"seed {seed} {effects}: diagnose final {diag['final_effects']}, a_y unexplained {a_y['unexplained']}; "
          f"{outside.get('text', 'nothing named')}", flush=True)
    if outside.get("signature") not in shapes or expected not in outside.get("formula_template", ""):
        errors.append(f"seed {seed} {effects}: diagnose did not name one of {shapes} with {expected}: {diag['outside_library']}")
        continue
    template = outside["formula_template"]
    with open(os.path.join(d, "diag", "ndsid-report.html")) as f:
        page = f.read()
    if "Outside the library" not in page or html.escape(template.splitlines()[3].strip()) not in page:
        errors.append(f"seed {seed}: the HTML report does not show the verdict outside the library with its template")
    formulas = list(yaml.safe_load(template)["model"]["formulas"])
    start = diag["start_effects"]
    hyp_cfg = write_config(d, "hypothesis.yaml", start + formulas, template)
    run(["diagnose", "--config", hyp_cfg, "--log", log, "--effects", ",".join(start), "--candidates",
         ",".join("+" + f for f in formulas), "--out", os.path.join(d, "diag_hypothesis")])
    with open(os.path.join(d, "diag_hypothesis", "diagnosis.json")) as f:
        final = json.load(f)["final_effects"]
    print(f"  diagnose with {', '.join('+' + f for f in formulas)}: final {final}", flush=True)
    if expected not in final or any(f in final for f in formulas if f != expected):
        errors.append(f"seed {seed}: the ladder did not keep {expected} alone of the hypotheses {formulas}: {final}")
        continue
    fixed = write_config(d, "fixed.yaml", final, template)
    floor, floor_r = compare(cfg, os.path.join(twin, "drive.log"), os.path.join(twin, "cmp"))
    before, before_r = compare(cfg, log, os.path.join(d, "cmp_before"))
    after, after_r = compare(fixed, log, os.path.join(d, "cmp_after"))
    run(["replay", "--config", fixed, "--log", log, "--final-only", "--report", os.path.join(d, "replay")])
    with open(glob.glob(os.path.join(d, "replay", "*", "estimate.json"))[0]) as f:
        est = json.load(f)
    fitted = next((p["value"] for p in est["parameters"] if p["name"] == param), None)
    eg = est["eg_deg_per_g"]
    print(f"  held-out a_y {before:.4f} -> {after:.4f} m/s^2 (twin {floor:.4f}, {after / floor:.3f}x); yaw rate "
          f"{before_r:.4f} -> {after_r:.4f} deg/s (twin {floor_r:.4f}, {after_r / floor_r:.3f}x); EG {eg:.4f} deg/g "
          f"(truth {eg_truth:.4f}, {100 * (eg / eg_truth - 1):+.2f} %), valid {est.get('valid')}; {param} = {fitted} "
          f"(truth {truth:.5f})", flush=True)
    if not before > 1.1 * floor:
        errors.append(f"seed {seed}: without the formula a_y {before:.4f} is not well above the twin's {floor:.4f}")
    if after > 1.15 * floor or after_r > 1.15 * floor_r:
        errors.append(f"seed {seed}: with the template the held-out RMSEs {after:.4f}, {after_r:.4f} are more than 15 % "
                      f"above the twin's {floor:.4f}, {floor_r:.4f}")
    if abs(eg / eg_truth - 1) > 0.01:
        errors.append(f"seed {seed}: with the template EG {eg:.4f} is more than 1 % off the truth {eg_truth:.4f}")
    tol = {"b": 0.1 * abs(truth), "c": 0.1 * abs(truth), "c2": 0.1 * abs(truth), "k": 0.01, "k2": 0.15 * abs(truth)}[param]
    if fitted is None or abs(fitted - truth) > tol:
        errors.append(f"seed {seed}: fitted {param} {fitted}, truth {truth:.5f} (tolerance {tol:.4f})")
    if not est.get("valid"):
        errors.append(f"seed {seed}: with the template the estimate is not valid: {est.get('reason')}")
if errors:
    print("\n".join(errors))
    sys.exit(1)
print("diagnose names the shape, and its template brings both outputs to the twin's floor and EG to the truth")
