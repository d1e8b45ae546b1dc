#!/usr/bin/env python3
"""The arm64 build's estimates against the amd64 build's, on the bundled default replay.

Runs `ndsid replay --final-only` (the replay of scripts/main.sh: the bundled sets in replay/
with config/example_vehicle.yaml) twice: the arm64 binary under qemu-user, and the amd64
binary of the host build. The two outputs must be the same text with the same numbers: every
number (EG and its sigma, the parameters, the RMSEs, the counters, the adequacy figures) within
REL_TOL of the amd64 value, or one unit of its last printed digit where the printing rounds
(a value that sits on a rounding boundary may print one digit apart). Lines that carry wall time
or paths (the time line, the report folder, log lines) are left out. Then each set's
estimate.json at full precision (JSON_REL_TOL). Prints the EG of both side by side.

Catches: a cross-compiled binary whose numbers differ from the native one's (the compiler's
floating-point contraction on aarch64, a library of another version in the sysroot, an
uninitialised value that happens to be zero on one side), or that fails to run at all.

usage: arm64_replay_crosscheck.py --emulator 'qemu-aarch64-static -L SYSROOT' --arm64 NDSID
                                  --amd64 NDSID --source SOURCE_DIR --work DIR
Exit 77 (skipped) when the amd64 binary is missing (build it: cmake --build build --target ndsid).
"""
import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import time

REL_TOL = 1e-6
# estimate.json of each set, at full precision: every number within JSON_REL_TOL relative (or
# JSON_ABS_TOL for values near zero); the wall times (the solver's, the model-choice refits') are left out. Measured: EG
# bit-identical, the largest difference 4e-9 relative on a value of 6e-10 (the EG shift if the
# bounds were released), the others below 1e-10.
JSON_REL_TOL = 1e-8
JSON_ABS_TOL = 1e-15
JSON_VOLATILE = re.compile(r"solve_seconds|model_choice\.seconds")
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
# Lines whose content depends on the machine or the run, not on the estimate.
VOLATILE = re.compile(r"frames/s|data-h/s|report: |page: |wrote | s wall|^\[\d\d:\d\d:")


def run(cmd, cwd, env):
    start = time.monotonic()
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=3000)
    seconds = time.monotonic() - start
    # 1: a set's estimate is not valid (the bundled steer_offset set, by design); more is an error.
    if proc.returncode not in (0, 1):
        sys.exit(f"FAIL: {' '.join(cmd)} exited {proc.returncode}\n{proc.stdout}\n{proc.stderr}")
    return proc.stdout, proc.returncode, seconds


def stable_lines(text):
    return [line.rstrip() for line in text.splitlines() if line.strip() and not VOLATILE.search(line)]


def last_digit_unit(token):
    """One unit of the last printed digit: '4.1930' -> 1e-4, '914802' -> 1, '4.9e-05' -> 1e-6."""
    mantissa, _, exponent = token.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def compare(amd64, arm64):
    """Returns (numbers compared, largest relative difference, list of failures)."""
    failures = []
    count = 0
    worst = 0.0
    if len(amd64) != len(arm64):
        failures.append(f"{len(amd64)} lines on amd64, {len(arm64)} on arm64")
    for a_line, b_line in zip(amd64, arm64):
        if NUMBER.sub("#", a_line) != NUMBER.sub("#", b_line):
            failures.append(f"text differs:\n  amd64: {a_line}\n  arm64: {b_line}")
            continue
        for a_tok, b_tok in zip(NUMBER.findall(a_line), NUMBER.findall(b_line)):
            a, b = float(a_tok), float(b_tok)
            count += 1
            diff = abs(a - b)
            if diff == 0:
                continue
            rel = diff / max(abs(a), abs(b))
            worst = max(worst, rel)
            if rel > REL_TOL and diff > last_digit_unit(a_tok) * 1.0000001:
                failures.append(f"{a_tok} (amd64) vs {b_tok} (arm64), relative {rel:.2e}:\n"
                                f"  amd64: {a_line}\n  arm64: {b_line}")
    return count, worst, failures


def json_numbers(node, path=""):
    if isinstance(node, dict):
        for key, value in node.items():
            yield from json_numbers(value, f"{path}.{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from json_numbers(value, f"{path}[{i}]")
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield path, float(node)


def compare_estimates(work):
    """estimate.json of every set, amd64 against arm64: (numbers, largest relative, failures)."""
    failures, count, worst = [], 0, 0.0
    sets = sorted(d for d in os.listdir(os.path.join(work, "amd64"))
                  if os.path.isfile(os.path.join(work, "amd64", d, "estimate.json")))
    for name in sets:
        with open(os.path.join(work, "amd64", name, "estimate.json")) as f:
            a = dict(json_numbers(json.load(f)))
        path_b = os.path.join(work, "arm64", name, "estimate.json")
        if not os.path.isfile(path_b):
            failures.append(f"{name}: no estimate.json on arm64")
            continue
        with open(path_b) as f:
            b = dict(json_numbers(json.load(f)))
        if a.keys() != b.keys():
            failures.append(f"{name}: estimate.json fields differ: {sorted(a.keys() ^ b.keys())[:5]}")
        print(f"{name}: EG {a.get('.eg_deg_per_g', float('nan')):.15g} deg/g amd64, "
              f"{b.get('.eg_deg_per_g', float('nan')):.15g} deg/g arm64")
        for key in sorted(a.keys() & b.keys()):
            if JSON_VOLATILE.search(key):
                continue
            count += 1
            diff = abs(a[key] - b[key])
            if diff == 0:
                continue
            rel = diff / max(abs(a[key]), abs(b[key]))
            worst = max(worst, rel)
            if rel > JSON_REL_TOL and diff > JSON_ABS_TOL:
                failures.append(f"{name}: {key} = {a[key]!r} (amd64) vs {b[key]!r} (arm64), relative {rel:.2e}")
    return count, worst, failures


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--emulator", required=True, help="the command that runs an arm64 program")
    ap.add_argument("--arm64", required=True)
    ap.add_argument("--amd64", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--work", required=True)
    args = ap.parse_args()
    if not os.access(args.amd64, os.X_OK):
        print(f"SKIP: no amd64 ndsid at {args.amd64} (cmake --build build --target ndsid)")
        return 77
    os.makedirs(args.work, exist_ok=True)
    env = dict(os.environ, NDSID_PROGRESS="0")
    replay = ["replay", "--final-only"]
    out_amd64, rc_amd64, t_amd64 = run([args.amd64, *replay, "--report", os.path.join(args.work, "amd64")],
                             args.source, env)
    out_arm64, rc_arm64, t_arm64 = run([*shlex.split(args.emulator), args.arm64, *replay,
                              "--report", os.path.join(args.work, "arm64")], args.source, env)
    for name, text in (("amd64", out_amd64), ("arm64", out_arm64)):
        with open(os.path.join(args.work, f"replay_{name}.txt"), "w") as f:
            f.write(text)
    amd64, arm64 = stable_lines(out_amd64), stable_lines(out_arm64)
    for a_line, b_line in zip(amd64, arm64):
        if "EG = " in a_line:
            print(f"amd64: {a_line.strip()}\narm64: {b_line.strip()}")
    count, worst, failures = compare(amd64, arm64)
    print(f"{count} numbers on {len(amd64)} lines compared; largest relative difference {worst:.2e} "
          f"(tolerance {REL_TOL:g} or one unit of the last printed digit); "
          f"replay {t_amd64:.1f} s amd64, {t_arm64:.1f} s arm64 under qemu ({t_arm64 / t_amd64:.1f}x)")
    json_count, json_worst, json_failures = compare_estimates(args.work)
    print(f"estimate.json: {json_count} numbers compared; largest relative difference {json_worst:.2e} "
          f"(tolerance {JSON_REL_TOL:g}, or {JSON_ABS_TOL:g} absolute)")
    failures += json_failures
    if json_count < 100:
        failures.append(f"only {json_count} numbers in estimate.json compared")
    if rc_amd64 != rc_arm64:
        failures.append(f"exit {rc_amd64} on amd64, {rc_arm64} on arm64")
    if count < 20:
        failures.append(f"only {count} numbers compared: the replay printed too little")
    if failures:
        print("FAIL:\n" + "\n".join(failures))
        return 1
    print("PASS: the arm64 replay prints the amd64 replay's estimates")
    return 0


if __name__ == "__main__":
    sys.exit(main())
