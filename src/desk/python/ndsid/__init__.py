"""ndsid from Python: the desk's C++ core in process (docs/python.md).

    import ndsid
    cfg = ndsid.load_config("config/example_vehicle.yaml")
    frames = ndsid.decode("replay/clean/drive.log.gz", dbc=cfg["dbc"])            # long DataFrame
    wide = ndsid.decode("replay/clean/drive.log.gz", dbc=cfg["dbc"], wide=True, rate_hz=50)
    run = ndsid.replay("config/example_vehicle.yaml")                              # dict + DataFrames
    cmp = ndsid.compare("config/example_vehicle.yaml", effects=[])                 # samples, bins
    dia = ndsid.diagnose("config/example_vehicle.yaml")                           # the error ladder
    sim = ndsid.simulate("/tmp/sim", hours=0.5, seed=3, effects={"steer_offset_deg": 1.0})
    st = ndsid.study("config/example_vehicle.yaml", hours=[0.1, 0.2])             # sets, summary
    fl = ndsid.fleet(dir="fleet/", out="out/fleet", workers=2)                     # many vehicles on Dask

Errors of configuration or input raise ndsid.ConfigError (a ValueError) with the CLI's message.
"""
from __future__ import annotations

import json
import os
import tempfile
from typing import Iterable, Optional, Sequence

import numpy as np
import pandas as pd

from . import _ndsid

__all__ = ["load_config", "decode", "replay", "compare", "diagnose", "study", "simulate", "fleet", "run", "ConfigError",
           "Error", "SOURCE_DIR"]

ConfigError = _ndsid.ConfigError
Error = _ndsid.Error
SOURCE_DIR = "@CMAKE_SOURCE_DIR@"  # the checkout this was built from (its bundled data and configs)


def _logs(logs: Optional[Iterable[str] | str]) -> list[str]:
    if logs is None:
        return []
    if isinstance(logs, (str, os.PathLike)):
        return [os.fspath(logs)]
    return [os.fspath(p) for p in logs]


def load_config(path: str | os.PathLike) -> dict:
    """The vehicle configuration as ndsid reads it (checked, paths resolved): vehicle, dbc,
    effects, outputs, logs, roles with their signals, units and latencies."""
    return json.loads(_ndsid.load_config(os.fspath(path)))


def decode(log: str | os.PathLike, dbc: str | os.PathLike, *, bus: str = "", wide: bool = False,
           rate_hz: Optional[float] = None) -> pd.DataFrame:
    """Every DBC signal of a log (candump, ASC, BLF or MF4, recognised from the content).

    Long form (default): columns t_s, message, signal, value, one row per decoded value.
    wide=True: one column per "message.signal", one row per time stamp; with rate_hz the
    signals are resampled onto a uniform grid by sample-and-hold (the last value at or before
    each grid time, as the pipeline's sync stage reads them)."""
    if wide and rate_hz is not None and not rate_hz > 0:  # checked before any work
        raise ConfigError(f"rate_hz must be > 0, got {rate_hz}")
    d = _ndsid.decode(os.fspath(log), os.fspath(dbc), bus)
    codes = np.asarray(d["code"], dtype=np.int32)

    def categorical(per_signal: list[str]) -> pd.Categorical:
        unique = list(dict.fromkeys(per_signal))
        index = np.array([unique.index(x) for x in per_signal], dtype=np.int32)
        return pd.Categorical.from_codes(index[codes] if len(index) else codes, categories=unique)

    labels = [f"{m}.{s}" for m, s in zip(d["messages"], d["signals"])]
    df = pd.DataFrame({"t_s": d["t_s"], "message": categorical(d["messages"]), "signal": categorical(d["signals"]),
                       "value": d["value"]})
    df.attrs.update(frames=d["frames"], malformed=d["malformed"], format=d["format"])
    if not wide:
        return df
    df["name"] = categorical(labels)
    table = df.pivot_table(index="t_s", columns="name", values="value", aggfunc="last", observed=True)
    table.columns = [str(c) for c in table.columns]
    table.columns.name = None
    if rate_hz is None:
        return table.reset_index()
    t0, t1 = table.index.min(), table.index.max()
    grid = pd.Index(t0 + np.arange(int(np.floor((t1 - t0) * rate_hz)) + 1) / rate_hz, name="t_s")
    held = table.ffill().reindex(table.index.union(grid)).ffill().reindex(grid)
    return held.reset_index()


def replay(config: str | os.PathLike, logs: Optional[Iterable[str] | str] = None, *, final_only: bool = True) -> dict:
    """The pipeline over the configured logs (or `logs`), as `ndsid replay` runs it.

    final_only=True (the desk default) identifies once at the end; False also at every
    identification.period_s of data, as the daemon does (the EG history). Returns a dict:
    estimate (the estimate document of docs/state-format.md, None without data), history and
    drives as DataFrames, gate (counters per rejection reason), window, frames, truth EG when a
    truth.yaml lies beside the log."""
    r = json.loads(_ndsid.replay(os.fspath(config), _logs(logs), final_only))
    hist = r.pop("history")
    r["history"] = pd.DataFrame([{
        "gated_hours": e["gated_hours"], "eg_rad_per_mps2": e["eg_rad_per_mps2"],
        "eg_se_rad_per_mps2": e["eg_se_rad_per_mps2"], "eg_deg_per_g": e["eg_deg_per_g"],
        "eg_se_deg_per_g": e["eg_se_deg_per_g"], "rmse_train_mps2": e["rmse_train_mps2"],
        "rmse_validation_mps2": e["rmse_validation_mps2"], "state": e["adequacy"]["state"], "valid": e["valid"]}
        for e in hist])
    r["drives"] = pd.DataFrame(r["drives"])
    return r


def parameters(estimate: dict) -> pd.DataFrame:
    """An estimate's (or a fitted model's) parameters as a DataFrame: name, value, se, unit,
    fixed, at_bound."""
    return pd.DataFrame(estimate["parameters"])


def compare(config: str | os.PathLike, logs: Optional[Iterable[str] | str] = None, *,
            effects: Optional[Sequence[str]] = None, baseline: Sequence[str] = ()) -> dict:
    """The model (the config's effects, or `effects`) and a baseline (default: the base model)
    fitted on the same window and simulated over it sample by sample, as `ndsid compare` does.

    Returns a dict: summary (data, noise floor, and per model its fit document with the RMSEs),
    samples (DataFrame at the fit rate: measured signals, ay_<label> / yaw_rate_<label> per model,
    scored, held_out), bins (DataFrame: per operating-condition bin and model, bias ± se, RMSE,
    verdict)."""
    d = _ndsid.compare(os.fspath(config), _logs(logs), None if effects is None else list(effects), list(baseline))
    samples = pd.DataFrame({k: v for k, v in d["samples"].items()})
    for flag in ("scored", "held_out"):
        samples[flag] = samples[flag].astype(bool)
    return {"summary": json.loads(d["summary"]), "samples": samples, "bins": pd.DataFrame(json.loads(d["bins"]))}


def run(*argv: str) -> int:
    """Any `ndsid` command in process, e.g. run("study", "--config", path): its exit status."""
    return _ndsid.run_command([str(a) for a in argv])


def diagnose(config: str | os.PathLike, logs: Optional[Iterable[str] | str] = None, *,
             effects: Optional[Sequence[str]] = None, candidates: Optional[Sequence[str]] = None,
             hold_out: Optional[Sequence[int]] = None, out: Optional[str | os.PathLike] = None) -> dict:
    """`ndsid diagnose` in process: step 0 (time alignment), the candidate ranking and the error
    ladder from the config's effects (or `effects`). Returns diagnosis.json as a dict with
    `ladder`, `ranking` and `alignment` also as DataFrames (keys ladder_df, ranking_df,
    alignment_df) and `report` (the folder written)."""
    out_dir = os.fspath(out) if out is not None else tempfile.mkdtemp(prefix="ndsid-diagnose-")
    argv = ["diagnose", "--config", os.fspath(config), "--out", out_dir]
    for log in _logs(logs):
        argv += ["--log", log]
    if effects is not None:
        argv += ["--effects", ",".join(effects) if effects else "none"]
    if candidates is not None:
        argv += ["--candidates", ",".join(candidates)]
    if hold_out:
        argv += ["--hold-out", ",".join(str(d) for d in hold_out)]
    rc = run(*argv)
    if rc != 0:
        raise Error(f"ndsid diagnose exited with {rc}")
    with open(os.path.join(out_dir, "diagnosis.json"), encoding="utf-8") as f:
        d = json.load(f)
    for key in ("ladder", "ranking", "alignment"):
        d[key + "_df"] = pd.DataFrame(d.get(key, []))
    d["report"] = out_dir
    return d


def study(config: str | os.PathLike, logs: Optional[Iterable[str] | str] = None, *,
          hours: Sequence[float] = (1.0, 2.0, 5.0), max_single: int = 20, validation_fraction: float = 0.15,
          seed: int = 1, truth: Optional[str | os.PathLike] = None, out: Optional[str | os.PathLike] = None) -> dict:
    """`ndsid study` in process: the study's subset analysis (single drives, independent sets of
    `hours` gated hours, all drives; each identified on its own and validated on drives held out
    from every set). Returns a dict: `sets` (DataFrame, one row per identified set: set, hours,
    eg_deg_per_g, eg_se_deg_per_g, rmse_validation, valid), `summary` (DataFrame, one row per set
    size, the terminal's table: EG min / median / max, spread in %, validation RMSE min / median /
    max / mean over the valid sets), `truth_eg_deg_per_g` (with `truth`, else None) and `report`
    (the folder written)."""
    hours = [float(h) for h in hours]  # checked by `ndsid study` before any work (ConfigError)
    out_dir = os.fspath(out) if out is not None else tempfile.mkdtemp(prefix="ndsid-study-")
    argv = ["study", "--config", os.fspath(config), "--out", out_dir, "--hours", ",".join(repr(h) for h in hours),
            "--max-single", str(int(max_single)), "--validation-fraction", repr(float(validation_fraction)),
            "--seed", str(int(seed))]
    for log in _logs(logs):
        argv += ["--log", log]
    if truth is not None:
        argv += ["--truth", os.fspath(truth)]
    rc = run(*argv)
    if rc != 0:
        raise Error(f"ndsid study exited with {rc}")
    sets = pd.read_csv(os.path.join(out_dir, "study.csv"))
    sets["valid"] = sets["valid"].astype(bool)
    summary = pd.read_csv(os.path.join(out_dir, "study_summary.csv"))
    truth_eg = None
    truth_path = os.path.join(out_dir, "study_truth.json")
    if os.path.exists(truth_path):
        with open(truth_path, encoding="utf-8") as f:
            truth_eg = json.load(f)["truth_eg_deg_per_g"]
    return {"sets": sets, "summary": summary, "truth_eg_deg_per_g": truth_eg, "report": out_dir}


def simulate(out: str | os.PathLike, *, config: Optional[str | os.PathLike] = None, hours: Optional[float] = None,
             seed: Optional[int] = None, effects: Optional[dict] = None, dbc: Optional[str | os.PathLike] = None) -> dict:
    """`ndsid simulate` in process: naturalistic drives (with hidden effects, e.g.
    {"steer_offset_deg": 1.0}) as a candump log with its truth.yaml in `out`. Returns the paths
    and the truth as a dict."""
    import yaml
    argv = ["simulate", "--out", os.fspath(out), "--gzip"]
    if config is not None:
        argv += ["--config", os.fspath(config)]
    if hours is not None:
        argv += ["--hours", repr(float(hours))]
    if seed is not None:
        argv += ["--seed", str(int(seed))]
    if dbc is not None:
        argv += ["--dbc", os.fspath(dbc)]
    for k, v in (effects or {}).items():
        argv += ["--effect", f"{k}={v}"]
    rc = run(*argv)
    if rc != 0:
        raise Error(f"ndsid simulate exited with {rc}")
    truth_path = os.path.join(os.fspath(out), "truth.yaml")
    with open(truth_path, encoding="utf-8") as f:
        truth = yaml.safe_load(f)
    log = os.path.join(os.fspath(out), "drive.log.gz")
    return {"log": log, "truth_path": truth_path, "truth": truth}


def fleet(manifest: Optional[str | os.PathLike] = None, *, dir: Optional[str | os.PathLike] = None,
          out: str | os.PathLike, workers: Optional[int] = None, scheduler: Optional[str] = None, client=None,
          extras: Sequence[str] = (), progress: bool = False):
    """`python -m ndsid fleet` in process (docs/fleet.md): every vehicle of a manifest (CSV or
    YAML) or of a folder (`dir`: FOLDER/<vehicle>/vehicle.yaml + logs/) replayed on Dask — a
    LocalCluster of `workers` processes, the cluster at `scheduler`, or a distributed.Client
    given as `client` — each log reduced as its own task, each vehicle merged and identified as
    one. `extras`: also diagnose, study, compare per vehicle. Returns a FleetResult: `table`
    (fleet.parquet: one row per vehicle), `drives` (drives.parquet), `failed` (vehicle ids),
    `priors` (per group), `exit_code` (0 all identified, 1 some failed). Raises
    ndsid.fleet_manifest.ManifestError (a ValueError) for a bad manifest."""
    from .fleet_run import run_fleet
    return run_fleet(manifest, dir, out=out, workers=workers, scheduler=scheduler, client=client, extras=extras,
                     progress=progress)
