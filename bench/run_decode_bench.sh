#!/usr/bin/env bash
# Decode throughput: ndsid (CandumpReader + dbc::Decoder) vs python-can CanutilsLogReader +
# cantools on the same generated candump log. Not part of the test suite.
#
#   bench/run_decode_bench.sh [FRAMES] [PY_FRAMES]
#
# FRAMES (default 2000000) frames of dbc/ndsid_example.dbc messages with random payloads are
# written to $WORK_DIR (default a temporary directory). ndsid reads all of them (best of 3
# passes). Python reads the first PY_FRAMES (default: all, one pass; about 12 s for 2 M frames
# here). With PY_FRAMES < FRAMES its rate over that prefix is taken as its rate for the whole
# file (the frame mix is the same throughout) and the output says so. Both decode every
# signal of every frame; the checksums of the decoded values of the first PY_FRAMES frames
# must agree.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-${NDSID_BUILD_DIR:-$ROOT/build}}"
PYTHON="${PYTHON:-$ROOT/.venv/bin/python3}"
FRAMES="${1:-2000000}"
PY_FRAMES="${2:-$FRAMES}"
DBC="$ROOT/dbc/ndsid_example.dbc"
WORK_DIR="${WORK_DIR:-$(mktemp -d)}"
LOG="$WORK_DIR/bench_${FRAMES}.log"

if [[ ! -x "$BUILD_DIR/bench/ndsid_bench_decode_throughput" ]]; then
  cmake -S "$ROOT" -B "$BUILD_DIR" -G Ninja >/dev/null
fi
cmake --build "$BUILD_DIR" -j2 --target ndsid_bench_make_log ndsid_bench_decode_throughput >/dev/null

if [[ ! -s "$LOG" ]]; then
  "$BUILD_DIR/bench/ndsid_bench_make_log" "$DBC" "$LOG" "$FRAMES" 1 >/dev/null
fi
echo "log: $LOG ($(wc -l <"$LOG") lines, $(du -h "$LOG" | cut -f1))"
echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores"

CPP_OUT="$("$BUILD_DIR/bench/ndsid_bench_decode_throughput" "$DBC" "$LOG" 3 "$PY_FRAMES" 2>/dev/null | grep '=')"
PY_OUT="$("$PYTHON" "$ROOT/bench/decode_throughput.py" "$DBC" "$LOG" "$PY_FRAMES")"
echo "$CPP_OUT"
echo "$PY_OUT"

get() { sed -n "s/^$1=//p" <<<"$2"; }
CPP_FPS="$(get parse_decode_fps "$CPP_OUT")"
PY_FPS="$(get py_parse_decode_fps "$PY_OUT")"
CPP_SUM="$(get check_sum "$CPP_OUT")"
PY_SUM="$(get py_check_sum "$PY_OUT")"
awk -v c="$CPP_FPS" -v p="$PY_FPS" -v cs="$CPP_SUM" -v ps="$PY_SUM" -v n="$FRAMES" -v pn="$PY_FRAMES" 'BEGIN {
  d = cs - ps; if (d < 0) d = -d; s = ps < 0 ? -ps : ps;
  printf "checksum of first %d frames: ndsid %s, cantools %s -> %s\n", pn, cs, ps,
         (d <= 1e-9 * (s > 1 ? s : 1)) ? "agree" : "DIFFER";
  printf "ndsid parse+decode:           %.0f frames/s (all %d frames, best of 3)\n", c, n;
  if (pn < n) printf "python-can + cantools:        %.0f frames/s (first %d frames only; extrapolated to all %d: %.1f s)\n", p, pn, n, n / p;
  else        printf "python-can + cantools:        %.0f frames/s (all %d frames, one pass)\n", p, n;
  printf "ratio ndsid / python:         %.0fx\n", c / p;
}'
