"""The fleet's results as tables (docs/fleet.md, "Outputs"): one row per vehicle (fleet.parquet),
one per vehicle and drive (drives.parquet), the groups' comparison and priors, the HTML page."""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from . import fleet_prior

DEG_PER_G = 180.0 / math.pi * 9.81
OUTLIER_Z = 3.0  # |z| against the rest of the group above this: an outlier


@dataclass
class FleetResult:
    table: pd.DataFrame       # fleet.parquet
    drives: pd.DataFrame      # drives.parquet
    out: str
    failed: list[str]
    computed: int             # vehicles identified in this run (the others reused or failed before)
    wall_s: float
    priors: dict = field(default_factory=dict)  # group -> fleet prior (fleet_prior.group_prior)
    worker_peak_mb: dict = field(default_factory=dict)  # worker -> its process's peak resident memory [MB]

    @property
    def exit_code(self) -> int:
        return 1 if self.failed else 0


def _nan(x) -> float:
    return float("nan") if x is None else float(x)


def vehicle_row(rec: dict) -> dict:
    res = rec.get("result") or {}
    est = res.get("estimate") or {}
    row = {"vehicle": rec["vehicle"], "group": rec.get("group") or "", **(rec.get("extra") or {}),
           "config": rec.get("config", ""), "logs": len(rec.get("logs") or []), "error": rec.get("error") or "",
           "error_kind": rec.get("error_kind") or "", "reused": bool(rec.get("reused"))}
    row.update(eg_deg_per_g=_nan(est.get("eg_deg_per_g")), eg_se_deg_per_g=_nan(est.get("eg_se_deg_per_g")),
               eg_rad_per_mps2=_nan(est.get("eg_rad_per_mps2")), eg_se_rad_per_mps2=_nan(est.get("eg_se_rad_per_mps2")),
               valid=bool(est.get("valid", False)), reason=est.get("reason", "") or "")
    checks = ((est.get("plausibility") or {}).get("checks")) or []
    row["checks_failed"] = ",".join(c.get("name", "") for c in checks if c.get("verdict") == "failed")
    ad = est.get("adequacy") or {}
    row.update(adequacy_state=ad.get("state", ""), adequacy_rel_se=_nan(ad.get("rel_se")),
               adequacy_rel_change=_nan(ad.get("rel_change")), adequacy_hours_under=_nan(ad.get("hours_under_tolerance")))
    window = res.get("window") or {}
    drives = res.get("drives") or []
    row.update(gated_hours=_nan(window.get("gated_hours")), window_hours=_nan(window.get("hours")),
               drives=len(drives), drives_used=sum(1 for d in drives if d.get("used")),
               frames=int(res.get("frames") or 0), malformed=int(res.get("malformed") or 0),
               rmse_train_mps2=_nan(est.get("rmse_train_mps2")), rmse_validation_mps2=_nan(est.get("rmse_validation_mps2")),
               rmse_train_yaw_radps=_nan(est.get("rmse_train_yaw_radps")),
               rmse_validation_yaw_radps=_nan(est.get("rmse_validation_yaw_radps")),
               runs=len(res.get("runs") or []), identify_wall_s=_nan(res.get("wall_s")))
    truth = res.get("truth_eg_rad_per_mps2")
    row["truth_eg_deg_per_g"] = _nan(truth) * DEG_PER_G if truth is not None else float("nan")
    for p in est.get("parameters") or []:
        n = f"p_{p['name']}"
        row.update({n: _nan(p.get("value")), f"{n}_se": _nan(p.get("se")), f"{n}_fixed": bool(p.get("fixed")),
                    f"{n}_at_bound": bool(p.get("at_bound"))})
    return row


def drive_rows(rec: dict) -> list[dict]:
    res = rec.get("result") or {}
    return [{"vehicle": rec["vehicle"], "group": rec.get("group") or "", **d} for d in res.get("drives") or []]


def _group_outliers(table: pd.DataFrame) -> None:
    """eg_group_mean / eg_group_tau (the rest of the group, leave-one-out), eg_z and eg_outlier."""
    for col in ("eg_group_mean", "eg_group_tau", "eg_z"):
        table[col] = np.nan
    table["eg_outlier"] = False
    ok = (table["error"] == "") & table["valid"] & np.isfinite(table["eg_deg_per_g"]) & (table["eg_se_deg_per_g"] > 0)
    for _, idx in table[ok].groupby("group").groups.items():
        idx = list(idx)
        if len(idx) < 3:
            continue
        for i in idx:
            rest = [j for j in idx if j != i]
            mean, se, tau = fleet_prior.random_effects(table.loc[rest, "eg_deg_per_g"], table.loc[rest, "eg_se_deg_per_g"])
            z = (table.at[i, "eg_deg_per_g"] - mean) / math.sqrt(table.at[i, "eg_se_deg_per_g"] ** 2 + tau**2 + se**2)
            table.loc[i, ["eg_group_mean", "eg_group_tau", "eg_z"]] = [mean, tau, z]
            table.at[i, "eg_outlier"] = abs(z) > OUTLIER_Z


def _prior_columns(table: pd.DataFrame, records: list[dict]) -> None:
    """prior_distance, prior_dof, prior_conflict and prior_z_<name> of vehicles whose
    configuration has model.priors."""
    import ndsid
    table["prior_distance"], table["prior_dof"], table["prior_conflict"] = np.nan, 0, False
    for i, rec in enumerate(records):
        est = (rec.get("result") or {}).get("estimate") or {}
        if not est.get("parameters"):
            continue
        try:
            priors = ndsid.load_config(rec["config"]).get("priors") or {}
        except (ndsid.Error, OSError):
            continue
        d = fleet_prior.prior_distance(est["parameters"], priors, est.get("eg_deg_per_g"))
        if d is None:
            continue
        table.loc[i, ["prior_distance", "prior_dof", "prior_conflict"]] = [d["distance"], d["dof"], d["conflict"]]
        for name, z in d["z"].items():
            table.loc[i, f"prior_z_{name}"] = z
    table["prior_conflict"] = table["prior_conflict"].astype(bool)


def build_tables(records: list[dict]) -> tuple[pd.DataFrame, pd.DataFrame]:
    table = pd.DataFrame([vehicle_row(r) for r in records])
    _group_outliers(table)
    _prior_columns(table, records)
    drives = pd.DataFrame([d for r in records for d in drive_rows(r)],
                          columns=["vehicle", "group", "drive", "start_s", "duration_s", "distance_km", "gated_s", "used"])
    return table, drives


def write_outputs(records: list[dict], out: str, *, wall_s: float, computed: int) -> FleetResult:
    from .fleet_report import write_report
    table, drives = build_tables(records)
    table.to_parquet(os.path.join(out, "fleet.parquet"), index=False)
    table.to_csv(os.path.join(out, "fleet.csv"), index=False)
    drives.to_parquet(os.path.join(out, "drives.parquet"), index=False)
    priors = {}
    for group in sorted(set(table["group"])):
        prior = fleet_prior.group_prior(table, group)
        if prior is None:
            continue
        priors[group] = prior
        fleet_prior.write_group_prior(os.path.join(out, "fleet.parquet"), prior)
    write_report(table, priors, os.path.join(out, "fleet-report.html"))
    failed = table.loc[table["error"] != "", "vehicle"].tolist()
    return FleetResult(table, drives, out, failed, computed, wall_s, priors)
