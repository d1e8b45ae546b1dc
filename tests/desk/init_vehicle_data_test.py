#!/usr/bin/env python3
"""`ndsid init` writes the data-sheet values it is given and a name of its own per car:
- --wheelbase and --mass land in vehicle.wheelbase_m / vehicle.mass_kg (no placeholder, no CHECK),
  the axle loads and track widths in their keys, and the written config loads (replay runs);
- without them the keys are written commented out with the reason, the summary warns that EG
  scales with the wheelbase, and the file does not load (exit 78 naming the key) until they are set;
- two cars set up in one folder (two logs, one DBC; or the same log written twice) get different
  vehicle names and state folders, so their learned states never mix.
Catches: the wheelbase used only for init's own check, a placeholder that loads, the DBC's name as everyone's vehicle name.
Usage: init_vehicle_data_test.py NDSID_EXE SOURCE_DIR OUT_DIR"""
import os
import re
import shutil
import subprocess
import sys

exe, src, out = sys.argv[1], sys.argv[2], sys.argv[3]
dbc = os.path.join(src, "dbc", "ndsid_example.dbc")
shutil.rmtree(out, ignore_errors=True)
os.makedirs(out)
errors = []


def run(args, expect_rc=0):
    r = subprocess.run([exe] + args, capture_output=True, text=True)
    if r.returncode != expect_rc:
        print(r.stdout, r.stderr[-3000:])
        sys.exit(f"{' '.join(args[:1])}: exit {r.returncode}, expected {expect_rc}")
    return r.stdout


def vehicle_keys(path):
    text = open(path).read()
    keys = dict(re.findall(r"^  (name|wheelbase_m|mass_kg|front_axle_load_kg|rear_axle_load_kg|track_front_m|track_rear_m):"
                           r" *\"?([^\"#\s]+)\"?", text, re.M))
    keys["state_dir"] = re.search(r"^state_dir: *\"?([^\"#\s]+)", text, re.M).group(1)
    return keys, text


run(["simulate", "--hours", "0.05", "--seed", "9", "--out", os.path.join(out, "sim")])
cars = os.path.join(out, "cars")
os.makedirs(cars)
for name in ("cmax_monday.log", "van_tuesday.log"):
    shutil.copy(os.path.join(out, "sim", "drive.log"), os.path.join(cars, name))

# Car 1: every data-sheet value given.
s1 = run(["init", "--dbc", dbc, "--log", os.path.join(cars, "cmax_monday.log"), "--out", os.path.join(cars, "cmax.yaml"),
          "--wheelbase", "2.648", "--mass", "1900", "--front-axle-load-kg", "1050", "--rear-axle-load-kg", "850",
          "--track-front", "1.58", "--track-rear", "1.55"])
k1, t1 = vehicle_keys(os.path.join(cars, "cmax.yaml"))
want = {"wheelbase_m": "2.648", "mass_kg": "1900", "front_axle_load_kg": "1050", "rear_axle_load_kg": "850",
        "track_front_m": "1.58", "track_rear_m": "1.55"}
for key, value in want.items():
    if k1.get(key) != value:
        errors.append(f"car 1: vehicle.{key} = {k1.get(key)}, expected {value}")
if "NOT STATED" in t1 or "WARNING" in s1:
    errors.append("car 1: a placeholder or warning although --wheelbase and --mass were given")

# Car 2: nothing given: the keys commented out with the reason, a warning naming the wheelbase,
# and a file that does not load until they are set (exit 78, the key named).
s2 = run(["init", "--dbc", dbc, "--log", os.path.join(cars, "van_tuesday.log"), "--out", os.path.join(cars, "van.yaml")])
k2, t2 = vehicle_keys(os.path.join(cars, "van.yaml"))
if "wheelbase_m" in k2 or "mass_kg" in k2:
    errors.append(f"car 2: a wheelbase or mass written although none was given: {k2}")
if not re.search(r"^  # NOT STATED: this car's wheelbase.*EG scales with it", t2, re.M) or not re.search(r"^  # wheelbase_m:$", t2, re.M):
    errors.append("car 2: the wheelbase is not written commented out with its reason")
if not re.search(r"^WARNING: vehicle.wheelbase_m is not stated: EG scales with the wheelbase", s2, re.M):
    errors.append("car 2: no warning line that EG scales with the wheelbase")
r2 = subprocess.run([exe, "replay", "--config", os.path.join(cars, "van.yaml"), "--final-only"], capture_output=True, text=True)
if r2.returncode != 78 or not re.search(r"van\.yaml:\d+.*vehicle\.wheelbase_m: not stated; EG scales with it", r2.stderr + r2.stdout):
    errors.append(f"car 2: replay of the file without a wheelbase: exit {r2.returncode}, expected 78 naming "
                  f"vehicle.wheelbase_m:\n{r2.stdout[-1500:]}{r2.stderr[-1500:]}")
# With the wheelbase written in by hand but no mass: the mass is named next.
with open(os.path.join(cars, "van_l.yaml"), "w") as f:
    f.write(t2.replace("  # wheelbase_m:\n", "  wheelbase_m: 3.1\n").replace("out/state/van_tuesday", "out/state/van_l"))
r3 = subprocess.run([exe, "replay", "--config", os.path.join(cars, "van_l.yaml"), "--final-only"], capture_output=True, text=True)
if r3.returncode != 78 or "vehicle.mass_kg: not stated" not in r3.stderr + r3.stdout:
    errors.append(f"car 2 with a wheelbase: exit {r3.returncode}, expected 78 naming vehicle.mass_kg:\n{r3.stderr[-1500:]}")

# Car 3: the first car's log again, written into the same folder under another file name.
run(["init", "--dbc", dbc, "--log", os.path.join(cars, "cmax_monday.log"), "--out", os.path.join(cars, "cmax_again.yaml"),
     "--wheelbase", "2.648", "--mass", "1900"])
k3, _ = vehicle_keys(os.path.join(cars, "cmax_again.yaml"))
names = [k["name"] for k in (k1, k2, k3)]
states = [k["state_dir"] for k in (k1, k2, k3)]
print("names:", names, "state dirs:", states)
if len(set(names)) != 3 or len(set(states)) != 3:
    errors.append(f"cars in one folder share a name or state folder: {names}, {states}")
if names[0] != "cmax_monday-ndsid_example" or names[1] != "van_tuesday-ndsid_example":
    errors.append(f"names not from the log's and the DBC's stems: {names}")
if any(s != "out/state/" + n for s, n in zip(states, names)):
    errors.append(f"state_dir does not follow the name: {states}")

# Both axle loads or neither (exit 78, the configuration error).
run(["init", "--dbc", dbc, "--log", os.path.join(cars, "cmax_monday.log"), "--out", os.path.join(out, "bad.yaml"),
     "--front-axle-load-kg", "1000"], expect_rc=78)

# The written config loads and runs, with the given wheelbase.
r = subprocess.run([exe, "replay", "--config", os.path.join(cars, "cmax.yaml"), "--final-only", "--report",
                    os.path.join(out, "report")], capture_output=True, text=True)
if "EG = " not in r.stdout:
    errors.append("replay of car 1's config printed no EG:\n" + r.stdout[-2000:] + r.stderr[-2000:])

if errors:
    print("\n".join(errors))
    sys.exit(1)
print("data-sheet values written, values not given leave a file that does not load, three cars in one folder have three names and state folders")
