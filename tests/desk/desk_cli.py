"""What the desk's end-to-end tests share: running `ndsid`, the example configuration with its
paths made absolute, and compare's held-out RMSEs. Imported by the scripts beside it."""
import json
import os
import re
import subprocess
import sys


def run(exe, args):
    """`exe args`; its stdout, or the test ends with the command's exit code and output."""
    r = subprocess.run([exe] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args[:2])}: exit {r.returncode}\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    return r.stdout


def example_config(src, work):
    """The example configuration's text, the DBC path absolute, state and reports under `work`."""
    with open(os.path.join(src, "config", "example_vehicle.yaml")) as f:
        text = f.read()
    text = text.replace("dbc: ../dbc/", "dbc: " + os.path.join(src, "dbc") + "/")
    text = re.sub(r"^state_dir: .*$", "state_dir: " + os.path.join(work, "state"), text, flags=re.M)
    return re.sub(r"^report_dir: .*$", "report_dir: " + os.path.join(work, "report"), text, flags=re.M)


def with_model(text, effects, formulas_yaml):
    """`text` with model.effects set to `effects` and `formulas_yaml` ("  formulas:\\n    ...")
    after it."""
    line = "  effects: [" + ", ".join(effects) + "]\n" + formulas_yaml.rstrip("\n")
    text, n = re.subn(r"^  effects: \[.*$", lambda m: line, text, flags=re.M)
    assert n == 1, "the example config's model.effects line changed"
    return text


def compare(exe, cfg, log, out):
    """`ndsid compare`; the model's summary (a_y) and its held-out yaw-rate RMSE [deg/s]."""
    run(exe, ["compare", "--config", cfg, "--log", log, "--out", out])
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    m = next(x for x in s["models"] if x["label"] == "model")
    r = next(x for x in s["yaw_rate"]["models"] if x["label"] == "model")
    return m, r["rmse_validation_degps"]
