#!/usr/bin/env python3
"""ndsid fleet against the serial replay loop (bench/README.md, "Fleet").

    fleet_bench.py make WORK VEHICLES HOURS     simulate VEHICLES cars (classes cmax, van, city in turn)
                                                with 2 logs of HOURS/2 h of driving each into WORK/fleet
    fleet_bench.py run WORK [ROUNDS] [WORKERS…]  whole processes, in turn per round: the serial loop
                                                (`ndsid replay --final-only` per vehicle, one after the
                                                other) and `python -m ndsid fleet --workers W` for each W
                                                (default 1 2); medians of the wall and CPU seconds,
                                                vehicle-hours per core-second, peak memory per worker

Vehicle-hours are the hours of driving in the logs (the drives' durations), core-seconds the
wall time times the cores the run may use (the serial loop: 1 core; W workers: W cores).
"""
import glob
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = os.environ.get("BUILD_DIR", os.path.join(ROOT, "build"))


def make(work: str, vehicles: int, hours: float) -> None:
    from ndsid import fleet_sim
    classes = list(fleet_sim.CLASSES)
    for k in range(vehicles):
        fleet_sim.make_vehicle(os.path.join(work, "fleet"), f"v{k + 1:03d}", classes[k % len(classes)], logs=2,
                               hours_per_log=hours / 2, seed=500 + k)


def driving_hours(out: str) -> float:
    """Hours of driving in the logs: the drives' durations (drives.parquet of a fleet run)."""
    import pandas as pd
    return float(pd.read_parquet(os.path.join(out, "drives.parquet"))["duration_s"].sum()) / 3600.0


def timed(cmd: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds (user + system of the process and all it waited for) of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd[:4])}…: exit {p.returncode}\n{p.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, p.stdout


def serial_cmd(work: str) -> list[str]:
    script = []
    for v in sorted(glob.glob(os.path.join(work, "fleet", "*", "vehicle.yaml"))):
        logs = sorted(glob.glob(os.path.join(os.path.dirname(v), "logs", "*.log.gz")))
        args = " ".join(f"--log {log}" for log in logs)
        script.append(f"{BUILD}/bin/ndsid replay --config {v} {args} --final-only --report {work}/serial-report >/dev/null")
    return ["sh", "-c", " && ".join(script)]


def fleet_cmd(work: str, workers: int) -> list[str]:
    out = os.path.join(work, f"out{workers}")
    shutil.rmtree(out, ignore_errors=True)  # a rerun would reuse the results
    return [sys.executable, "-m", "ndsid", "fleet", "--dir", os.path.join(work, "fleet"), "--out", out,
            "--workers", str(workers), "--no-progress"]


def run(work: str, rounds: int, workers: list[int]) -> None:
    n = len(glob.glob(os.path.join(work, "fleet", "*", "vehicle.yaml")))
    sides = {"serial": []} | {f"fleet {w}w": [] for w in workers}
    peaks = {w: [] for w in workers}
    for _ in range(rounds):
        sides["serial"].append(timed(serial_cmd(work))[:2])
        for w in workers:
            wall, cpu, out = timed(fleet_cmd(work, w))
            sides[f"fleet {w}w"].append((wall, cpu))
            m = re.search(r"peak memory per worker: (\d+) MB", out)
            if m:
                peaks[w].append(int(m.group(1)))
    hours = driving_hours(os.path.join(work, f"out{workers[0]}"))
    print(f"{n} vehicles, {hours:.2f} h of driving, {rounds} rounds (medians)")
    print(f"{'side':<12} {'wall s':>8} {'cpu s':>8} {'veh-h/core-s':>13} {'peak MB/worker':>15}")
    for side, runs in sides.items():
        wall = statistics.median(r[0] for r in runs)
        cpu = statistics.median(r[1] for r in runs)
        cores = 1 if side == "serial" else int(side.split()[1][:-1])
        peak = statistics.median(peaks[cores]) if side != "serial" and peaks[cores] else float("nan")
        print(f"{side:<12} {wall:8.1f} {cpu:8.1f} {hours / (wall * cores):13.4f} {peak:15.0f}")


def main() -> None:
    if len(sys.argv) >= 5 and sys.argv[1] == "make":
        make(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
    elif len(sys.argv) >= 3 and sys.argv[1] == "run":
        rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
        workers = [int(w) for w in sys.argv[4:]] or [1, 2]
        run(sys.argv[2], rounds, workers)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
