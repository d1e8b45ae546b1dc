"""Simulated fleets for trying `ndsid fleet` and for its tests and benchmark (docs/fleet.md):
vehicles of a few classes, each with its variants (load, tyres, steering ratio), laid out as
`ndsid fleet --dir` reads them: FOLDER/<vehicle>/vehicle.yaml, logs/NN.log.gz (+ the truth),
group.txt. The estimator's configuration of each vehicle is config/example_vehicle.yaml with the
class's data-sheet wheelbase and mass (the load is unknown to it, as on a real fleet) and a box
of +-40 % (lv, is: +-15 %) around the class's nominal parameters.
"""
from __future__ import annotations

import copy
import os
import shutil
import tempfile
from dataclasses import dataclass
from typing import Optional

# Nominal truths: the simulator's C-Max-class car and two other classes.
CLASSES = {
    "cmax": {"mass_kg": 1900, "yaw_inertia_kgm2": 2700, "cornering_stiffness_front_npr": 75000,
             "cornering_stiffness_rear_npr": 120000, "cg_to_front_m": 1.15, "wheelbase_m": 2.648, "steering_ratio": 14.8,
             "track_width_m": 1.55},
    "van": {"mass_kg": 2600, "yaw_inertia_kgm2": 4600, "cornering_stiffness_front_npr": 100000,
            "cornering_stiffness_rear_npr": 165000, "cg_to_front_m": 1.45, "wheelbase_m": 3.0, "steering_ratio": 16.5,
            "track_width_m": 1.7},
    "city": {"mass_kg": 1150, "yaw_inertia_kgm2": 1350, "cornering_stiffness_front_npr": 48000,
             "cornering_stiffness_rear_npr": 70000, "cg_to_front_m": 0.95, "wheelbase_m": 2.45, "steering_ratio": 13.5,
             "track_width_m": 1.45},
}
DAY_S = 86400
EPOCH_S = 1709537400


@dataclass
class Variant:
    """A vehicle of a class: extra load at the CG (Jz scaled with it), tyres' cornering stiffness
    and the steering ratio, relative to the class."""
    load_pct: float = 0.0
    tyre_pct: float = 0.0
    ratio_pct: float = 0.0


def truth_vehicle(cls: str, v: Variant) -> dict:
    t = dict(CLASSES[cls])
    k = 1 + v.load_pct / 100
    t["mass_kg"] *= k
    t["yaw_inertia_kgm2"] *= k
    for key in ("cornering_stiffness_front_npr", "cornering_stiffness_rear_npr"):
        t[key] *= 1 + v.tyre_pct / 100
    t["steering_ratio"] *= 1 + v.ratio_pct / 100
    return t


def estimator_config(cls: str, name: str, folder: str, logs: list[str], window_h: Optional[float] = None,
                     threads: int = 1) -> dict:
    import yaml

    import ndsid
    with open(os.path.join(ndsid.SOURCE_DIR, "config", "example_vehicle.yaml"), encoding="utf-8") as f:
        cfg = yaml.safe_load(f)
    c = CLASSES[cls]
    cfg = copy.deepcopy(cfg)
    # The class's own rear track: the example's rear wheel difference reads r against it.
    cfg["vehicle"] = {"name": name, "wheelbase_m": c["wheelbase_m"], "mass_kg": c["mass_kg"],
                      "track_rear_m": c["track_width_m"]}
    cfg["source"]["logs"] = list(logs)
    cfg["dbc"] = os.path.join(ndsid.SOURCE_DIR, "dbc", "ndsid_example.dbc")
    cfg["state_dir"] = os.path.join(folder, "state")
    cfg["report_dir"] = os.path.join(folder, "report")
    wide = {"Jz": c["yaw_inertia_kgm2"], "cv": c["cornering_stiffness_front_npr"], "ch": c["cornering_stiffness_rear_npr"]}
    params = {"m": {"min": c["mass_kg"] * 0.9, "max": c["mass_kg"] * 1.1, "fixed": True}}
    for k, v in wide.items():
        params[k] = {"min": round(v * 0.6), "max": round(v * 1.4)}
    params["lv"] = {"min": round(c["cg_to_front_m"] * 0.85, 4), "max": round(c["cg_to_front_m"] * 1.15, 4)}
    params["is"] = {"min": round(c["steering_ratio"] * 0.85, 3), "max": round(c["steering_ratio"] * 1.15, 3)}
    cfg["identification"]["parameters"] = params
    cfg["identification"]["threads"] = threads
    if window_h is not None:
        cfg["identification"]["window_h"] = window_h
    return cfg


def simulate_log(out_log: str, truth: dict, *, seed: int, start_epoch_s: int, hours: Optional[float] = None,
                 drives: Optional[int] = None) -> dict:
    """One simulated log (candump, gzip) of a vehicle with `truth` (the simulation config's
    vehicle section); returns the truth (truth.yaml as a dict), written beside the log."""
    import yaml

    import ndsid
    sim = {"seed": seed, "start_epoch_s": start_epoch_s, "vehicle": truth,
           "duration": {"hours": hours or 1.0, "drives": drives or 0}}
    with tempfile.TemporaryDirectory(prefix="ndsid-fleet-sim-") as tmp:
        cfg = os.path.join(tmp, "sim.yaml")
        with open(cfg, "w", encoding="utf-8") as f:
            yaml.safe_dump(sim, f)
        r = ndsid.simulate(tmp, config=cfg, hours=hours, seed=seed)
        os.makedirs(os.path.dirname(out_log), exist_ok=True)
        shutil.move(r["log"], out_log)
        truth_path = os.path.join(os.path.dirname(out_log), "truth.yaml")
        if not os.path.exists(truth_path):
            shutil.move(r["truth_path"], truth_path)
        return r["truth"]


def make_vehicle(fleet: str, vid: str, cls: str, variant: Variant = Variant(), *, logs: int = 2,
                 hours_per_log: Optional[float] = None, drives_per_log: Optional[int] = 3, seed: int = 1,
                 window_h: Optional[float] = None, group: Optional[str] = None) -> dict:
    """A simulated vehicle in `fleet`/<vid>: its logs (a month apart), vehicle.yaml, group.txt.
    Returns {"vehicle", "group", "truth_eg_deg_per_g", "logs", "config"}."""
    import yaml
    folder = os.path.join(fleet, vid)
    truth = truth_vehicle(cls, variant)
    paths, t = [], {}
    for k in range(logs):
        path = os.path.join(folder, "logs", f"{k:02d}.log.gz")
        t = simulate_log(path, truth, seed=seed * 1000 + k, start_epoch_s=EPOCH_S + 30 * DAY_S * k,
                         hours=hours_per_log, drives=None if hours_per_log else drives_per_log)
        paths.append(path)
    with open(os.path.join(folder, "vehicle.yaml"), "w", encoding="utf-8") as f:
        yaml.safe_dump(estimator_config(cls, vid, folder, paths, window_h), f, sort_keys=False)
    with open(os.path.join(folder, "group.txt"), "w", encoding="utf-8") as f:
        f.write((group or cls) + "\n")
    eg = (t.get("vehicle") or {}).get("self_steer_gradient_deg_per_g")
    return {"vehicle": vid, "group": group or cls, "truth_eg_deg_per_g": eg, "logs": paths,
            "config": os.path.join(folder, "vehicle.yaml")}
