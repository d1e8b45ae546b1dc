#!/usr/bin/env bash
# `ndsid decode` (CSV to a file) against can-utils `log2asc` (ASC to a file) on the same plain
# candump log, side by side, best of 3 each. Default log: replay/clean/drive.log.gz (914 802
# frames), decompressed once. Not part of the test suite.
#   bench/run_decode_csv_bench.sh [LOG.gz|LOG]      (WORK_DIR=/tmp/x keeps the files)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-${NDSID_BUILD_DIR:-$ROOT/build}}"
WORK_DIR="${WORK_DIR:-$(mktemp -d)}"
SRC="${1:-$ROOT/replay/clean/drive.log.gz}"
command -v log2asc >/dev/null || { echo "log2asc missing: apt-get install can-utils" >&2; exit 1; }
cmake --build "$BUILD_DIR" -j2 --target ndsid >/dev/null
LOG="$WORK_DIR/drive.log"
case "$SRC" in *.gz) [[ -s "$LOG" ]] || gzip -dc "$SRC" > "$LOG" ;; *) LOG="$SRC" ;; esac
FRAMES=$(wc -l < "$LOG")

best() {  # best wall time of 3 runs of "$@" (stdout to $OUT_FILE)
  local b=999999 t
  for _ in 1 2 3; do
    /usr/bin/time -f "%e" -o "$WORK_DIR/time.txt" "$@" > "$OUT_FILE" 2>/dev/null
    t=$(tail -1 "$WORK_DIR/time.txt")
    b=$(awk -v a="$b" -v c="$t" 'BEGIN{print (c<a)?c:a}')
  done
  echo "$b"
}
OUT_FILE="$WORK_DIR/decode.csv" T_DEC=$(best "$BUILD_DIR/bin/ndsid" decode --dbc "$ROOT/dbc/ndsid_example.dbc" --log "$LOG")
OUT_FILE="$WORK_DIR/log2asc.stdout" T_ASC=$(best log2asc -I "$LOG" -O "$WORK_DIR/drive.asc" can0 vcan0 can1)
VALUES=$(($(wc -l < "$WORK_DIR/decode.csv") - 1))
awk -v n="$FRAMES" -v v="$VALUES" -v d="$T_DEC" -v a="$T_ASC" 'BEGIN{
  printf "log: %d frames (%d decoded values)\n", n, v;
  printf "ndsid decode -> CSV:  %.2f s  %.2f M frames/s  %.1f M values/s\n", d, n/d/1e6, v/d/1e6;
  printf "log2asc -> ASC:       %.2f s  %.2f M frames/s\n", a, n/a/1e6;
  printf "ratio (log2asc time / ndsid time): %.2f\n", a/d }'
