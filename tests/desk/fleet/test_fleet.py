"""ndsid fleet on a 2-worker LocalCluster (docs/fleet.md), against the serial replay.

What each test catches:
- test_each_vehicle_equals_its_serial_replay: a merge of the per-log reductions that differs from
  one pipeline reading the logs in order (drive numbering, held-out drives, window eviction,
  segment order, the read-through of a log cut mid-drive) in any printed digit.
- test_failing_vehicles_fail_alone: a truncated log or a broken config that takes other vehicles
  down, is not reported in its row, or gives the wrong exit status; a bad manifest not giving 78.
- test_killed_worker_gives_the_same_table: a worker lost mid-run that loses a vehicle or changes
  a number.
- test_rerun_skips_unchanged_vehicles: a rerun that recomputes vehicles whose inputs did not
  change, or misses a changed log or config.
"""
import gzip
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest

import ndsid
from ndsid.fleet_manifest import ManifestError

distributed = pytest.importorskip("distributed")

PRINTED = {"eg_deg_per_g": "{:.4f}", "eg_se_deg_per_g": "{:.4f}", "rmse_train_mps2": "{:.4f}",
           "rmse_validation_mps2": "{:.4f}", "gated_hours": "{:.2f}", "window_hours": "{:.2f}"}


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def first_run(fleet_dir, client, tmp_path_factory):
    root, _ = fleet_dir
    out = str(tmp_path_factory.mktemp("out"))
    return ndsid.fleet(dir=root, out=out, client=client)


def _printed(est: dict) -> dict:
    p = {k: fmt.format(est[k]) for k, fmt in PRINTED.items() if k in est}
    p["valid"], p["reason"] = est["valid"], est["reason"]
    for par in est["parameters"]:
        p[par["name"]] = f"{par['value']:.6g} ± {par['se']:.3g}"
    return p


def test_each_vehicle_equals_its_serial_replay(fleet_dir, first_run):
    root, truth = fleet_dir
    assert first_run.exit_code == 0, first_run.table[["vehicle", "error"]]
    assert len(first_run.table) == 9 and first_run.computed == 9
    worst = 0.0
    for vid in truth:
        with open(os.path.join(first_run.out, "vehicles", vid, "result.json")) as f:
            fleet_doc = json.load(f)["result"]
        logs = [os.path.join(root, vid, "logs", n) for n in sorted(os.listdir(os.path.join(root, vid, "logs")))
                if not n.endswith(".yaml")]
        serial = ndsid.replay(os.path.join(root, vid, "vehicle.yaml"), logs, final_only=True)
        est_f, est_s = fleet_doc["estimate"], serial["estimate"]
        assert _printed(est_f) == _printed(est_s), vid
        assert fleet_doc["drives"] == serial["drives"].to_dict("records"), vid
        assert fleet_doc["gate"] == serial["gate"], vid
        assert fleet_doc["window"]["segments"] == serial["window"]["segments"], vid
        assert est_f["training_segments"] == est_s["training_segments"], vid
        assert est_f["validation_segments"] == est_s["validation_segments"], vid
        assert fleet_doc["frames"] == serial["frames"], vid
        worst = max(worst, abs(est_f["eg_rad_per_mps2"] - est_s["eg_rad_per_mps2"]) / abs(est_s["eg_rad_per_mps2"]))
    print(f"largest relative EG difference fleet vs serial: {worst:.2e}")
    # The log cut mid-drive was read together with its first half; every other log alone.
    row = first_run.table.set_index("vehicle")
    assert (row.loc["cmax-03", "logs"], row.loc["cmax-03", "runs"]) == (3, 2)
    assert (row.drop(index="cmax-03")["runs"] == 2).all()
    # The short window evicted segments: fewer hours in it than gated.
    assert row.loc["van-04", "window_hours"] < row.loc["van-04", "gated_hours"] - 0.05
    # Each vehicle's EG against the simulator's truth (0.5 h of driving, a box of +-40 %: 10 %).
    for vid, v in truth.items():
        assert row.loc[vid, "valid"], (vid, row.loc[vid, "reason"])
        assert abs(row.loc[vid, "eg_deg_per_g"] / row.loc[vid, "truth_eg_deg_per_g"] - 1) < 0.10, vid
    assert os.path.exists(os.path.join(first_run.out, "drives.parquet"))
    html = open(os.path.join(first_run.out, "fleet-report.html"), encoding="utf-8").read()
    assert "cmax-01" in html and "<svg" in html and "http" not in html.replace("http://www.w3.org/2000/svg", "")


def _truncate(src: str, dst: str) -> None:
    with open(src, "rb") as f:
        data = f.read()
    with open(dst, "wb") as f:
        f.write(data[: len(data) // 2])


def test_failing_vehicles_fail_alone(fleet_dir, client, tmp_path):
    root, _ = fleet_dir
    bad_log = tmp_path / "truncated.log.gz"
    _truncate(os.path.join(root, "van-05", "logs", "00.log.gz"), str(bad_log))
    bad_cfg = tmp_path / "broken.yaml"
    bad_cfg.write_text(open(os.path.join(root, "city-07", "vehicle.yaml")).read() + "unknown_key: 1\n")
    manifest = tmp_path / "fleet.csv"
    manifest.write_text("vehicle,config,logs,group\n"
                        f"cmax-01,{root}/cmax-01/vehicle.yaml,{root}/cmax-01/logs/*.log.gz,cmax\n"
                        f"van-05,{root}/van-05/vehicle.yaml,{bad_log};{root}/van-05/logs/01.log.gz,van\n"
                        f"city-07,{bad_cfg},{root}/city-07/logs/*.log.gz,city\n"
                        f"city-08,{root}/city-08/vehicle.yaml,{root}/city-08/logs/nothing*.log.gz,city\n")
    r = ndsid.fleet(manifest, out=tmp_path / "out", client=client)
    t = r.table.set_index("vehicle")
    assert r.exit_code == 1 and sorted(r.failed) == ["city-07", "city-08", "van-05"]
    assert t.loc["cmax-01", "error"] == "" and t.loc["cmax-01", "valid"]
    assert "reading stopped" in t.loc["van-05", "error"] and t.loc["van-05", "error_kind"] == "input"
    assert "unknown_key" in t.loc["city-07", "error"] and t.loc["city-07", "error_kind"] == "config"
    assert "no log matches" in t.loc["city-08", "error"]
    # The command's exit status, and 78 for a manifest it cannot use.
    bad_manifest = tmp_path / "bad.csv"
    bad_manifest.write_text("car,config\nx,y.yaml\n")
    with pytest.raises(ManifestError):
        ndsid.fleet(bad_manifest, out=tmp_path / "out2", client=client)
    cmd = [sys.executable, "-m", "ndsid", "fleet", "--manifest", str(bad_manifest), "--out", str(tmp_path / "o3")]
    assert subprocess.run(cmd, capture_output=True).returncode == 78


def test_killed_worker_gives_the_same_table(fleet_dir, first_run, client, tmp_path):
    root, _ = fleet_dir
    pids = client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed = {}

    def kill_when_busy():
        # Kill one worker once the reductions run (its tasks are rescheduled by Dask).
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            if any(client.processing().values()):
                time.sleep(1.0)
                os.kill(victim, signal.SIGKILL)
                killed["at"] = time.monotonic()
            time.sleep(0.1)

    import threading
    t = threading.Thread(target=kill_when_busy)
    t.start()
    r = ndsid.fleet(dir=root, out=tmp_path / "out", client=client)
    t.join()
    assert killed, "no worker was killed"
    assert r.exit_code == 0 and r.computed == 9
    cols = ["vehicle", "eg_deg_per_g", "eg_se_deg_per_g", "valid", "gated_hours", "drives", "frames"]
    pd.testing.assert_frame_equal(r.table[cols], first_run.table[cols])
    client.wait_for_workers(2, timeout=60)


def test_rerun_skips_unchanged_vehicles(fleet_dir, client, tmp_path):
    root, _ = fleet_dir
    copy = tmp_path / "fleet"
    for vid in ("cmax-01", "van-06", "city-09"):
        shutil.copytree(os.path.join(root, vid), copy / vid, ignore=shutil.ignore_patterns("state", "report"))
    out = tmp_path / "out"
    first = ndsid.fleet(dir=copy, out=out, client=client)
    again = ndsid.fleet(dir=copy, out=out, client=client)
    assert again.computed == 0 and again.table["reused"].all()
    pd.testing.assert_frame_equal(again.table.drop(columns="reused"), first.table.drop(columns="reused"))
    # Same frames, other bytes (another gzip level): that vehicle alone is read again, same numbers.
    log = copy / "city-09" / "logs" / "00.log.gz"
    with gzip.open(log, "rb") as f:
        data = f.read()
    with gzip.open(log, "wb", compresslevel=1) as f:
        f.write(data)
    cfg = copy / "van-06" / "vehicle.yaml"
    cfg.write_text(cfg.read_text() + "# edited\n")
    third = ndsid.fleet(dir=copy, out=out, client=client)
    assert third.computed == 2
    assert sorted(third.table.loc[~third.table["reused"], "vehicle"]) == ["city-09", "van-06"]
    cols = ["vehicle", "eg_deg_per_g", "eg_se_deg_per_g"]
    pd.testing.assert_frame_equal(third.table[cols], first.table[cols])
