#!/usr/bin/env python3
"""A bus that carries the road wheels' angle instead of the steering wheel's: init finds it, the
estimate holds.

A research car's export or another simulator's output often gives the road-wheel angle. Each case
simulates a drive, decodes its bus to time series, divides the steering-wheel angle by the
simulator's steer ratio (the road wheels' angle), writes it in the case's unit into the DBC's
RoadWheelAngle (whose DBC unit is 'deg', also where the values are rad) with `python -m ndsid
encode`, and sets the car up with `ndsid init` as a new user would. Each case must give:
- init: `vehicle.steering_angle_at: road_wheels` and the steering unit the values are in;
- replay with that config: valid, every check passed, the fitted steer ratio 1 within 3 %, EG
  within 3 sigma and 3 % of the simulator's truth.
Cases vary the seed, the unit (deg, rad), the vehicle (the example car, a van: l 3.40 m, 2 650 kg).
Catches: init taking the road-wheel angle for a steering wheel's in another unit (steer ratio 47
"if rad"), a box or a steer-ratio check that only knows steering wheels.
Usage: road_wheel_angle_test.py NDSID_EXE SOURCE_DIR OUT_DIR"""
import json
import math
import os
import re
import shutil
import subprocess
import sys

import numpy as np

import ndsid
import desk_cli

exe, src, out = sys.argv[1], sys.argv[2], sys.argv[3]
HOURS = "0.5"
shutil.rmtree(out, ignore_errors=True)
os.makedirs(out)
errors = []


def van_config():
    """The C-Max class's simulator config with a van's data (l 3.40 m, 2 650 kg, is 17.2)."""
    with open(os.path.join(src, "config", "sim_cmax.yaml")) as f:
        text = f.read()
    for key, value in (("mass_kg", 2650), ("yaw_inertia_kgm2", 5200), ("cornering_stiffness_front_npr", 105000),
                       ("cornering_stiffness_rear_npr", 190000), ("cg_to_front_m", 1.55), ("wheelbase_m", 3.40),
                       ("steering_ratio", 17.2)):
        text, n = re.subn(rf"^(  {key}:) *[0-9.]+", rf"\g<1> {value}", text, flags=re.M)
        assert n == 1, f"sim_cmax.yaml: vehicle.{key} not found once"
    path = os.path.join(out, "van.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path


CASES = (  # name, simulator config (None: the example car), seed, unit
    ("example_deg", None, 61, "deg"),
    ("van_rad", van_config(), 62, "rad"),
)


def truth_of(folder):
    with open(os.path.join(folder, "truth.yaml")) as f:
        text = f.read()

    def number(key):
        return float(re.search(rf"^\s+{key}: ([-0-9.e+]+)", text, flags=re.M).group(1))

    return {k: number(k) for k in ("mass_kg", "wheelbase_m", "steering_ratio", "self_steer_gradient_deg_per_g")}


def road_wheel_csv(folder, steer_ratio, unit, path):
    """The simulated bus as time series at 100 Hz, the steering as the road wheels' angle."""
    t = ndsid.decode(os.path.join(folder, "drive.log"), os.path.join(src, "dbc", "ndsid_example.dbc"), wide=True,
                     rate_hz=100.0)
    road_deg = t["STEERING_SENSOR.SteeringWheelAngle"] / steer_ratio
    cols = {
        "t_s": t["t_s"] - t["t_s"].iloc[0],
        "road": road_deg if unit == "deg" else np.radians(road_deg),
        "v_mps": t["VEHICLE_SPEED.VehicleSpeed"] / 3.6,
        "ay": t["ESP_DYNAMICS.LateralAcceleration"],
        "ax": t["ESP_DYNAMICS.LongitudinalAcceleration"],
        "r_degps": t["ESP_DYNAMICS.YawRate"],
    }
    import pandas as pd
    pd.DataFrame(cols).dropna().to_csv(path, index=False, float_format="%.6g")
    return float(t["t_s"].iloc[0])


for name, sim_config, seed, unit in CASES:
    d = os.path.join(out, name)
    args = ["simulate", "--hours", HOURS, "--seed", str(seed), "--out", d]
    desk_cli.run(exe, args + (["--config", sim_config] if sim_config else []))
    truth = truth_of(d)
    csv = os.path.join(d, "road_wheel.csv")
    start = road_wheel_csv(d, truth["steering_ratio"], unit, csv)
    with open(os.path.join(d, "map.yaml"), "w") as f:
        f.write(f"time: t_s\nstart_s: {start:.3f}\nsignals:\n"
                "  TS_STEERING.RoadWheelAngle: road\n  TS_SPEED.VehicleSpeed: v_mps\n"
                "  TS_IMU.LateralAcceleration: ay\n  TS_IMU.LongitudinalAcceleration: ax\n  TS_IMU.YawRate: r_degps\n")
    log = os.path.join(d, "road_wheel.log.gz")
    subprocess.run([sys.executable, "-m", "ndsid", "encode", "--csv", csv, "--dbc", os.path.join(src, "dbc", "timeseries.dbc"),
                    "--map", os.path.join(d, "map.yaml"), "--out", log], check=True, capture_output=True)
    cfg = os.path.join(d, "car.yaml")
    desk_cli.run(exe, ["init", "--dbc", os.path.join(src, "dbc", "timeseries.dbc"), "--log", log, "--out", cfg,
                       "--wheelbase", str(truth["wheelbase_m"]), "--mass", str(truth["mass_kg"])])
    with open(cfg) as f:
        text = f.read()
    steering = re.search(r"^  steering_wheel_angle: \{.*unit: (\w+)", text, flags=re.M)
    print(f"--- {name} (seed {seed}, road-wheel angle in {unit})\n" +
          "\n".join(l for l in text.splitlines() if "steer" in l), flush=True)
    if not re.search(r"^  steering_angle_at: road_wheels", text, flags=re.M):
        errors.append(f"{name}: init did not write vehicle.steering_angle_at: road_wheels")
    if not steering or steering.group(1) != unit:
        errors.append(f"{name}: init's steering unit {steering.group(1) if steering else None}, the values are in {unit}")
    report = os.path.join(d, "report")
    printed = desk_cli.run(exe, ["replay", "--config", cfg, "--final-only", "--report", report])
    print(printed[printed.find("EG ="):printed.find("gate:")], flush=True)
    with open(next(os.path.join(r, "estimate.json") for r, _, files in os.walk(report) if "estimate.json" in files)) as f:
        est = json.load(f)
    eg, se = est["eg_deg_per_g"], est["eg_se_deg_per_g"]
    eg_true = truth["self_steer_gradient_deg_per_g"]
    steer_ratio = next(p["value"] for p in est["parameters"] if p["name"] == "is")
    failed = [c["name"] for c in est["plausibility"]["checks"] if c["verdict"] == "failed"]
    print(f"{name}: EG {eg:.4f} ± {se:.4f} deg/g (truth {eg_true:.4f}, {(eg - eg_true) / se:+.2f} sigma, "
          f"{100 * (eg / eg_true - 1):+.2f} %), is {steer_ratio:.4f}, valid {est['valid']}, failed {failed}", flush=True)
    if not est["valid"] or failed:
        errors.append(f"{name}: not valid ({failed}): {est.get('reason', '')}")
    if not abs(steer_ratio - 1) < 0.03:
        errors.append(f"{name}: fitted steer ratio {steer_ratio:.4f}, the road wheels' is 1 (3 %)")
    if not (abs(eg - eg_true) < 3 * se and abs(eg / eg_true - 1) < 0.03):
        errors.append(f"{name}: EG {eg:.4f} ± {se:.4f} against the truth {eg_true:.4f} (3 sigma and 3 %)")

if errors:
    print("\n".join(errors))
    sys.exit(1)
print("every road-wheel angle found by init, its unit read from the data, EG within 3 sigma and 3 % of the truth")
