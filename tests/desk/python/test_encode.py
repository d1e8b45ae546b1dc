"""python -m ndsid encode: decoded time series onto a DBC as a candump log. What is written
decodes back (ndsid.decode, the pipeline's own decoder) to the CSV's values within each signal's
resolution, at the rows' times, file after file with the gap between them; bad maps are
configuration errors (exit 78) that name the key."""
import os
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import ndsid

DBC = os.path.join(ndsid.SOURCE_DIR, "dbc", "timeseries.dbc")


def cli(*args):
    return subprocess.run([sys.executable, "-m", "ndsid", *args], capture_output=True, text=True, timeout=600)


def _csv(path, seed, n=500, dt=0.01):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt + 3.7  # each file's own time base
    df = pd.DataFrame({
        "t_s": t,
        "steer_rad": 0.4 * np.sin(0.7 * t) + 0.01 * rng.standard_normal(n),
        "v_mps": 12 + 3 * np.sin(0.05 * t),
        "ay": 2.5 * np.sin(0.7 * t - 0.2),
        "r_radps": -0.2 * np.cos(0.7 * t),
    })
    df.loc[17, "ay"] = np.nan  # a missing value: no IMU frame on that row
    df.to_csv(path, index=False)
    return df


MAP = """time: t_s
start_s: 1600000000
gap_s: 90
signals:
  TS_STEERING.SteeringWheelAngle: {column: steer_rad, scale: 57.29577951308232}
  TS_SPEED.VehicleSpeed: v_mps
  TS_IMU.LateralAcceleration: ay
  TS_IMU.YawRate: {column: r_radps, scale: 57.29577951308232, offset: 0.5}
"""


def test_encoded_log_decodes_back_to_the_csv(tmp_path):
    a, b = _csv(tmp_path / "a.csv", 1), _csv(tmp_path / "b.csv", 2)
    (tmp_path / "map.yaml").write_text(MAP)
    out = tmp_path / "drive.log.gz"
    r = cli("encode", "--csv", str(tmp_path / "a.csv"), str(tmp_path / "b.csv"), "--dbc", DBC, "--map",
            str(tmp_path / "map.yaml"), "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "2998 frames from 2 files" in r.stdout  # 2 x 500 rows x 3 messages, one IMU frame missing in each
    wide = ndsid.decode(str(out), dbc=DBC, wide=True)
    t0 = 1600000000.0
    for df, start in [(a, t0), (b, t0 + 4.99 + 90)]:
        part = wide[(wide.t_s >= start - 1e-6) & (wide.t_s <= start + 5.0)]
        assert len(part) == 500
        assert np.allclose(part.t_s.to_numpy() - start, df.t_s.to_numpy() - df.t_s.iloc[0], atol=2e-6)
        np.testing.assert_allclose(part["TS_STEERING.SteeringWheelAngle"], np.degrees(df.steer_rad), atol=6e-4)
        np.testing.assert_allclose(part["TS_SPEED.VehicleSpeed"], df.v_mps, atol=6e-5)
        ay = part["TS_IMU.LateralAcceleration"].to_numpy()
        yaw = part["TS_IMU.YawRate"].to_numpy()
        assert np.isnan(ay[17]) and np.isnan(yaw[17])  # no IMU frame at that row's time
        keep = np.arange(len(ay)) != 17
        np.testing.assert_allclose(ay[keep], df.ay.to_numpy()[keep], atol=6e-5)
        np.testing.assert_allclose(yaw[keep], np.degrees(df.r_radps.to_numpy()[keep]) + 0.5, atol=6e-5)
    frames = ndsid.decode(str(out), dbc=DBC)
    assert (frames.signal == "LateralAcceleration").sum() == 998


def test_bad_maps_are_configuration_errors(tmp_path):
    _csv(tmp_path / "a.csv", 1)
    for text, words in [
        ("signals: {NO_SUCH.X: ay}", "no message NO_SUCH"),
        ("signals: {TS_IMU.Nope: ay}", "has no signal Nope"),
        ("signals: {TS_IMU.YawRate: missing_column}", "no column 'missing_column'"),
        ("time: tt\nsignals: {TS_IMU.YawRate: ay}", "no time column 'tt'"),
    ]:
        (tmp_path / "m.yaml").write_text(text)
        r = cli("encode", "--csv", str(tmp_path / "a.csv"), "--dbc", DBC, "--map", str(tmp_path / "m.yaml"), "--out",
                str(tmp_path / "o.log"))
        assert r.returncode == 78, (text, r.stdout, r.stderr)
        assert words in r.stderr, (text, r.stderr)
