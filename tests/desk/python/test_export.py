"""Interchange files (ndsid.export, python -m ndsid): what is written reads back, with an
independent reader (pyarrow for Parquet, asammdf for MDF 4), to the values ndsid.decode and
ndsid.compare return; bad arguments are configuration errors (exit 78)."""
import os
import subprocess
import sys

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from asammdf import MDF

import ndsid
from ndsid import export

SRC = ndsid.SOURCE_DIR
CONFIG = os.path.join(SRC, "config", "example_vehicle.yaml")
STEER_OFFSET = os.path.join(SRC, "replay", "steer_offset", "drive.log.gz")
DBC = os.path.join(SRC, "dbc", "ndsid_example.dbc")


def cli(*args):
    return subprocess.run([sys.executable, "-m", "ndsid", *args], capture_output=True, text=True, timeout=600)


def test_decode_to_parquet_reads_back_with_pyarrow(head_log, tmp_path):
    out = tmp_path / "long.parquet"
    r = cli("decode", "--dbc", DBC, "--log", head_log, "--out", str(out))
    assert r.returncode == 0, r.stderr
    want = ndsid.decode(head_log, dbc=DBC)
    got = pq.read_table(out).to_pandas()
    assert list(got.columns) == ["t_s", "message", "signal", "value"]
    assert isinstance(got.message.dtype, pd.CategoricalDtype)  # dictionary-encoded, not strings per row
    assert np.array_equal(got.t_s.to_numpy(), want.t_s.to_numpy())
    assert np.array_equal(got.value.to_numpy(), want.value.to_numpy())
    assert (got.signal.astype(str) == want.signal.astype(str)).all()
    meta = export.read_parquet_metadata(out)
    assert meta["frames"] == 20000 and meta["format"] == "candump" and meta["form"] == "long"


def test_decode_wide_resampled_to_parquet_equals_the_dataframe(head_log, tmp_path):
    out = tmp_path / "wide.parquet"
    df = export.decode_to_parquet(head_log, DBC, out, wide=True, rate_hz=50)
    got = pd.read_parquet(out)
    assert list(got.columns) == list(df.columns) and len(got) == len(df)
    pd.testing.assert_frame_equal(got, df, check_exact=True)
    assert export.read_parquet_metadata(out)["rate_hz"] == 50


def test_decode_to_mf4_holds_every_signal_on_its_messages_time_stamps(head_log, tmp_path):
    out = tmp_path / "signals.mf4"
    r = cli("decode", "--dbc", DBC, "--log", head_log, "--out", str(out))
    assert r.returncode == 0, r.stderr
    long = ndsid.decode(head_log, dbc=DBC)
    t0 = long.t_s.min()
    names = {f"{m}.{s}" for m, s in zip(long.message.astype(str), long.signal.astype(str))}
    with MDF(str(out)) as mdf:
        channels = {name for name in mdf.channels_db if "." in name}
        assert channels == names
        for name in sorted(names)[::5]:
            message, signal = name.split(".", 1)
            rows = long[(long.message == message) & (long.signal == signal)]
            sig = mdf.get(name)
            assert np.array_equal(sig.samples, rows.value.to_numpy())
            assert np.allclose(sig.timestamps, rows.t_s.to_numpy() - t0, rtol=0, atol=1e-9)


def test_compare_to_parquet_samples_give_the_summarys_rmse(tmp_path):
    out = tmp_path / "cmp"
    r = cli("compare", "--config", CONFIG, "--log", STEER_OFFSET, "--effects", "none", "--out", str(out))
    assert r.returncode == 0, r.stderr
    samples = pd.read_parquet(out / "samples.parquet")
    bins = pd.read_parquet(out / "bins.parquet")
    summary = export.read_parquet_metadata(out / "samples.parquet")
    scored = samples[samples.scored]
    rmse = float(np.sqrt(np.mean((scored.ay_mps2 - scored.ay_model) ** 2)))
    assert rmse == pytest.approx(summary["models"][0]["rmse_all_mps2"], rel=1e-6)
    assert bins.verdict.str.startswith("FAIL").any()  # the base model fails on the hidden offset
    assert os.path.exists(out / "summary.json")


def test_bad_export_arguments_are_config_errors(head_log, tmp_path):
    for args in (["--out", str(tmp_path / "x.csv")],
                 ["--out", str(tmp_path / "x.mf4"), "--wide"],
                 ["--out", str(tmp_path / "x.parquet"), "--rate-hz", "50"]):
        r = cli("decode", "--dbc", DBC, "--log", head_log, *args)
        assert r.returncode == 78 and "python -m ndsid decode:" in r.stderr, (args, r.stderr)
    r = cli("decode", "--dbc", DBC, "--log", str(tmp_path / "missing.log"), "--out", str(tmp_path / "x.parquet"))
    assert r.returncode != 0 and "missing.log" in r.stderr
