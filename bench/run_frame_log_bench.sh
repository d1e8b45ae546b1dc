#!/usr/bin/env bash
# Read throughput of every log format: replay/clean/drive.log.gz (914 802 frames) converted to
# Vector ASC and BLF (python-can) and ASAM MF4 (asammdf, transposed-deflate blocks), each read
# through can::OpenFrameLog, best of 3 passes. The checksum column (ids + payload bytes) must be
# the same on every line. Not part of the test suite.
#   bench/run_frame_log_bench.sh          (WORK_DIR=/tmp/x keeps and reuses the converted files)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD_DIR:-${NDSID_BUILD_DIR:-$ROOT/build}}"
PYTHON="${PYTHON:-$ROOT/.venv/bin/python3}"
WORK_DIR="${WORK_DIR:-$(mktemp -d)}"
LOG="$ROOT/replay/clean/drive.log.gz"

cmake --build "$BUILD_DIR" -j2 --target ndsid_bench_frame_log_throughput >/dev/null
[[ -s "$WORK_DIR/drive.mf4" ]] || "$PYTHON" "$ROOT/bench/make_format_logs.py" "$LOG" "$WORK_DIR"
[[ -s "$WORK_DIR/drive.log" ]] || gzip -dc "$LOG" > "$WORK_DIR/drive.log"
"$BUILD_DIR/bench/ndsid_bench_frame_log_throughput" 3 "$WORK_DIR/drive.log" "$LOG" \
  "$WORK_DIR/drive.asc" "$WORK_DIR/drive.blf" "$WORK_DIR/drive.mf4"
