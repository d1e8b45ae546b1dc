"""The work of `ndsid fleet` as Dask tasks (docs/fleet.md): plain functions of paths and bytes,
run on any worker that sees the same files.

    hash_file(path)                  content hash of one input
    reduce_logs(config, logs)        decode + sync + gate + statistics of one log: a reduction (bytes)
    identify(config, reductions)     a vehicle's reductions merged in log order, the final fit
    extra(kind, config, logs, out)   diagnose / study / compare of one vehicle into its folder

Errors leave a task as VehicleError (picklable; `kind` "config" for a configuration error,
"input" for unreadable logs, else "error"), so the client can put them in the vehicle's row.
"""
from __future__ import annotations

import hashlib
import json
import os

CHUNK = 1 << 20


class VehicleError(Exception):
    """A vehicle's task failed for a reason of its own (its config, its logs)."""

    def __init__(self, message: str, kind: str = "error"):
        super().__init__(message)
        self.kind = kind

    def __reduce__(self):
        return (VehicleError, (str(self), self.kind))


def _quiet():
    from . import _ndsid
    _ndsid.set_log_level("error")  # workers' stderr: the errors only
    return _ndsid


def _wrap(fn, *args):
    import ndsid
    try:
        return fn(*args)
    except ndsid.ConfigError as e:
        raise VehicleError(str(e), "config") from None
    except ndsid.Error as e:
        raise VehicleError(str(e), "input") from None
    except OSError as e:
        raise VehicleError(f"{e.filename}: {e.strerror}", "input") from None


def hash_file(path: str) -> str:
    """BLAKE2b (128 bit) of the file's content, hex."""
    h = hashlib.blake2b(digest_size=16)
    try:
        with open(path, "rb") as f:
            while True:
                block = f.read(CHUNK)
                if not block:
                    break
                h.update(block)
    except OSError as e:
        raise VehicleError(f"{path}: {e.strerror}", "input") from None
    return h.hexdigest()


def reduce_logs(config: str, logs: list[str]) -> bytes:
    """The logs read to their end by a fresh pipeline: the reduction document (CBOR)."""
    core = _quiet()
    return _wrap(core.reduce, config, list(logs))


def identify(config: str, reductions: list[bytes]) -> dict:
    """The vehicle's reductions merged in log order and identified: the replay document
    (as ndsid.replay(config, logs, final_only=True) returns it before its DataFrames)."""
    core = _quiet()
    return json.loads(_wrap(core.identify_reduced, config, list(reductions)))


def extra(kind: str, config: str, logs: list[str], out: str) -> dict:
    """`diagnose`, `study` or `compare` of one vehicle, written into `out`; a summary dict."""
    import ndsid
    _quiet()
    os.makedirs(out, exist_ok=True)

    def run():
        if kind == "diagnose":
            d = ndsid.diagnose(config, logs, out=out)
            return {"report": d["report"]}
        if kind == "study":
            s = ndsid.study(config, logs, out=out)
            return {"report": s["report"], "sets": len(s["sets"])}
        if kind == "compare":
            from . import export
            return {k: str(v) for k, v in export.compare_to_parquet(config, out, logs).items()}
        raise VehicleError(f"unknown extra {kind!r} (diagnose, study, compare)", "config")

    return _wrap(run)
