"""The fleet prior (docs/fleet.md, "The fleet prior"): what the identified vehicles of one group
say about a new vehicle of that group, as `model.priors` of its configuration.

Vehicles of one model share their geometry and tyres, not their load: the prior is kept in
units that carry over between them, per kilogram of the vehicle's (configured, fixed) mass for
Jz, cv and ch, as they are for lv and is. Across the group's vehicles each parameter's mean and
between-vehicle spread tau come from a random-effects estimate (DerSimonian-Laird: each vehicle
weighted by 1/(se^2 + tau^2)); a new vehicle's parameter is predicted as N(mean, tau^2 + se(mean)^2).
For a configuration it is scaled back by that vehicle's mass (priors_for_config). The group's EG,
estimated the same way, becomes a prior on EG itself (model.priors.eg_deg_per_g): a vehicle's
cv, ch and lv err together, so the group knows its EG far better than the parameters' spreads say.
"""
from __future__ import annotations

import math
import os
import re
import zlib
from typing import Iterable, Optional

import numpy as np

PRIOR_PARAMS = {"Jz": "Jz_per_m", "cv": "cv_per_m", "ch": "ch_per_m", "lv": "lv", "is": "is"}
UNITS = {"Jz_per_m": "m^2", "cv_per_m": "N/rad/kg", "ch_per_m": "N/rad/kg", "lv": "m", "is": "-"}
# chi-square 0.999 quantiles by degrees of freedom: a posterior this far from its prior (in the
# prior's standard deviations) happens by chance once in a thousand vehicles at most.
CHI2_999 = {1: 10.83, 2: 13.82, 3: 16.27, 4: 18.47, 5: 20.52, 6: 22.46, 7: 24.32, 8: 26.12, 9: 27.88, 10: 29.59}
MIN_VEHICLES = 3
# model.priors' name of the prior on EG itself (deg/g): the group's EG is known far better than its
# parameters' spread implies, because each vehicle's cv, ch and lv errors are correlated.
EG_PRIOR = "eg_deg_per_g"


def random_effects(x: Iterable[float], se: Iterable[float]) -> tuple[float, float, float]:
    """(mean, se of the mean, tau) of values with standard errors: DerSimonian-Laird."""
    x = np.asarray(list(x), dtype=float)
    se = np.maximum(np.asarray(list(se), dtype=float), 1e-12 * max(1.0, float(np.max(np.abs(x))) if len(x) else 1.0))
    w = 1.0 / se**2
    mean_fixed = float(np.sum(w * x) / np.sum(w))
    q = float(np.sum(w * (x - mean_fixed) ** 2))
    denom = float(np.sum(w) - np.sum(w**2) / np.sum(w))
    tau2 = max(0.0, (q - (len(x) - 1)) / denom) if len(x) > 1 and denom > 0 else 0.0
    ws = 1.0 / (se**2 + tau2)
    return float(np.sum(ws * x) / np.sum(ws)), float(math.sqrt(1.0 / np.sum(ws))), math.sqrt(tau2)


def usable(table, group: str):
    """The group's vehicles a prior may learn from: identified, valid, not an EG outlier of the
    group, not contradicting a prior they were started from."""
    t = table[(table["group"] == group) & (table["error"] == "") & table["valid"].fillna(False).astype(bool)]
    for flag in ("eg_outlier", "prior_conflict"):
        if flag in t:
            t = t[~t[flag].fillna(False).astype(bool)]
    return t


def group_prior(table, group: str, min_vehicles: int = MIN_VEHICLES) -> Optional[dict]:
    """The group's prior from the fleet table (fleet.parquet), or None with fewer than
    `min_vehicles` usable vehicles for a parameter."""
    t = usable(table, group)
    params = {}
    for name, key in PRIOR_PARAMS.items():
        col = f"p_{name}"
        if col not in t:
            return None
        ok = t[~t[f"{col}_fixed"].astype(bool) & ~t[f"{col}_at_bound"].astype(bool) & (t[f"{col}_se"] > 0)]
        if len(ok) < min_vehicles:
            return None
        scale = ok["p_m"].to_numpy(float) if key.endswith("_per_m") else np.ones(len(ok))
        mean, se_mean, tau = random_effects(ok[col].to_numpy(float) / scale, ok[f"{col}_se"].to_numpy(float) / scale)
        params[key] = {"mean": mean, "sd": math.sqrt(tau**2 + se_mean**2), "tau": tau, "se_mean": se_mean,
                       "vehicles": int(len(ok)), "unit": UNITS[key]}
    eg_mean, eg_se, eg_tau = random_effects(t["eg_deg_per_g"], t["eg_se_deg_per_g"])
    return {"group": group, "vehicles": sorted(t["vehicle"].tolist()), "parameters": params,
            "eg_deg_per_g": {"mean": eg_mean, "sd": math.sqrt(eg_tau**2 + eg_se**2), "tau": eg_tau}}


def prior_yaml(prior: dict) -> str:
    """The prior as fleet_prior.yaml."""
    import yaml
    head = ("# Fleet prior of one group (docs/fleet.md): per parameter the group's mean and the spread a\n"
            "# new vehicle of the group is predicted with; Jz, cv, ch per kg of the vehicle's mass.\n"
            "# Apply: identification.prior_from: THIS (or the fleet.parquet it names with prior_group), or\n"
            "#        python -m ndsid fleet prior --prior THIS --config car.yaml --out car_with_prior.yaml\n")
    return head + yaml.safe_dump(prior, sort_keys=False)


def group_folder(group: str) -> str:
    """The group's folder name under OUT/groups/ (ndsid reads it there for prior_group)."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", group) or "_"


def table_source(table_path: str) -> dict:
    """What a group prior records of the fleet table it comes from: ndsid checks the size and
    CRC-32 when a configuration names the table (identification.prior_from + prior_group)."""
    with open(table_path, "rb") as f:
        data = f.read()
    return {"table": os.path.basename(table_path), "bytes": len(data), "crc32": f"{zlib.crc32(data):08x}"}


def write_group_prior(table_path: str, prior: dict) -> str:
    """OUT/groups/<group>/fleet_prior.yaml beside the fleet table, with the table's source."""
    folder = os.path.join(os.path.dirname(os.path.abspath(table_path)), "groups", group_folder(prior["group"]))
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "fleet_prior.yaml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(prior_yaml(dict(prior, source=table_source(table_path))))
    return path


def load_prior(path: str) -> dict:
    import yaml
    with open(path, encoding="utf-8") as f:
        prior = yaml.safe_load(f)
    if not isinstance(prior, dict) or not isinstance(prior.get("parameters"), dict):
        raise ValueError(f"{path}: not a fleet prior (needs 'parameters')")
    return prior


def priors_for_config(prior: dict, mass_kg: float) -> dict[str, dict]:
    """model.priors for a vehicle of `mass_kg`: {name: {value, sd}} in the parameters' SI units."""
    out = {}
    for name, key in PRIOR_PARAMS.items():
        p = prior["parameters"].get(key)
        if p is None:
            continue
        scale = mass_kg if key.endswith("_per_m") else 1.0
        out[name] = {"value": p["mean"] * scale, "sd": max(p["sd"] * scale, 1e-9 * abs(p["mean"] * scale))}
    eg = prior.get(EG_PRIOR)
    if eg is not None:
        out[EG_PRIOR] = {"value": eg["mean"], "sd": max(eg["sd"], 1e-9 * abs(eg["mean"]))}
    return out


def prior_distance(parameters: list[dict], priors: dict[str, dict],
                   eg_deg_per_g: Optional[float] = None) -> Optional[dict]:
    """The posterior's distance from the prior: each prior parameter's (and, given the estimate's
    EG, the EG prior's) z = (value - prior) / sd, the distance over them (sqrt(sum z^2), as ndsid
    states it in the estimate's notes), and whether it contradicts the prior (distance^2 above
    the chi-square 0.999 quantile)."""
    by_name = {p["name"]: p for p in parameters}
    if eg_deg_per_g is not None:
        by_name[EG_PRIOR] = {"name": EG_PRIOR, "value": eg_deg_per_g}
    z = {}
    for name, pr in priors.items():
        p = by_name.get(name)
        if p is None or p.get("fixed") or not pr.get("sd"):
            continue
        z[name] = (p["value"] - pr["value"]) / pr["sd"]
    if not z:
        return None
    d2 = sum(v * v for v in z.values())
    threshold = CHI2_999.get(len(z), len(z) + 3.1 * math.sqrt(2 * len(z)))
    return {"distance": math.sqrt(d2), "dof": len(z), "z": z, "conflict": d2 > threshold,
            "threshold": math.sqrt(threshold)}
