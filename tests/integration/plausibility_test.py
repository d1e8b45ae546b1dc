#!/usr/bin/env python3
"""Plausibility end to end: simulated drives replayed with the configuration mistakes a
hand-written vehicle YAML makes, on several seeds and two vehicles (the C-Max class of the
bundled sets and an SUV with its own, wider identification box). Every mistake must give
`valid: false` with the check that names it; the correct configuration must stay valid.

Usage: plausibility_test.py NDSID_EXE SOURCE_DIR   (exit 0 pass, 1 fail)"""
import json
import os
import re
import subprocess
import sys
import tempfile

exe, src = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
base_cfg = open(os.path.join(src, "config", "example_vehicle.yaml")).read()
dbc = os.path.join(src, "dbc", "ndsid_example.dbc")

SUV_SIM = """
vehicle:
  mass_kg: 2300
  yaw_inertia_kgm2: 4200
  cornering_stiffness_front_npr: 100000
  cornering_stiffness_rear_npr: 150000
  cg_to_front_m: 1.35
  wheelbase_m: 2.9
  steering_ratio: 16.5
  track_width_m: 1.65
"""
SUV_BOX = """    m:  {min: 2200, max: 2400, fixed: true}
    Jz: {min: 2500, max: 6000}
    cv: {min: 50000, max: 200000}
    ch: {min: 60000, max: 250000}
    lv: {min: 1.0, max: 1.8}
    is: {min: 12.0, max: 20.0}
"""

# name -> (regex, replacement) on the vehicle YAML, and the check that must fail.
MISTAKES = {
    "ay_sign": (r"(lateral_acceleration: *\{[^}]*sign: )1", r"\g<1>-1", "kinematics"),
    "steer_sign": (r"(steering_wheel_angle: *\{[^}]*sign: )1", r"\g<1>-1", "steering_sign"),
    "steer_rad": (r"(steering_wheel_angle: *\{[^}]*unit: )deg", r"\g<1>rad", "steer_ratio"),
    "speed_mps": (r"(vehicle_speed: *\{[^}]*unit: )km/h", r"\g<1>m/s", ["kinematics", "wheel_speed"]),
    # the optional wheel_speed role in mph for km/h: only the speed check can see it
    "wheel_mph": (r"(wheel_speed: *\{[^}]*unit: )km/h", r"\g<1>mph", ["wheel_speed"]),
    # the rear track 10 % or more too small: the rear wheels contradict every model fitted
    "track": (r"track_rear_m: [0-9.]+", "track_rear_m: 1.40", ["model_choice"]),
}


def vehicle_yaml(log, suv, mistake=None):
    text = base_cfg.replace("../replay/clean/drive.log.gz", log).replace("../dbc/ndsid_example.dbc", dbc)
    if suv:
        text = re.sub(r"wheelbase_m: [0-9.]+", "wheelbase_m: 2.9", text, count=1)
        text = re.sub(r"mass_kg: [0-9.]+", "mass_kg: 2300", text, count=1)
        text = re.sub(r"track_rear_m: [0-9.]+", "track_rear_m: 1.65", text, count=1)
        text = re.sub(r"    m:  \{[^\n]*\n    Jz:[^\n]*\n    cv:[^\n]*\n    ch:[^\n]*\n    lv:[^\n]*\n    is:[^\n]*\n", SUV_BOX, text)
    if mistake:
        pattern, repl, _ = MISTAKES[mistake]
        text, n = re.subn(pattern, repl, text, count=1)
        assert n == 1, f"mistake {mistake} did not apply"
    return text


def replay(d, name, text):
    cfg = os.path.join(d, name + ".yaml")
    with open(cfg, "w") as f:
        f.write(text)
    out = os.path.join(d, "report_" + name)
    p = subprocess.run([exe, "replay", "--config", cfg, "--final-only", "--report", out], capture_output=True, text=True)
    js = [os.path.join(out, x, "estimate.json") for x in os.listdir(out)] if os.path.isdir(out) else []
    if not js:
        return p, None
    return p, json.load(open(js[0]))


failures = []
cases = [(seed, False) for seed in (11, 12, 13)] + [(21, True)]
with tempfile.TemporaryDirectory() as d:
    for seed, suv in cases:
        sim = os.path.join(d, f"sim{seed}")
        args = [exe, "simulate", "--hours", "0.6", "--seed", str(seed), "--out", sim, "--gzip"]
        if suv:
            simcfg = os.path.join(d, "suv_sim.yaml")
            with open(simcfg, "w") as f:
                f.write(SUV_SIM)
            args += ["--config", simcfg]
        subprocess.run(args, check=True, capture_output=True)
        log = os.path.join(sim, "drive.log.gz")
        tag = f"seed {seed}{' SUV' if suv else ''}"
        p, j = replay(d, f"clean{seed}", vehicle_yaml(log, suv))
        if j is None or not j.get("valid"):
            failures.append(f"{tag} clean: not valid: {j and j.get('reason')} {p.stderr[-500:]}")
        else:
            print(f"{tag} clean: valid, EG {j['eg_deg_per_g']:.3f} +- {j['eg_se_deg_per_g']:.3f} deg/g; "
                  + ", ".join(f"{c['name']} {c['verdict']} {c['value']:.3g}" for c in j["plausibility"]["checks"]))
        for mistake, (_, _, check) in MISTAKES.items():
            p, j = replay(d, f"{mistake}{seed}", vehicle_yaml(log, suv, mistake))
            if j is None:
                failures.append(f"{tag} {mistake}: no estimate.json (exit {p.returncode}) {p.stderr[-300:]}")
                continue
            failed = [c["name"] for c in j["plausibility"]["checks"] if c["verdict"] == "failed"]
            verdict = "valid" if j.get("valid") else "NOT valid"
            print(f"{tag} {mistake}: {verdict}; failed checks {failed}; reason: {j.get('reason', '')[:160]}")
            checks = check if isinstance(check, list) else [check]
            if mistake == "track" and "rear track at" not in j.get("reason", ""):
                failures.append(f"{tag} track: the reason does not give the track the wheels imply: {j.get('reason', '')[:300]}")
            if j.get("valid") or any(c not in failed for c in checks):
                failures.append(f"{tag} {mistake}: expected not valid with {checks} failed, got {verdict}, {failed}")
            if "NOT VALID" not in p.stdout and not j.get("valid"):
                failures.append(f"{tag} {mistake}: the console headline does not say NOT VALID")
if failures:
    print("\n".join(failures))
    sys.exit(1)
print("every mistake named, every correct configuration valid")
