"""`ndsid fleet` on Dask distributed (docs/fleet.md): every log reduced as its own task, each
vehicle's reductions merged and identified as one task, results written as vehicles finish.

OUT/vehicles/<vehicle>/result.json   the vehicle's replay document, its error, its inputs' hashes
OUT/fleet.parquet, OUT/drives.parquet, OUT/fleet-report.html, OUT/groups/<group>/fleet_prior.yaml
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

from . import fleet_tasks
from .fleet_manifest import Vehicle, read_manifest, scan_folder

EXTRAS = ("diagnose", "study", "compare")
RESULT_FORMAT = 1


@dataclass
class Plan:
    """One vehicle's work: what it reads and the hashes that decide whether it must run."""
    vehicle: Vehicle
    logs: list[str] = field(default_factory=list)
    config_hash: str = ""
    error: str = ""
    error_kind: str = ""


def _blake(*parts: bytes) -> str:
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        h.update(p)
        h.update(b"\0")
    return h.hexdigest()


def _engine_hash() -> str:
    """The compiled core's hash: a rebuilt engine may give other numbers, so reruns redo all."""
    from . import _ndsid
    return fleet_tasks.hash_file(_ndsid.__file__)


def _plan(v: Vehicle, engine: str) -> Plan:
    import ndsid
    p = Plan(v)
    try:
        cfg = ndsid.load_config(v.config)
        with open(v.config, "rb") as f:
            config_bytes = f.read()
        with open(cfg["dbc"], "rb") as f:
            dbc_bytes = f.read()
    except ndsid.ConfigError as e:
        p.error, p.error_kind = str(e), "config"
        return p
    except (ndsid.Error, OSError) as e:
        p.error, p.error_kind = str(e), "config"
        return p
    p.config_hash = _blake(engine.encode(), config_bytes, dbc_bytes)
    p.logs = list(v.logs) or list(cfg["logs"])
    if v.problem:
        p.error, p.error_kind = v.problem, "input"
    elif not p.logs:
        p.error, p.error_kind = "no logs (neither in the manifest nor in the config's source.logs)", "input"
    return p


def _vehicle_dir(out: str, vid: str) -> str:
    return os.path.join(out, "vehicles", vid)


def _previous(out: str, vid: str) -> Optional[dict]:
    path = os.path.join(_vehicle_dir(out, vid), "result.json")
    try:
        with open(path, encoding="utf-8") as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None
    return rec if rec.get("format") == RESULT_FORMAT else None


def _write_record(out: str, rec: dict) -> None:
    d = _vehicle_dir(out, rec["vehicle"])
    os.makedirs(d, exist_ok=True)
    tmp = os.path.join(d, "result.json.tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(rec, f)
    os.replace(tmp, os.path.join(d, "result.json"))


def _record(plan: Plan, inputs: Optional[dict], result: Optional[dict], error: str, kind: str) -> dict:
    v = plan.vehicle
    return {"format": RESULT_FORMAT, "vehicle": v.vehicle, "group": v.group, "config": v.config, "extra": v.extra,
            "logs": plan.logs, "inputs": inputs, "error": error, "error_kind": kind, "result": result, "reused": False}


class _Cluster:
    """The Dask client: the one given, a scheduler's, or a LocalCluster on this machine."""

    def __init__(self, workers: Optional[int], scheduler: Optional[str], client=None):
        from distributed import Client, LocalCluster
        self.own_cluster = None
        if client is not None:
            self.client, self.own_client = client, False
            return
        self.own_client = True
        if scheduler:
            self.client = Client(scheduler)
        else:
            n = workers or max(1, os.cpu_count() or 1)
            self.own_cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                            silence_logs=logging.ERROR)
            self.client = Client(self.own_cluster)

    def close(self):
        if self.own_client:
            self.client.close()
        if self.own_cluster is not None:
            self.own_cluster.close()


def _worker_peaks_mb(client) -> dict:
    """Each worker process's peak resident memory [MB] (since it started)."""
    def peak() -> float:
        import resource
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    try:
        return client.run(peak)
    except Exception:  # noqa: BLE001 - a figure for the summary only
        return {}


def _progress_bar(futures: list) -> Optional[threading.Thread]:
    from distributed import progress
    if not futures:
        return None
    t = threading.Thread(target=progress, args=(futures,), kwargs={"notebook": False}, daemon=True)
    t.start()
    return t


def _submit(client, plans: dict[str, Plan], out: str, extras: Sequence[str], echo) -> tuple[dict, dict, list]:
    """Hashes the inputs, reuses unchanged vehicles' results, submits the rest. Returns the
    finished records, {future: (plan, inputs)} of the identifications and the extras' futures."""
    unique = sorted({p for plan in plans.values() if not plan.error for p in plan.logs})
    hashes = {p: client.submit(fleet_tasks.hash_file, p, key="hash-" + _blake(p.encode()), pure=False) for p in unique}
    done: dict[str, dict] = {}
    pending: dict = {}
    extra_futures: list = []
    for vid, plan in plans.items():
        if plan.error:
            done[vid] = _record(plan, None, None, plan.error, plan.error_kind)
            continue
        try:
            log_hashes = client.gather([hashes[p] for p in plan.logs])
        except fleet_tasks.VehicleError as e:
            done[vid] = _record(plan, None, None, str(e), e.kind)
            continue
        inputs = {"config": plan.config_hash, "logs": [[p, h] for p, h in zip(plan.logs, log_hashes)]}
        prev = _previous(out, vid)
        if prev and prev.get("inputs") == inputs and not prev.get("error") and prev.get("result") is not None:
            prev.update(reused=True, group=plan.vehicle.group, extra=plan.vehicle.extra)
            done[vid] = prev
            continue
        reductions = [client.submit(fleet_tasks.reduce_logs, plan.vehicle.config, [p],
                                    key=f"reduce-{plan.config_hash}-{h}-{i}", pure=False)
                      for i, (p, h) in enumerate(zip(plan.logs, log_hashes))]
        inputs_key = _blake(json.dumps(inputs).encode())
        fut = client.submit(fleet_tasks.identify, plan.vehicle.config, reductions, key=f"identify-{vid}-{inputs_key}",
                            pure=False)
        pending[fut] = (plan, inputs)
        for kind in extras:
            extra_futures.append(client.submit(fleet_tasks.extra, kind, plan.vehicle.config, plan.logs,
                                               os.path.join(_vehicle_dir(out, vid), kind), key=f"{kind}-{vid}-{inputs_key}",
                                               pure=False))
    reused = sum(1 for r in done.values() if r.get("reused"))
    if reused:
        echo(f"{reused} vehicle(s) unchanged since the last run: their results are reused")
    return done, pending, extra_futures


def _collect(pending: dict, out: str, done: dict, echo, quiet: bool) -> None:
    from distributed import as_completed
    for fut in as_completed(list(pending)):
        plan, inputs = pending[fut]
        vid = plan.vehicle.vehicle
        try:
            rec = _record(plan, inputs, fut.result(), "", "")
        except fleet_tasks.VehicleError as e:
            rec = _record(plan, inputs, None, str(e), e.kind)
        except Exception as e:  # noqa: BLE001 - e.g. KilledWorker after the retries: that vehicle's error
            rec = _record(plan, inputs, None, f"{type(e).__name__}: {e}", "error")
        _write_record(out, rec)
        done[vid] = rec
        if not quiet:
            est = (rec["result"] or {}).get("estimate") or {}
            text = rec["error"] or (f"EG {est.get('eg_deg_per_g', float('nan')):.4f} ± {est.get('eg_se_deg_per_g', float('nan')):.4f}"
                                    f" deg/g{'' if est.get('valid') else ' NOT VALID'}")
            echo(f"{vid}: {text}")
        fut.release()


def run_fleet(manifest: Optional[str | os.PathLike] = None, folder: Optional[str | os.PathLike] = None, *,
              out: str | os.PathLike, workers: Optional[int] = None, scheduler: Optional[str] = None, client=None,
              extras: Sequence[str] = (), progress: bool = False, echo: Callable[[str], None] = print):
    """Runs the fleet; returns the FleetResult (fleet_tables.py). Raises ManifestError."""
    from .fleet_tables import write_outputs
    if (manifest is None) == (folder is None):
        raise ValueError("give a manifest or a folder")
    for kind in extras:
        if kind not in EXTRAS:
            raise ValueError(f"unknown extra {kind!r}: {', '.join(EXTRAS)}")
    vehicles = read_manifest(manifest) if manifest is not None else scan_folder(folder)
    out = os.path.abspath(os.fspath(out))
    os.makedirs(out, exist_ok=True)
    t0 = time.monotonic()
    engine = _engine_hash()
    plans = {v.vehicle: _plan(v, engine) for v in vehicles}
    cluster = _Cluster(workers, scheduler, client)
    try:
        c = cluster.client
        echo(f"ndsid fleet: {len(vehicles)} vehicles on {len(c.scheduler_info()['workers'])} worker(s); "
             f"dashboard {c.dashboard_link}")
        done, pending, extra_futures = _submit(c, plans, out, extras, echo)
        bar = _progress_bar(list(pending) + extra_futures) if progress else None
        _collect(pending, out, done, echo, quiet=bar is not None)
        for f in extra_futures:
            try:
                f.result()
            except Exception as e:  # noqa: BLE001 - an extra's failure is reported, the replay stands
                echo(f"{f.key}: {e}")
        if bar is not None:
            bar.join(timeout=5)
            echo("")
        peak_mb = _worker_peaks_mb(c)
    finally:
        cluster.close()
    records = [done[v.vehicle] for v in vehicles]
    result = write_outputs(records, out, wall_s=time.monotonic() - t0, computed=len(pending))
    result.worker_peak_mb = peak_mb
    return result
