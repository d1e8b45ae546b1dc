"""The Python package ndsid (docs/python.md) on the bundled data: each call checked against an
independent oracle (cantools for decoding) or the simulator's truth (truth.yaml), not against
numbers of its own."""
import math
import os

import cantools
import numpy as np
import pytest
import yaml

import ndsid

SRC = ndsid.SOURCE_DIR
CONFIG = os.path.join(SRC, "config", "example_vehicle.yaml")
CLEAN = os.path.join(SRC, "replay", "clean", "drive.log.gz")
STEER_OFFSET = os.path.join(SRC, "replay", "steer_offset", "drive.log.gz")
DBC = os.path.join(SRC, "dbc", "ndsid_example.dbc")


def truth(log):
    with open(os.path.join(os.path.dirname(log), "truth.yaml"), encoding="utf-8") as f:
        return yaml.safe_load(f)


def test_load_config_reads_the_vehicle_and_its_roles():
    cfg = ndsid.load_config(CONFIG)
    assert cfg["vehicle"]["name"] == "example-cmax"
    assert os.path.samefile(cfg["dbc"], DBC)
    assert "lateral_acceleration" in cfg["roles"] and cfg["roles"]["lateral_acceleration"]["signal"]
    assert cfg["outputs"][0] == "a_y"


def test_a_bad_config_raises_a_located_config_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(open(CONFIG, encoding="utf-8").read().replace("wheelbase_m:", "wheelbase_mm:", 1))
    with pytest.raises(ndsid.ConfigError) as e:
        ndsid.load_config(bad)
    assert "bad.yaml:" in str(e.value) and "wheelbase" in str(e.value)
    with pytest.raises(ndsid.ConfigError):
        ndsid.diagnose(CONFIG, effects=["no_such_effect"])


def test_decode_matches_cantools_value_for_value(head_log):
    df = ndsid.decode(head_log, dbc=DBC)
    assert df.attrs["format"] == "candump" and df.attrs["frames"] == 20000
    db = cantools.database.load_file(DBC)
    expected = []
    for line in open(head_log):
        stamp, _bus, frame = line.split()
        can_id, data = frame.split("#")
        try:
            msg = db.get_message_by_frame_id(int(can_id, 16))
        except KeyError:
            continue
        for name, value in msg.decode(bytes.fromhex(data), decode_choices=False).items():
            expected.append((float(stamp.strip("()")), msg.name, name, float(value)))
    assert len(df) == len(expected) > 10000
    # Within a frame the signals may come in another order: compare sorted by time and name.
    got = sorted(zip(df.t_s.round(6), df.message.astype(str), df.signal.astype(str), df.value))
    expected = sorted((round(t, 6), m, s, v) for t, m, s, v in expected)
    for (t, m, s, v), (te, me, se, ve) in zip(got, expected):
        assert (t, m, s) == (te, me, se)
        assert v == pytest.approx(ve, rel=1e-12, abs=1e-12)


def test_decode_wide_resampled_holds_the_last_value(head_log):
    long = ndsid.decode(head_log, dbc=DBC)
    wide = ndsid.decode(head_log, dbc=DBC, wide=True, rate_hz=50)
    assert np.allclose(np.diff(wide.t_s), 0.02, rtol=0, atol=1e-6)  # epoch seconds: ~2e-7 s resolution
    column = next(c for c in wide.columns if c != "t_s")
    message, signal = column.split(".", 1)
    raw = long[(long.message == message) & (long.signal == signal)].sort_values("t_s", kind="stable")
    for k in range(5, len(wide), 97):
        t = wide.t_s.iloc[k]
        i = np.searchsorted(raw.t_s.to_numpy(), t, side="right") - 1
        if i < 0:
            assert math.isnan(wide[column].iloc[k])
        else:
            assert wide[column].iloc[k] == raw.value.iloc[i]
    with pytest.raises(ndsid.ConfigError):
        ndsid.decode(head_log, dbc=DBC, wide=True, rate_hz=0)


def test_replay_recovers_the_simulators_eg():
    run = ndsid.replay(CONFIG, [CLEAN])
    est = run["estimate"]
    eg_true = truth(CLEAN)["vehicle"]["self_steer_gradient_rad_per_mps2"]
    assert est["valid"]
    # Within 3 sigma or 2 % of the truth (docs/accuracy.md: the clean set's EG within 1 %).
    assert abs(est["eg_rad_per_mps2"] - eg_true) < max(3 * est["eg_se_rad_per_mps2"], 0.02 * abs(eg_true))
    assert run["truth_eg_rad_per_mps2"] == pytest.approx(eg_true, rel=1e-6)
    # final_only: one identification, at the end.
    assert len(run["history"]) == 1 and run["history"].eg_rad_per_mps2.iloc[0] == est["eg_rad_per_mps2"]
    assert run["drives"].used.sum() >= 1
    assert run["gate"]["accepted"] > 0 and run["window"]["gated_hours"] == pytest.approx(est["gated_hours"])
    params = ndsid.parameters(est)
    assert list(params.name[:6]) == ["m", "Jz", "cv", "ch", "lv", "is"]


def test_compare_diagnose_add_and_the_error_falls():
    offset_true = math.radians(truth(STEER_OFFSET)["effects"]["steer_offset_deg"]["value"])
    before = ndsid.compare(CONFIG, [STEER_OFFSET], effects=[])
    base = before["summary"]["models"][0]
    assert before["samples"].scored.any()
    assert before["bins"].verdict.str.startswith("FAIL").any()  # the base model fails somewhere
    dia = ndsid.diagnose(CONFIG, [STEER_OFFSET], effects=[])
    assert "steer_offset" in dia["final_effects"]
    assert dia["ladder_df"].model.iloc[-1].count("+") >= 1
    after = ndsid.compare(CONFIG, [STEER_OFFSET], effects=dia["final_effects"])
    fitted = after["summary"]["models"][0]
    assert fitted["rmse_validation_mps2"] < base["rmse_validation_mps2"]
    assert dia["ladder_df"].delta_bic.iloc[-1] < -10  # the ladder's own test: decisively better
    offset = next(p for p in fitted["parameters"] if p["name"] == "steer_offset_rad")
    assert offset["value"] == pytest.approx(offset_true, abs=0.003)  # the hidden-effect test's tolerance
    # The samples carry each model's output: their RMSE is the summary's.
    s = after["samples"]
    scored = s[s.scored]
    rmse = float(np.sqrt(np.mean((scored.ay_mps2 - scored.ay_model) ** 2)))
    assert rmse == pytest.approx(fitted["rmse_all_mps2"], rel=1e-6)


def test_simulate_writes_a_log_with_its_truth(tmp_path):
    sim = ndsid.simulate(tmp_path / "sim", hours=0.2, seed=11, effects={"steer_offset_deg": 0.7}, dbc=DBC)
    assert os.path.getsize(sim["log"]) > 0
    assert sim["truth"]["seed"] == 11
    assert sim["truth"]["effects"]["steer_offset_deg"]["value"] == pytest.approx(0.7)
    df = ndsid.decode(sim["log"], dbc=DBC)
    assert df.t_s.max() - df.t_s.min() > 0.15 * 3600 * 0.5


def test_study_tables_as_dataframes(tmp_path):
    truth_file = os.path.join(os.path.dirname(CLEAN), "truth.yaml")
    st = ndsid.study(CONFIG, [CLEAN], hours=[0.06, 0.12], validation_fraction=0.25, truth=truth_file,
                     out=tmp_path / "study")
    sets, summary = st["sets"], st["summary"]
    assert list(sets.columns) == ["set", "hours", "eg_deg_per_g", "eg_se_deg_per_g", "rmse_validation", "valid"]
    assert (sets.set == "SD").sum() == 3  # 4 bundled drives, one held out
    assert {"H0.06", "H0.12", "AD"} <= set(sets.set)
    # The summary is the per-size aggregate of the valid sets: recomputed here with pandas.
    valid = sets[sets.valid]
    for _, row in summary.iterrows():
        g = valid[valid.set == row.set]
        assert row.sets == len(g)
        assert row.eg_min == pytest.approx(g.eg_deg_per_g.min(), abs=2e-6)
        assert row.eg_median == pytest.approx(g.eg_deg_per_g.median(), abs=2e-6)
        assert row.eg_max == pytest.approx(g.eg_deg_per_g.max(), abs=2e-6)
        assert row.rmse_validation_mean == pytest.approx(g.rmse_validation.mean(), abs=2e-6)
        assert row.spread_pct == pytest.approx(100 * (row.eg_max - row.eg_min) / abs(row.eg_median), abs=1e-3)
    assert list(summary.set) == list(dict.fromkeys(valid.set))
    # The all-data set against the simulator's truth (the CLI study test's 5 %).
    eg_true = st["truth_eg_deg_per_g"]
    assert eg_true == pytest.approx(truth(CLEAN)["vehicle"]["self_steer_gradient_deg_per_g"], rel=1e-6)
    ad = summary[summary.set == "AD"].iloc[0]
    assert abs(ad.eg_median - eg_true) / eg_true < 0.05
    with pytest.raises(ndsid.ConfigError):
        ndsid.study(CONFIG, [CLEAN], hours=[1, 0])
