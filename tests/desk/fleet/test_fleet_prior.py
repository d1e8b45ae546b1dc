"""The fleet prior (docs/fleet.md) against the simulator's truth, on several seeds.

A group of identified C-Max-class vehicles (the simulator's car, different drivers and roads,
a_y and yaw rate fitted) gives the prior; a new vehicle of the group with 0.5 h of driving starts
from it. Where the new vehicle's bus has the yaw rate too, 0.5 h alone already gives EG within
1 % in the simulator (the prior narrows sigma by a fifth); the prior's case is a vehicle whose bus
has no yaw rate (a_y alone: alone it needs hours).
- test_prior_reaches_one_percent_where_alone_does_not catches a prior that does not carry
  over (wrong units, wrong mass scaling, too loose) or that hides its uncertainty (EG off by more
  than 3 of its sigma), and a data set on which the vehicle alone would already be as good.
- test_loaded_vehicle_contradicts_its_prior catches a prior that hides a vehicle that really
  differs: 30 % more load (at the CG, so EG 30 % higher) must be flagged, in the fleet's
  columns and in the estimate's notes, and not published valid; and a vehicle like its group
  must not be.
- test_long_drive_without_yaw_rate_keeps_an_honest_sigma catches a prior that biases EG beyond
  its sigma where hours of data leave a parameter combination to it.
"""
import os
import shutil
import subprocess
import sys

import pandas as pd
import pytest
import yaml

import ndsid
from ndsid import fleet_prior, fleet_sim
from ndsid.fleet_config import write_config_with_priors
from ndsid.fleet_sim import Variant

pytest.importorskip("distributed")

GROUP = 4            # identified vehicles in the group
GROUP_HOURS = 1.5    # of driving each
NEW_HOURS = 0.5      # the new vehicle's driving
SEEDS = (201, 202, 203)
TOLERANCE = 0.01     # EG within 1 % of the truth with the prior


@pytest.fixture(scope="module")
def group(tmp_path_factory):
    root = str(tmp_path_factory.mktemp("group"))
    for k in range(GROUP):
        fleet_sim.make_vehicle(root, f"cmax-{k + 1:02d}", "cmax", Variant(), logs=1, hours_per_log=GROUP_HOURS, seed=100 + k)
    r = ndsid.fleet(dir=root, out=str(tmp_path_factory.mktemp("group_out")), workers=2)
    assert r.exit_code == 0, r.table[["vehicle", "error"]]
    assert r.table["valid"].all(), r.table[["vehicle", "reason"]]
    return root, r


@pytest.fixture(scope="module")
def prior(group):
    return group[1].priors["cmax"]


def _new_vehicle(root, name, variant, seed, prior, a_y_only=False, hours=NEW_HOURS):
    v = fleet_sim.make_vehicle(str(root), name, "cmax", variant, logs=1, hours_per_log=hours, seed=seed)
    if a_y_only:  # a bus without a yaw rate: a_y fitted alone, no effect that needs the yaw rate
        with open(v["config"]) as f:
            cfg = yaml.safe_load(f)
        del cfg["signals"]["yaw_rate"]
        cfg["identification"]["outputs"] = ["a_y"]
        cfg["model"]["effects"] = []
        with open(v["config"], "w") as f:
            yaml.safe_dump(cfg, f)
    with_prior = os.path.join(str(root), name, "with_prior.yaml")
    write_config_with_priors(v["config"], fleet_prior.priors_for_config(prior, fleet_sim.CLASSES["cmax"]["mass_kg"]),
                             with_prior, "fleet prior (test)")
    return v, with_prior


def test_prior_reaches_one_percent_where_alone_does_not(prior, tmp_path):
    assert set(prior["parameters"]) == {"Jz_per_m", "cv_per_m", "ch_per_m", "lv", "is"}
    alone_misses = 0
    for seed in SEEDS:
        v, cfg = _new_vehicle(tmp_path, f"new-{seed}", Variant(), seed, prior, a_y_only=True)
        truth = v["truth_eg_deg_per_g"]
        est = ndsid.replay(cfg, v["logs"])["estimate"]
        alone = ndsid.replay(v["config"], v["logs"])["estimate"]
        err, se = est["eg_deg_per_g"] - truth, est["eg_se_deg_per_g"]
        err_alone, se_alone = alone["eg_deg_per_g"] - truth, alone["eg_se_deg_per_g"]
        print(f"seed {seed}: with prior EG {est['eg_deg_per_g']:.4f} ± {se:.4f} ({100 * err / truth:+.2f} %), "
              f"alone {alone['eg_deg_per_g']:.4f} ± {se_alone:.4f} ({100 * err_alone / truth:+.2f} %), truth {truth:.4f}")
        assert est["valid"], est["reason"]
        assert abs(err) < TOLERANCE * truth, seed
        assert abs(err) < 3 * se, seed  # an honest sigma
        d = fleet_prior.prior_distance(est["parameters"], ndsid.load_config(cfg)["priors"], est["eg_deg_per_g"])
        assert not d["conflict"], (seed, d)
        assert _prior_check(est) == "passed"
        # The adequacy tracker counts the prior as driving: here it holds most of EG's
        # information, worth more than the half hour driven (docs/fleet.md).
        share, credit = est.get("eg_prior_info_share", 0), est["adequacy"].get("prior_hours", 0)
        print(f"  the prior's share of EG's information {share:.2f}, counted as {credit:.2f} h of driving")
        assert share > 0.5 and credit > NEW_HOURS, (seed, share, credit)
        assert "eg_prior_info_share" not in alone and "prior_hours" not in alone["adequacy"]
        # Alone, 0.5 h does not reach 1 %: off by more, or a sigma that cannot promise it.
        alone_misses += abs(err_alone) > TOLERANCE * truth or 2 * se_alone > TOLERANCE * truth
    assert alone_misses == len(SEEDS)


def test_loaded_vehicle_contradicts_its_prior(prior, tmp_path):
    for seed in SEEDS[:2]:
        v, cfg = _new_vehicle(tmp_path, f"van-like-{seed}", Variant(load_pct=30), seed + 100, prior)
        est = ndsid.replay(cfg, v["logs"])["estimate"]
        d = fleet_prior.prior_distance(est["parameters"], ndsid.load_config(cfg)["priors"], est["eg_deg_per_g"])
        print(f"seed {seed + 100}: 30 % load: distance {d['distance']:.1f} (threshold {d['threshold']:.1f}), "
              f"z {', '.join(f'{k} {z:+.1f}' for k, z in d['z'].items())}")
        assert d["conflict"], (seed, d)
        notes = est["identifiability"]["notes"]
        assert any("contradicts" in n for n in notes), notes
        assert not est["valid"], est  # a compromise between the prior and the data is not published valid
        assert "contradicts them" in est["reason"], est["reason"]
        assert _prior_check(est) == "failed"

        assert "prior_hours" not in est["adequacy"]  # a contradicted prior is not counted as driving

def test_long_drive_without_yaw_rate_keeps_an_honest_sigma(prior, tmp_path):
    """Catches a prior that biases EG where the data leave a parameter combination to it: hours of
    a_y alone pull cv, ch and lv along the data's direction while independent priors hold each
    apart (before the prior carried the group's EG: -1.4 %, 3.8 sigma after 4.5 h, seed 201)."""
    seed = 201
    v, cfg = _new_vehicle(tmp_path, f"long-{seed}", Variant(), seed, prior, a_y_only=True, hours=4.5)
    truth = v["truth_eg_deg_per_g"]
    est = ndsid.replay(cfg, v["logs"])["estimate"]
    err, se = est["eg_deg_per_g"] - truth, est["eg_se_deg_per_g"]
    print(f"seed {seed}, 4.5 h, a_y alone, with prior: EG {est['eg_deg_per_g']:.4f} ± {se:.4f} "
          f"({100 * err / truth:+.2f} %, z {err / se:+.2f}), truth {truth:.4f}")
    assert est["valid"], est["reason"]
    assert abs(err) < 3 * se


def test_a_prior_started_vehicle_is_adequate_sooner_where_egs_convergence_is_the_limit(prior, tmp_path):
    """Catches a prior not counted as driving by the adequacy tracker (docs/fleet.md, "Adequacy with
    a fleet prior"), or counted for a biased EG. A bus without a yaw rate, 3 h driven; coverage is
    taken out of the judgement (kl_threshold 100: the simulator's drives keep adding coverage for
    hours, docs/fleet.md), so EG's convergence is the limit. Alone, EG still moves by more than
    the tolerance at the end; with the prior the vehicle reads ADEQUATE after the hold of its own
    hours, on an EG within 1 % and 3 sigma of the truth."""
    seed = 201
    runs = {}
    for label, use_prior in (("prior", True), ("alone", False)):
        v, cfg = _new_vehicle(tmp_path / label, f"adequate-{seed}", Variant(), seed, prior, a_y_only=True, hours=3.0)
        path = cfg if use_prior else v["config"]
        with open(path) as f:
            c = yaml.safe_load(f)
        c["adequacy"] = dict(c.get("adequacy") or {}, kl_threshold=100)
        with open(path, "w") as f:
            yaml.safe_dump(c, f)
        runs[label] = (v, ndsid.replay(path, v["logs"], final_only=False))
    v, r = runs["prior"]
    truth, h = v["truth_eg_deg_per_g"], r["history"]
    adequate = h[h["state"] == "ADEQUATE"]
    assert len(adequate), r["estimate"]["adequacy"]["explanation"]
    first = adequate.iloc[0]
    print(f"with prior: ADEQUATE at {first.gated_hours:.2f} gated h, EG {first.eg_deg_per_g:.4f} ± "
          f"{first.eg_se_deg_per_g:.4f} (truth {truth:.4f})")
    assert abs(first.eg_deg_per_g - truth) < min(0.01 * truth, 3 * first.eg_se_deg_per_g)
    assert first.gated_hours >= 2.0  # the hold (2 h) is the vehicle's own driving
    _, alone = runs["alone"]
    a = alone["estimate"]["adequacy"]
    print(f"alone: {a['state']} at {a['gated_hours']:.2f} gated h: {a['explanation']}")
    assert a["state"] != "ADEQUATE" and a["rel_change"] > 0.01  # its EG has not converged


def _prior_check(est: dict) -> str:
    """The verdict of the estimate's check `prior` (its distance from model.priors)."""
    return next(c["verdict"] for c in est["plausibility"]["checks"] if c["name"] == "prior")


def _priors_close(got: dict, want: dict) -> bool:
    return set(got) == set(want) and all(
        abs(got[n]["value"] - want[n]["value"]) <= 1e-9 * abs(want[n]["value"]) and
        abs(got[n]["sd"] - want[n]["sd"]) <= 1e-9 * want[n]["sd"] for n in want)


def test_a_configuration_naming_the_fleet_table_reads_its_groups_prior(group, tmp_path):
    """Catches: prior_from: fleet.parquet + prior_group not reading the prior that ndsid fleet
    derived from that table's rows, a table changed afterwards accepted with the old prior, and
    `fleet prior --fleet T --group G` not writing the prior of the table as it is now."""
    root, r = group
    shutil.copytree(r.out, tmp_path / "out")  # the module's fleet stays as it was
    table = str(tmp_path / "out" / "fleet.parquet")
    with open(os.path.join(root, "cmax-01", "vehicle.yaml")) as f:
        cfg = yaml.safe_load(f)
    cfg["identification"] = dict(cfg.get("identification") or {}, prior_from=table, prior_group="cmax")
    path = str(tmp_path / "new.yaml")
    with open(path, "w") as f:
        yaml.safe_dump(cfg, f)
    mass = fleet_sim.CLASSES["cmax"]["mass_kg"]
    assert _priors_close(ndsid.load_config(path)["priors"], fleet_prior.priors_for_config(r.priors["cmax"], mass))

    # The table without its first vehicle: the written prior no longer comes from it.
    fewer = pd.read_parquet(table).iloc[1:]
    fewer.to_parquet(table, index=False)
    with pytest.raises(ndsid.ConfigError, match="another version of"):
        ndsid.load_config(path)
    done = subprocess.run([sys.executable, "-m", "ndsid", "fleet", "prior", "--fleet", table, "--group", "cmax"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    again = fleet_prior.group_prior(fewer, "cmax")
    assert again["vehicles"] == sorted(fewer["vehicle"]) and len(again["vehicles"]) == GROUP - 1
    assert _priors_close(ndsid.load_config(path)["priors"], fleet_prior.priors_for_config(again, mass))
    assert not _priors_close(fleet_prior.priors_for_config(again, mass),
                             fleet_prior.priors_for_config(r.priors["cmax"], mass))
