#!/usr/bin/env python3
"""The defaults docs/model-workflow.md states for `ndsid diagnose`, and docs/new-car.md for
`ndsid init`, are the binary's own.

Reads each option's default from `ndsid diagnose --help` (CLI11 prints `--opt TYPE=VALUE`) and
checks every "(default V)" the workflow page gives for that option, and that no sentence speaks
of another default threshold (the page once said 4 while the code used 3).
Usage: docs_defaults_test.py NDSID_EXE SOURCE_DIR
"""
import re
import subprocess
import sys
from pathlib import Path

exe, src = sys.argv[1], Path(sys.argv[2])
help_text = subprocess.run([exe, "diagnose", "--help"], check=True, capture_output=True, text=True).stdout
defaults = dict(re.findall(r"(--[a-z-]+) [A-Z]+=(\S+)", help_text))
assert "--z-threshold" in defaults, "diagnose --help shows no default for --z-threshold:\n" + help_text
doc = (src / "docs" / "model-workflow.md").read_text()
errors = []
stated = re.findall(r"(--[a-z-]+) [A-Z]+ \(default ([^)]+)\)", doc)
if not stated:
    errors.append("docs/model-workflow.md states no '(default V)' for any diagnose option")
for opt, value in stated:
    if opt in defaults and float(defaults[opt]) != float(value):
        errors.append(f"docs say {opt} default {value}, the binary uses {defaults[opt]}")
for m in re.finditer(r"default (?:`--z-threshold`|threshold)[^0-9]{0,8}([0-9.]+)", doc):
    if float(m.group(1)) != float(defaults["--z-threshold"]):
        errors.append(f"docs: '{m.group(0)}' but the default --z-threshold is {defaults['--z-threshold']}")
# docs/new-car.md: every "`--opt` (default V)" is `ndsid init --help`'s default.
init_help = subprocess.run([exe, "init", "--help"], check=True, capture_output=True, text=True).stdout
init_defaults = dict(re.findall(r"(--[a-z-]+) [A-Z]+(?::[^=\s]*(?: in \[[^\]]*\])?)?=(\S+)", init_help))
init_stated = re.findall(r"`(--[a-z-]+)` \(default `?([^)` ]+)`?", (src / "docs" / "new-car.md").read_text())
if len(init_stated) < 2:
    errors.append(f"docs/new-car.md states {len(init_stated)} '`--opt` (default V)' for init, expected --out and --wheelbase")
for opt, value in init_stated:
    got = init_defaults.get(opt)
    same = got is not None and (got == value or (re.fullmatch(r"[0-9.]+", value) and float(got) == float(value)))
    if not same:
        errors.append(f"docs/new-car.md says {opt} default {value}, `ndsid init --help` says {got}")
stated += init_stated
if errors:
    print("\n".join(errors))
    sys.exit(1)
print(f"docs agree with ndsid diagnose --help: {len(stated)} stated default(s)")
