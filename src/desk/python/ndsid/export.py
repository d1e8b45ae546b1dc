"""Interchange files (docs/python.md, "Export"): decoded signals and compare's tables as Parquet
(pyarrow, from the project venv), decoded signals as ASAM MDF 4 (asammdf).

    from ndsid import export
    export.decode_to_parquet("drive.log.gz", "car.dbc", "signals.parquet", wide=True, rate_hz=50)
    export.decode_to_mf4("drive.log.gz", "car.dbc", "signals.mf4")
    export.compare_to_parquet("config/example_vehicle.yaml", "out/")

The same from a shell: python -m ndsid decode|compare ... --out FILE|DIR (python -m ndsid -h).

Parquet keeps the columns' types (the long form's message and signal as dictionary-encoded
categoricals, t_s as float64 seconds since the epoch) and the decode counters as file metadata
(frames, malformed, format). MDF 4 holds one channel group per CAN message, each signal a channel
on its message's own time stamps (as bus-logging tools write them; a multiplexed signal gets a
group of its own, on the time stamps of its page), so no value is resampled.
There is no Parquet writer in the C++ CLI: Debian 12 packages no Arrow C++.
"""
from __future__ import annotations

import datetime
import json
import os
from typing import Iterable, Optional, Sequence

import numpy as np
import pandas as pd

from . import compare as _compare
from . import decode as _decode

__all__ = ["write_parquet", "read_parquet_metadata", "decode_to_parquet", "decode_to_mf4", "compare_to_parquet"]

_META_KEY = b"ndsid"


def write_parquet(df: pd.DataFrame, path: str | os.PathLike, metadata: Optional[dict] = None) -> str:
    """`df` as a Parquet file (pyarrow, zstd), with `metadata` (default: df.attrs) as JSON under
    the file's key "ndsid". Returns the path."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[_META_KEY] = json.dumps(df.attrs if metadata is None else metadata, default=str).encode()
    pq.write_table(table.replace_schema_metadata(meta), os.fspath(path), compression="zstd")
    return os.fspath(path)


def read_parquet_metadata(path: str | os.PathLike) -> dict:
    """The "ndsid" metadata write_parquet stored in a file ({} if none)."""
    import pyarrow.parquet as pq

    meta = pq.read_schema(os.fspath(path)).metadata or {}
    return json.loads(meta[_META_KEY]) if _META_KEY in meta else {}


def decode_to_parquet(log: str | os.PathLike, dbc: str | os.PathLike, path: str | os.PathLike, *, bus: str = "",
                      wide: bool = False, rate_hz: Optional[float] = None) -> pd.DataFrame:
    """ndsid.decode(...) written to `path` as Parquet; returns the DataFrame."""
    df = _decode(log, dbc, bus=bus, wide=wide, rate_hz=rate_hz)
    attrs = dict(df.attrs)
    attrs.update(log=os.fspath(log), dbc=os.fspath(dbc), form="wide" if wide else "long",
                 rate_hz=rate_hz)
    write_parquet(df, path, attrs)
    return df


def decode_to_mf4(log: str | os.PathLike, dbc: str | os.PathLike, path: str | os.PathLike, *, bus: str = "") -> int:
    """Every decoded signal of a log as an ASAM MDF 4.10 file: one channel group per message
    (named after it; a multiplexed signal's own group), one channel per signal
    ("message.signal"), the message's own time stamps
    (seconds since the log's first decoded frame; the absolute start is the file's start time).
    Returns the number of channels written."""
    from asammdf import MDF, Signal

    df = _decode(log, dbc, bus=bus)
    mdf = MDF(version="4.10")
    channels = 0
    if len(df):
        t0 = float(df["t_s"].min())
        mdf.header.start_time = datetime.datetime.fromtimestamp(t0, tz=datetime.timezone.utc)
        for message, rows in df.groupby("message", observed=True, sort=False):
            table = rows.pivot_table(index="t_s", columns="signal", values="value", aggfunc="last", observed=True)
            t = table.index.to_numpy(dtype=np.float64) - t0
            # Signals in every frame of the message share its group; a multiplexed signal (in the
            # frames of its page only) gets a group of its own, on its own time stamps.
            full = [s for s in table.columns if not table[s].isna().any()]
            if full:
                mdf.append([Signal(samples=table[s].to_numpy(dtype=np.float64), timestamps=t, name=f"{message}.{s}")
                            for s in full], comment=str(message), common_timebase=True)
            for s in table.columns:
                if s in full:
                    continue
                present = table[s].notna().to_numpy()
                mdf.append([Signal(samples=table[s].to_numpy(dtype=np.float64)[present], timestamps=t[present],
                                   name=f"{message}.{s}")], comment=f"{message} (multiplexed: {s})")
            channels += len(table.columns)
    mdf.save(os.fspath(path), overwrite=True)
    mdf.close()
    return channels


def compare_to_parquet(config: str | os.PathLike, folder: str | os.PathLike, logs: Optional[Iterable[str] | str] = None,
                       *, effects: Optional[Sequence[str]] = None, baseline: Sequence[str] = ()) -> dict:
    """ndsid.compare(...) written to `folder`: samples.parquet (measured and modelled outputs per
    sample at the fit rate), bins.parquet (where it fails: bias, RMSE, verdict per bin and model)
    and summary.json; the summary is also each Parquet file's metadata. Returns the paths."""
    r = _compare(config, logs, effects=effects, baseline=baseline)
    os.makedirs(folder, exist_ok=True)
    out = {"samples": os.path.join(folder, "samples.parquet"), "bins": os.path.join(folder, "bins.parquet"),
           "summary": os.path.join(folder, "summary.json")}
    write_parquet(r["samples"], out["samples"], r["summary"])
    write_parquet(r["bins"], out["bins"], r["summary"])
    with open(out["summary"], "w", encoding="utf-8") as f:
        json.dump(r["summary"], f, indent=1)
    return out
