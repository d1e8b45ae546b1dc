"""A simulated fleet shared by the fleet's tests (ndsid.fleet_sim): 9 vehicles of 3 classes, each
with its variant (load, tyres, steering ratio), 2 logs of at least 0.15 h of driving (a drive is driven to its end) a month apart; one
with a short window (segments evicted across its logs), one whose log is cut in the middle of a
drive into two files (the boundary the merge must read through). Built once for the module."""
import gzip
import os

import pytest

from ndsid import fleet_sim
from ndsid.fleet_sim import Variant

HOURS_PER_LOG = 0.15


def split_log(log: str, first: str, second: str) -> None:
    """Cuts a candump log into two files in the middle of its frames (mid-drive)."""
    with gzip.open(log, "rt") as f:
        lines = f.readlines()
    half = len(lines) // 2
    with open(first, "w") as a:
        a.writelines(lines[:half])
    with open(second, "w") as b:
        b.writelines(lines[half:])
    os.remove(log)


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    root = str(tmp_path_factory.mktemp("fleet"))
    plan = [("cmax", Variant()), ("cmax", Variant(load_pct=15)), ("cmax", Variant(tyre_pct=-8)),
            ("van", Variant()), ("van", Variant(ratio_pct=4)), ("van", Variant(load_pct=10)),
            ("city", Variant()), ("city", Variant(tyre_pct=6)), ("city", Variant(load_pct=20))]
    truth = {}
    for k, (cls, variant) in enumerate(plan):
        vid = f"{cls}-{k + 1:02d}"
        window_h = 0.2 if k == 3 else None
        v = fleet_sim.make_vehicle(root, vid, cls, variant, logs=2, hours_per_log=HOURS_PER_LOG, seed=11 + k,
                                   window_h=window_h)
        truth[vid] = v
    # cmax-03: its second log cut mid-drive into two files.
    logs = os.path.join(root, "cmax-03", "logs")
    split_log(os.path.join(logs, "01.log.gz"), os.path.join(logs, "01a.log"), os.path.join(logs, "01b.log"))
    return root, truth
