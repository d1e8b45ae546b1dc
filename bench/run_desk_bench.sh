#!/usr/bin/env bash
# The desk's two long commands on 2 h of simulated driving (targets: `diagnose` < 30 s,
# `compare` < 15 s): `ndsid compare` (base model + road_bank against the measurements, the
# binned where-it-fails tables, the report) and `ndsid diagnose` (step 0, the score tests, the
# error ladder), with `ndsid replay --final-only` (the same log through the pipeline with one
# fit) as the baseline beside them. One hidden effect (a 1.5 deg steering offset) gives the
# ladder a rung to climb. One run each, side by side. Not part of the test suite.
#   bench/run_desk_bench.sh [HOURS] [SEED]     (WORK_DIR=/tmp/x keeps and reuses the log)
# With BASELINE=path/to/an/older/ndsid (built from another commit), each command also runs with
# that binary, right after this build's, on the same log.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-${NDSID_BUILD_DIR:-$ROOT/build}}"
WORK_DIR="${WORK_DIR:-$(mktemp -d)}"
HOURS="${1:-2}"
SEED="${2:-31}"
cmake --build "$BUILD_DIR" -j2 --target ndsid >/dev/null
NDSID="$BUILD_DIR/bin/ndsid"
SIM="$WORK_DIR/sim${HOURS}h-$SEED"
if [[ ! -s "$SIM/drive.log" ]]; then
  "$NDSID" simulate --hours "$HOURS" --seed "$SEED" --effect steer_offset_deg=1.5 --out "$SIM" > /dev/null
fi
LOG="$SIM/drive.log"
CFG="$ROOT/config/example_vehicle.yaml"
run1() {  # binary, label, then the ndsid arguments; prints the wall time and peak memory
  local bin=$1 label=$2; shift 2
  /usr/bin/time -f "%e %M" -o "$WORK_DIR/time.txt" "$bin" "$@" > "$WORK_DIR/$label.out" 2> "$WORK_DIR/$label.err"
  read -r wall rss < <(tail -1 "$WORK_DIR/time.txt")
  printf '%-26s %7.1f s  (max RSS %d MB)\n' "$label" "$wall" "$((rss / 1024))"
}
run() {  # label, then the ndsid arguments (output folders end in the label)
  local label=$1; shift
  run1 "$NDSID" "$label" "$@"
  if [[ -n "${BASELINE:-}" ]]; then
    local args=("$@")
    args[-1]="${args[-1]}-baseline"
    run1 "$BASELINE" "$label-baseline" "${args[@]}"
  fi
}
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "log: $HOURS h simulated (seed $SEED, steer_offset_deg=1.5), $(wc -l < "$LOG") frames"
run replay-final-only replay --config "$CFG" --log "$LOG" --final-only --report "$WORK_DIR/report-replay"
run compare compare --config "$CFG" --log "$LOG" --effects road_bank --out "$WORK_DIR/compare"
run diagnose diagnose --config "$CFG" --log "$LOG" --out "$WORK_DIR/diagnose"
grep -m3 -i -E "rung|added|ladder" "$WORK_DIR/diagnose.out" | sed 's/^/    /' || true
