#!/usr/bin/env bash
# One periodic update after period_s (10 min) of new data at 1, 5 and 20 gated hours of history:
# the incremental update and the full-window refit, side by side in one process each
# (docs/incremental.md). Usage: bench/run_update_bench.sh [HOURS...]
# NDSID_HELD_OUT=1: every k-th drive held out, as in the pipeline (both fits give its RMSE).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${NDSID_BUILD_DIR:-$here/build}"
cmake --build "$build" --target ndsid_bench_identify_update >/dev/null
hours=("$@")
((${#hours[@]})) || hours=(1 5 20)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
for h in "${hours[@]}"; do
  "$build/bench/ndsid_bench_identify_update" "$h" road_bank
done
