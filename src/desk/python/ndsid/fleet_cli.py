"""python -m ndsid fleet: many vehicles on Dask (docs/fleet.md).

    python -m ndsid fleet (--manifest FILE | --dir FOLDER) --out FOLDER [--workers N | --scheduler ADDR]
                          [--with diagnose,study,compare] [--no-progress]
    python -m ndsid fleet prior (--fleet OUT/fleet.parquet --group G | --prior fleet_prior.yaml)
                                --config car.yaml --out car_with_prior.yaml
    python -m ndsid fleet prior --fleet OUT/fleet.parquet --group G     (OUT/groups/G/fleet_prior.yaml again)
    python -m ndsid fleet simulate --out FOLDER [--classes cmax,van] [--per-class 3] [--logs 2] [--drives 3] [--seed 1]

Exit status: 0 every vehicle identified, 1 some failed (each with its error in its row), 78 a
bad manifest or argument.
"""
from __future__ import annotations

import argparse
import os
import sys

EXIT_CONFIG = 78


def _run(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="python -m ndsid fleet", description="ndsid over a fleet of vehicles, on Dask")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--manifest", help="CSV or YAML: vehicle, config, logs (paths or globs), group")
    src.add_argument("--dir", help="FOLDER/<vehicle>/vehicle.yaml with the logs in FOLDER/<vehicle>/logs/")
    p.add_argument("--out", required=True, help="output folder (results are reused from it when inputs did not change)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="a LocalCluster of N worker processes (default: one per core)")
    where.add_argument("--scheduler", help="an existing Dask cluster, e.g. tcp://host:8786")
    p.add_argument("--with", dest="extras", default="", help="also per vehicle: diagnose, study, compare (comma-separated)")
    p.add_argument("--no-progress", action="store_true", help="one line per vehicle instead of Dask's progress bar")
    a = p.parse_args(argv)
    from .fleet_manifest import ManifestError
    from .fleet_run import run_fleet
    if a.workers is not None and a.workers < 1:
        p.error("--workers must be >= 1")
    extras = [x for x in a.extras.split(",") if x]
    try:
        r = run_fleet(a.manifest, a.dir, out=a.out, workers=a.workers, scheduler=a.scheduler, extras=extras,
                      progress=not a.no_progress)
    except (ManifestError, ValueError) as e:
        print(f"python -m ndsid fleet: {e}", file=sys.stderr)
        return EXIT_CONFIG
    ok = len(r.table) - len(r.failed)
    print(f"{ok} of {len(r.table)} vehicles identified ({r.computed} computed now, {r.wall_s:.1f} s); "
          f"{os.path.join(r.out, 'fleet.parquet')}, {os.path.join(r.out, 'fleet-report.html')}")
    if r.worker_peak_mb:
        print(f"  peak memory per worker: {max(r.worker_peak_mb.values()):.0f} MB (largest of {len(r.worker_peak_mb)})")
    for vid in r.failed:
        err = r.table.loc[r.table["vehicle"] == vid, "error"].iloc[0]
        print(f"  failed: {vid}: {err}", file=sys.stderr)
    flagged = r.table[r.table["eg_outlier"] | r.table["prior_conflict"]]["vehicle"].tolist()
    if flagged:
        print(f"  flagged (outlier of its group or contradicting its prior): {', '.join(flagged)}")
    return r.exit_code


def _prior(argv: list[str]) -> int:
    import ndsid
    from . import fleet_prior
    from .fleet_config import write_config_with_priors
    p = argparse.ArgumentParser(prog="python -m ndsid fleet prior",
                                description="a vehicle configuration starting from its group's fleet prior (model.priors)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--fleet", help="a fleet's fleet.parquet (with --group)")
    src.add_argument("--prior", help="a fleet_prior.yaml")
    p.add_argument("--group", help="the group of the new vehicle (with --fleet)")
    p.add_argument("--config", help="the new vehicle's configuration (without it, with --fleet: write the group's "
                                    "fleet_prior.yaml beside the table again)")
    p.add_argument("--out", help="the configuration to write (with model.priors)")
    a = p.parse_args(argv)
    if a.config is not None and a.out is None:
        p.error("--config needs --out")
    if a.config is None and not a.fleet:
        p.error("--prior needs --config and --out")
    try:
        if a.fleet:
            import pandas as pd
            if a.group is None:
                raise ndsid.ConfigError("--fleet needs --group")
            prior = fleet_prior.group_prior(pd.read_parquet(a.fleet), a.group)
            if prior is None:
                raise ndsid.ConfigError(f"{a.fleet}: group {a.group!r} has fewer than {fleet_prior.MIN_VEHICLES} "
                                        "valid vehicles with every parameter free and off its bounds")
            if a.config is None:
                print(f"{fleet_prior.write_group_prior(a.fleet, prior)}: the prior of group {a.group} from {a.fleet}")
                return 0
        else:
            prior = fleet_prior.load_prior(a.prior)
        mass = ndsid.load_config(a.config)["vehicle"]["mass_kg"]
        priors = fleet_prior.priors_for_config(prior, mass)
        note = f"fleet prior of group {prior.get('group', '?')} ({len(prior.get('vehicles', []))} vehicles)"
        write_config_with_priors(a.config, priors, a.out, note)
    except (ndsid.ConfigError, ValueError, OSError) as e:
        print(f"python -m ndsid fleet prior: {e}", file=sys.stderr)
        return EXIT_CONFIG
    for name, pr in priors.items():
        print(f"  {name}: {pr['value']:.6g} ± {pr['sd']:.3g}")
    print(f"{a.out}: model.priors from the fleet prior of group {prior.get('group')}")
    return 0


def _simulate(argv: list[str]) -> int:
    from . import fleet_sim
    p = argparse.ArgumentParser(prog="python -m ndsid fleet simulate", description="a simulated fleet for --dir")
    p.add_argument("--out", required=True)
    p.add_argument("--classes", default="cmax,van,city", help=f"of {', '.join(fleet_sim.CLASSES)}")
    p.add_argument("--per-class", type=int, default=3)
    p.add_argument("--logs", type=int, default=2, help="logs per vehicle")
    p.add_argument("--drives", type=int, default=3, help="drives per log")
    p.add_argument("--hours", type=float, help="hours of driving per log (instead of --drives)")
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    variants = [fleet_sim.Variant(), fleet_sim.Variant(load_pct=15), fleet_sim.Variant(tyre_pct=-8),
                fleet_sim.Variant(ratio_pct=4)]
    seed = a.seed
    for cls in [c for c in a.classes.split(",") if c]:
        if cls not in fleet_sim.CLASSES:
            print(f"python -m ndsid fleet simulate: unknown class {cls!r}", file=sys.stderr)
            return EXIT_CONFIG
        for k in range(a.per_class):
            v = fleet_sim.make_vehicle(a.out, f"{cls}-{k + 1:02d}", cls, variants[k % len(variants)], logs=a.logs,
                                       hours_per_log=a.hours, drives_per_log=a.drives, seed=seed)
            seed += 1
            print(f"{v['vehicle']}: {len(v['logs'])} logs, truth EG {v['truth_eg_deg_per_g']}")
    return 0


def main(argv: list[str]) -> int:
    if argv and argv[0] == "prior":
        return _prior(argv[1:])
    if argv and argv[0] == "simulate":
        return _simulate(argv[1:])
    return _run(argv)
