#!/usr/bin/env bash
# Replaying HOURS (default 10) of simulated logged driving with the daemon's update schedule
# (a fit every identification.period_s of data time, incremental: docs/incremental.md) against
# the same pipeline pass with one fit at the end (--final-only), the periodic schedule with
# full-window refits (identification.incremental: false), and can-utils `log2asc` converting
# the same plain candump log, side by side (RUNS=N: N interleaved runs, medians compared). Not
# part of the test suite.
#   bench/run_replay_bench.sh [HOURS]      (WORK_DIR=/tmp/x keeps and reuses the log)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-${NDSID_BUILD_DIR:-$ROOT/build}}"
WORK_DIR="${WORK_DIR:-$(mktemp -d)}"
HOURS="${1:-10}"
command -v log2asc >/dev/null || { echo "log2asc missing: apt-get install can-utils" >&2; exit 1; }
cmake --build "$BUILD_DIR" -j2 --target ndsid >/dev/null
NDSID="$BUILD_DIR/bin/ndsid"
SIM="$WORK_DIR/sim$HOURS"
if [[ ! -s "$SIM/drive.log" ]]; then
  "$NDSID" simulate --hours "$HOURS" --seed 5 --out "$SIM" > /dev/null
fi
LOG="$SIM/drive.log"
FRAMES=$(wc -l < "$LOG")
# The same configuration with full-window periodic refits.
# (Relative paths in a configuration are relative to its folder: the DBC path is made absolute.)
sed -e 's/^  incremental: true /  incremental: false/' -e "s|^dbc: \.\./|dbc: $ROOT/|" \
  "$ROOT/config/example_vehicle.yaml" > "$WORK_DIR/full.yaml"
grep -q '^  incremental: false' "$WORK_DIR/full.yaml" || { echo "could not switch incremental off" >&2; exit 1; }

run() {  # label, then the ndsid replay arguments; prints the wall time and the replay's time line
  local label=$1; shift
  /usr/bin/time -f "%e" -o "$WORK_DIR/time.txt" "$NDSID" replay --log "$LOG" --report "$WORK_DIR/report-$label" "$@" \
    > "$WORK_DIR/$label.out" 2> "$WORK_DIR/$label.err"
  printf '%-34s %7.1f s   %s\n' "$label" "$(tail -1 "$WORK_DIR/time.txt")" "$(grep -m1 '  time:' "$WORK_DIR/$label.out" | sed 's/^ *//')"
  grep -m1 'EG ' "$WORK_DIR/$label.out" | sed 's/^ */    /'
}
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "log: $HOURS h simulated (seed 5), $FRAMES frames, $(du -h "$LOG" | cut -f1)"
ONLY="${ONLY:-final-only periodic-incremental periodic-full}"   # a subset, e.g. ONLY=periodic-full
# RUNS=N runs the set N times, interleaved, and compares medians: on a 2-core machine one run's
# pass without fits varies by about 15 %, and the ratio with it.
RUNS="${RUNS:-1}"
[[ "$RUNS" =~ ^[1-9][0-9]*$ ]] || { echo "RUNS must be a positive integer, got '$RUNS'" >&2; exit 2; }
# Each run's time line is the replay's own (from opening the logs to the final fit), without
# start-up and report writing; the pass without fits is --final-only's time line less its one fit.
timeline() { grep -m1 '  time:' "$WORK_DIR/$1.out" | sed -E 's/.*time: ([0-9.]+) s wall.*/\1/'; }
finalfit() { grep -m1 '  time:' "$WORK_DIR/$1.out" | sed -E 's/.*final fit ([0-9.]+) s.*/\1/'; }
median() { tr ' ' '\n' | grep . | sort -g | awk '{ v[NR] = $1 } END { print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2) }'; }
declare -A lines
for ((i = 1; i <= RUNS; i++)); do
  [[ $RUNS -gt 1 ]] && echo "run $i of $RUNS"
  for r in $ONLY; do
    case $r in
      final-only) run final-only --config "$ROOT/config/example_vehicle.yaml" --final-only ;;
      periodic-incremental) run periodic-incremental --config "$ROOT/config/example_vehicle.yaml" ;;
      periodic-full) run periodic-full --config "$WORK_DIR/full.yaml" ;;
      *) echo "unknown run '$r' in ONLY" >&2; exit 2 ;;
    esac
    if [[ $r == final-only ]]; then
      lines[pass]+=" $(awk -v w="$(timeline final-only)" -v f="$(finalfit final-only)" 'BEGIN { printf "%.2f", w - f }')"
    else
      lines[$r]+=" $(timeline "$r")"
    fi
  done
done
if [[ " $ONLY " == *" final-only "* ]]; then
  pass=$(echo "${lines[pass]}" | median)
  if [[ $RUNS -gt 1 ]]; then
    echo "pass without fits (final-only's time line less its fit): median $pass s of${lines[pass]}"
  else
    echo "pass without fits (final-only's time line less its fit): $pass s"
  fi
  for r in periodic-incremental periodic-full; do
    [[ " $ONLY " == *" $r "* ]] || continue
    w=$(echo "${lines[$r]}" | median)
    if [[ $RUNS -gt 1 ]]; then
      awk -v w="$w" -v p="$pass" -v r="$r" -v all="${lines[$r]}" \
        'BEGIN { printf "%s: time line median %.1f s of%s = %.2fx the median pass without fits\n", r, w, all, w / p }'
    else
      awk -v w="$w" -v p="$pass" -v r="$r" 'BEGIN { printf "%s: time line %.1f s = %.1fx the pass without fits\n", r, w, w / p }'
    fi
  done
fi
/usr/bin/time -f "%e" -o "$WORK_DIR/time.txt" log2asc -I "$LOG" -O "$WORK_DIR/drive.asc" can0 > /dev/null
printf '%-34s %7.1f s\n' "log2asc (convert only)" "$(tail -1 "$WORK_DIR/time.txt")"
