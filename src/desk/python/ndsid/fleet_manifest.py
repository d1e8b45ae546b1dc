"""The vehicles of a fleet (docs/fleet.md): a manifest (CSV or YAML) or a folder of vehicles.

Manifest columns (CSV header or YAML keys of each entry under `vehicles:`):
    vehicle  the vehicle's id (unique)
    config   its vehicle configuration (YAML)
    logs     its logs: paths or globs (CSV: separated by ';'); empty: the config's source.logs
    group    its model/variant (vehicles of one group are compared and share a fleet prior); optional
Other columns are kept and carried into the fleet table. Relative paths are relative to the
manifest's folder; a glob's matches are taken in name order.

A folder: FOLDER/<vehicle>/vehicle.yaml, the logs in FOLDER/<vehicle>/logs/ (every file in name
order but notes: *.yaml, *.yml, *.json, *.txt, *.md, *.csv), the group in FOLDER/<vehicle>/group.txt
(optional, one line).
"""
from __future__ import annotations

import csv
import glob
import os
import re
from dataclasses import dataclass, field

NOTE_SUFFIXES = (".yaml", ".yml", ".json", ".txt", ".md", ".csv")
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


class ManifestError(ValueError):
    """A manifest that cannot be used at all (exit 78): unreadable, a required column missing,
    a vehicle id repeated or not usable as a folder name."""


@dataclass
class Vehicle:
    vehicle: str
    config: str                 # absolute path
    logs: list[str]             # absolute paths, in reading order; empty: the config's source.logs
    group: str = ""
    extra: dict = field(default_factory=dict)  # further manifest columns
    problem: str = ""           # why its logs cannot be listed (e.g. a glob matching nothing)


def _expand(patterns: list[str], base: str) -> tuple[list[str], str]:
    logs: list[str] = []
    for p in patterns:
        p = os.path.expanduser(p.strip())
        if not p:
            continue
        full = p if os.path.isabs(p) else os.path.join(base, p)
        if glob.has_magic(full):
            matches = sorted(glob.glob(full))
            if not matches:
                return [], f"no log matches {p}"
            logs += [os.path.abspath(m) for m in matches]
        else:
            logs.append(os.path.abspath(full))
    return logs, ""


def _entry(row: dict, base: str, where: str) -> Vehicle:
    vid = str(row.get("vehicle") or "").strip()
    cfg = str(row.get("config") or "").strip()
    if not vid or not cfg:
        raise ManifestError(f"{where}: needs a vehicle and a config")
    if not _ID.match(vid):
        raise ManifestError(f"{where}: vehicle id {vid!r} must be letters, digits, '.', '_' or '-' (it names a folder)")
    raw = row.get("logs")
    if raw is None:
        patterns = []
    elif isinstance(raw, (list, tuple)):
        patterns = [str(x) for x in raw]
    else:
        patterns = [x for x in str(raw).split(";")]
    logs, problem = _expand(patterns, base)
    extra = {k: v for k, v in row.items() if k not in ("vehicle", "config", "logs", "group") and k}
    config = cfg if os.path.isabs(cfg) else os.path.join(base, cfg)
    return Vehicle(vid, os.path.abspath(config), logs, str(row.get("group") or "").strip(), extra, problem)


def read_manifest(path: str | os.PathLike) -> list[Vehicle]:
    """The vehicles of a CSV or YAML manifest, in its order. Raises ManifestError."""
    path = os.fspath(path)
    base = os.path.dirname(os.path.abspath(path))
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise ManifestError(f"{path}: {e.strerror}") from None
    if path.lower().endswith((".yaml", ".yml")):
        import yaml
        try:
            doc = yaml.safe_load(text)
        except yaml.YAMLError as e:
            raise ManifestError(f"{path}: not YAML: {e}") from None
        rows = doc.get("vehicles") if isinstance(doc, dict) else doc
        if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
            raise ManifestError(f"{path}: needs a list of vehicles (each a mapping), under 'vehicles:' or at the top")
        where = [f"{path}: vehicles[{i}]" for i in range(len(rows))]
    else:
        reader = csv.DictReader(text.splitlines())
        missing = {"vehicle", "config"} - set(reader.fieldnames or [])
        if missing:
            raise ManifestError(f"{path}: the header lacks {', '.join(sorted(missing))} (columns: vehicle, config, logs, group)")
        rows = list(reader)
        where = [f"{path}:{i + 2}" for i in range(len(rows))]
    vehicles = [_entry(r, base, w) for r, w in zip(rows, where)]
    return _checked(vehicles, path)


def scan_folder(folder: str | os.PathLike) -> list[Vehicle]:
    """The vehicles of FOLDER/<vehicle>/vehicle.yaml (+ logs/, group.txt), in name order."""
    folder = os.path.abspath(os.fspath(folder))
    if not os.path.isdir(folder):
        raise ManifestError(f"{folder}: not a folder")
    vehicles = []
    for name in sorted(os.listdir(folder)):
        config = os.path.join(folder, name, "vehicle.yaml")
        if not os.path.isfile(config):
            continue
        if not _ID.match(name):
            raise ManifestError(f"{folder}/{name}: a vehicle folder's name must be letters, digits, '.', '_' or '-'")
        log_dir = os.path.join(folder, name, "logs")
        logs = []
        if os.path.isdir(log_dir):
            logs = [os.path.join(log_dir, f) for f in sorted(os.listdir(log_dir))
                    if os.path.isfile(os.path.join(log_dir, f)) and not f.lower().endswith(NOTE_SUFFIXES)]
        group = ""
        group_file = os.path.join(folder, name, "group.txt")
        if os.path.isfile(group_file):
            with open(group_file, encoding="utf-8") as f:
                group = f.readline().strip()
        vehicles.append(Vehicle(name, config, logs, group, {}, "" if logs else f"no logs in {log_dir}"))
    return _checked(vehicles, folder)


def _checked(vehicles: list[Vehicle], source: str) -> list[Vehicle]:
    if not vehicles:
        raise ManifestError(f"{source}: no vehicles")
    seen: set[str] = set()
    for v in vehicles:
        if v.vehicle in seen:
            raise ManifestError(f"{source}: vehicle {v.vehicle!r} listed twice")
        seen.add(v.vehicle)
    return vehicles
