#!/usr/bin/env bash
# Identification wall time and peak memory for windows of 1 h, 5 h and 20 h of gated driving,
# each in a fresh process (so peak RSS is that window's), with the coarse start (the default) and
# without it, side by side. With BASELINE=path/to/an/older/ndsid_bench_identify_window (built from
# another commit), that binary runs beside them on the same window.
# Usage: [BASELINE=...] bench/run_identify_bench.sh [HOURS...]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${NDSID_BUILD_DIR:-$here/build}"
cmake --build "$build" --target ndsid_bench_identify_window >/dev/null
hours=("$@")
((${#hours[@]})) || hours=(1 5 20)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
for h in "${hours[@]}"; do
  echo "-- with the coarse start (default):"
  "$build/bench/ndsid_bench_identify_window" "$h" road_bank
  echo "-- without it:"
  "$build/bench/ndsid_bench_identify_window" "$h" --no-coarse-start road_bank
  if [[ -n "${BASELINE:-}" ]]; then
    echo "-- baseline $BASELINE:"
    "$BASELINE" "$h" road_bank
  fi
done
