"""Decoded time series (CSV) onto a DBC, as a candump log: recordings that come as signals, not
frames (a research car's exported runs, a data logger's CSV), replayed through the same
pipeline as a bus log.

    python -m ndsid encode --csv run1.csv run2.csv --dbc dbc/timeseries.dbc --map map.yaml --out drive.log.gz

The map (YAML, or a dict for `encode_csv`) names the time column and, per DBC signal, the CSV
column it carries, with an optional scale and offset (physical = scale * column + offset, in the
DBC signal's unit):

    time: t_s                    # seconds; each file's own time base
    interface: can0              # the candump interface name
    start_s: 1500000000          # absolute time of the first file's first row [s]
    gap_s: 120                   # bus silence between consecutive files (a new drive, > gate.drive_gap_s)
    signals:
      TS_STEERING.SteeringWheelAngle: {column: steer_sw_rad, scale: 57.29577951308232}
      TS_SPEED.VehicleSpeed: v_mps
    messages:                    # optional: TS_SPEED: {every: 2} sends it on every 2nd row
      TS_SPEED: {every: 1}

Every row sends each mapped message once, at the row's time, with its mapped signals (the
message's other signals are 0); a row whose value is missing (empty, NaN) sends no frame of
that message. The encoding is cantools' (signal ranges are not enforced: a value beyond a
signal's range saturates in its raw bits as a real ECU's would not; `encode_csv` reports how
many values were clipped). Rows must be in time order within a file."""
from __future__ import annotations

import gzip
import math
import os
from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

import numpy as np
import pandas as pd


@dataclass
class _SignalMap:
    signal: str
    column: str
    scale: float = 1.0
    offset: float = 0.0


def _read_map(mapping: Mapping | str | os.PathLike) -> dict:
    if isinstance(mapping, (str, os.PathLike)):
        import yaml
        with open(mapping, encoding="utf-8") as f:
            mapping = yaml.safe_load(f)
        if not isinstance(mapping, dict):
            raise ValueError(f"{os.fspath(mapping)}: the map must be a YAML mapping")
    return dict(mapping)


def _parse_signals(spec: Mapping, db) -> dict[str, list[_SignalMap]]:
    """message name -> its mapped signals, checked against the DBC."""
    by_message: dict[str, list[_SignalMap]] = {}
    for key, value in spec.items():
        if "." not in key:
            raise ValueError(f"signals: '{key}' must be MESSAGE.SIGNAL")
        msg_name, sig_name = key.split(".", 1)
        try:
            msg = db.get_message_by_name(msg_name)
        except KeyError:
            raise ValueError(f"signals: {key}: no message {msg_name} in the DBC") from None
        if sig_name not in [s.name for s in msg.signals]:
            raise ValueError(f"signals: {key}: message {msg_name} has no signal {sig_name}")
        if isinstance(value, str):
            m = _SignalMap(sig_name, value)
        elif isinstance(value, Mapping) and "column" in value:
            m = _SignalMap(sig_name, str(value["column"]), float(value.get("scale", 1.0)),
                           float(value.get("offset", 0.0)))
        else:
            raise ValueError(f"signals: {key}: give a column name or {{column, scale, offset}}")
        if not (math.isfinite(m.scale) and math.isfinite(m.offset)):
            raise ValueError(f"signals: {key}: scale and offset must be finite")
        by_message.setdefault(msg_name, []).append(m)
    if not by_message:
        raise ValueError("signals: map at least one DBC signal to a column")
    return by_message


def encode_csv(csvs: Sequence[str | os.PathLike] | str | os.PathLike, dbc: str | os.PathLike,
               mapping: Mapping | str | os.PathLike, out: str | os.PathLike) -> dict:
    """Writes the CSV files, one after the other, as one candump log (gzip when `out` ends in .gz).
    Returns {'frames', 'files', 'clipped', 'seconds'}."""
    import cantools

    if isinstance(csvs, (str, os.PathLike)):
        csvs = [csvs]
    spec = _read_map(mapping)
    db = cantools.database.load_file(os.fspath(dbc), strict=False)
    by_message = _parse_signals(spec.get("signals") or {}, db)
    time_col = str(spec.get("time", "t_s"))
    iface = str(spec.get("interface", "can0"))
    start = float(spec.get("start_s", 1.5e9))
    gap = float(spec.get("gap_s", 120.0))
    every = {name: int((cfg or {}).get("every", 1)) for name, cfg in (spec.get("messages") or {}).items()}
    if any(e < 1 for e in every.values()):
        raise ValueError("messages: every must be >= 1")
    if not gap > 0:
        raise ValueError("gap_s must be > 0")

    frames = clipped = 0
    t_next = start
    opener = gzip.open if os.fspath(out).endswith(".gz") else open
    with opener(out, "wt", encoding="ascii") as f:
        for path in csvs:
            df = pd.read_csv(path)
            if time_col not in df.columns:
                raise ValueError(f"{os.fspath(path)}: no time column '{time_col}'")
            t = df[time_col].to_numpy(dtype=float)
            if len(t) == 0:
                continue
            if np.any(np.diff(t) < 0):
                raise ValueError(f"{os.fspath(path)}: the time column '{time_col}' goes backwards")
            t_abs = t - t[0] + t_next
            lines: list[tuple[float, int, str]] = []
            for msg_name, maps in by_message.items():
                msg = db.get_message_by_name(msg_name)
                values = {}
                for m in maps:
                    if m.column not in df.columns:
                        raise ValueError(f"{os.fspath(path)}: no column '{m.column}' (for {msg_name}.{m.signal})")
                    values[m.signal] = df[m.column].to_numpy(dtype=float) * m.scale + m.offset
                ranges = {s.name: (s.minimum, s.maximum) for s in msg.signals}
                others = {s.name: 0 for s in msg.signals if s.name not in values}
                id_text = f"{msg.frame_id:08X}" if msg.is_extended_frame else f"{msg.frame_id:03X}"
                step = every.get(msg_name, 1)
                for k in range(0, len(t), step):
                    row = dict(others)
                    missing = False
                    for name, series in values.items():
                        x = series[k]
                        if not math.isfinite(x):
                            missing = True
                            break
                        lo, hi = ranges[name]
                        if (lo is not None and x < lo) or (hi is not None and x > hi):
                            x = min(max(x, lo if lo is not None else x), hi if hi is not None else x)
                            clipped += 1
                        row[name] = x
                    if missing:
                        continue
                    data = msg.encode(row, scaling=True, padding=False, strict=False)
                    lines.append((t_abs[k], msg.frame_id, f"{id_text}#{data.hex().upper()}"))
            lines.sort(key=lambda x: (x[0], x[1]))
            for ts, _, body in lines:
                f.write(f"({ts:.6f}) {iface} {body}\n")
            frames += len(lines)
            t_next = t_abs[-1] + gap
    return {"frames": frames, "files": len(csvs), "clipped": clipped, "seconds": t_next - gap - start}
