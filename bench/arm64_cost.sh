#!/usr/bin/env bash
# The processor's and memory's cost of ndsidd on an arm64 logger, counted in the arm64 VM
# (docs/install.md, "The cost on the logger"):
#
#   bench/arm64_cost.sh [--hours H] [--seed S] [DEB]
#
# Replays, with ndsidd from the arm64 package (DEB, default the newest dist/ndsid_*_arm64.deb),
# the bundled drive (replay/clean/drive.log.gz) and a simulated drive of H hours (default 3, made
# here with build/bin/ndsid simulate --seed S, default 77) in the arm64 VM of the test bed
# (tests/vm/run_vm.sh --arch arm64 --icount: Cortex-A53 cores, one CPU, one instruction = one
# nanosecond of the guest's clock). A process's CPU seconds there are its instructions / 1e9
# (user and kernel, from /usr/bin/time, 10 ms = 1e7 instructions resolution); its peak memory is
# /usr/bin/time's maximum resident set. Prints, per log: the hours of driving (the log's time
# with gaps under 1 s), frames, instructions in all and per hour of driving, the peak memory,
# each periodic identification's instructions, and the processor's share on a 1.5 GHz core at
# 1.0 and 0.5 instructions per cycle (an in-order Cortex-A53 runs such code between the two).
# Takes 10-20 min on 2 cores (emulated), plus the VM root on its first run (tests/vm/arm64_root.sh).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
hours=3 seed=77
while [[ $# -gt 0 ]]; do
  case "$1" in
    --hours) hours="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    *) break ;;
  esac
done
deb="${1:-$(ls -t "$here"/dist/ndsid_*_arm64.deb 2>/dev/null | head -1)}"
[[ -n "$deb" && -r "$deb" ]] || { echo "arm64_cost: no arm64 package (scripts/package.sh --arch arm64)" >&2; exit 2; }
deb="$(cd "$(dirname "$deb")" && pwd)/$(basename "$deb")"
root="$("$here/tests/vm/arm64_root.sh" --deb "$deb")"
work="$(mktemp -d /tmp/ndsid-arm64-cost.XXXXXX)"
trap 'rm -rf "$work"' EXIT
"${BUILD_DIR:-$here/build}/bin/ndsid" simulate --hours "$hours" --seed "$seed" --gzip --out "$work/sim" >/dev/null
logs=("$here/replay/clean/drive.log.gz" "$work/sim/drive.log.gz")
mkdir -p "$work/results"
shares=(--share "$here" --share "$work/sim")
[[ "$deb" == "$here"/* ]] || shares+=(--share "$(dirname "$deb")")
NDSID_DEB="$deb" NDSID_VM_RESULTS="$work/results" \
  "$here/tests/vm/run_vm.sh" --arch arm64 --root "$root" "${shares[@]}" --icount --mem 2048 --timeout 7200 \
  "$here/bench/arm64_cost_vm.sh" "$here/config/example_vehicle.yaml" "${logs[@]}" >"$work/vm.out" ||
  { cat "$work/vm.out" >&2; echo "arm64_cost: the run in the VM failed" >&2; exit 1; }
grep '^RESULT' "$work/vm.out" >&2
python3 - "$work/vm.out" "${logs[@]}" <<'PY'
import gzip, re, sys
out, logs = open(sys.argv[1]).read(), sys.argv[2:]
def driving_hours(path):
    """Hours of the log's time, gaps of 1 s or more left out (between drives)."""
    total, last = 0.0, None
    with gzip.open(path, "rt") as f:
        for line in f:
            t = float(line[1:line.index(")")])
            if last is not None and 0 <= t - last < 1.0:
                total += t - last
            last = t
    return total / 3600
print("| log | driving h | frames | instructions | per driving hour | peak memory | share of a 1.5 GHz A53 (IPC 1.0 / 0.5) |")
print("|---|---|---|---|---|---|---|")
for i, log in enumerate(logs, 1):
    m = re.search(rf"RESULT case {i}: log \S+; user_s (\S+) sys_s (\S+) maxrss_kb (\d+) frames (\d+)", out)
    if not m:
        sys.exit(f"arm64_cost: no result for {log}")
    ins = (float(m.group(1)) + float(m.group(2))) * 1e9
    h = driving_hours(log)
    per_h = ins / h
    share = [per_h / (1.5e9 * ipc * 3600) for ipc in (1.0, 0.5)]
    print(f"| {log.split('/')[-2]}/{log.split('/')[-1]} | {h:.3f} | {int(m.group(4)):,} | {ins:.3g} | {per_h:.3g} | "
          f"{int(m.group(3)) / 1024:.0f} MB | {100 * share[0]:.3f} % / {100 * share[1]:.3f} % |")
    idents = re.findall(rf"RESULT case {i} ident (\d+): gated_h (\S+) s (\S+)", out)
    if idents:
        print("|  identifications (gated h: instructions) | " +
              ", ".join(f"{float(g):.2f}: {float(s) * 1e9:.2g}" for _, g, s in idents) + " | | | | | |")
PY
