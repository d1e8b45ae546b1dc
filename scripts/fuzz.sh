#!/usr/bin/env bash
# Fuzzing (docs/reliability.md): builds the libFuzzer targets of tests/fuzz with clang into
# build-fuzz/ (ASan + UBSan) and runs each for a while.
#   scripts/fuzz.sh [seconds]            build, then run every target `seconds` long (default 30)
#   scripts/fuzz.sh [seconds] name...    only these targets
#   scripts/fuzz.sh --build              only build
#   scripts/fuzz.sh --one name seconds [build-dir]   run one built target (the ctest label
#                                        "fuzz"); exit 77 (skipped) when it is not built
# Prints the executions per target. A finding (crash, leak, timeout, out-of-memory) is kept in
# build-fuzz/findings/<name>/ and the script exits 1; reproduce it with
#   build-fuzz/tests/fuzz/<name>_fuzz <file>
# New coverage accumulates in build-fuzz/corpus/<name>/ (seeds: tests/fuzz/corpus/<name>/).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${NDSID_FUZZ_BUILD_DIR:-$here/build-fuzz}"

run_one() {  # name seconds build-dir
  local name="$1" seconds="$2" dir="$3"
  local bin="$dir/tests/fuzz/${name}_fuzz"
  if [[ ! -x "$bin" ]]; then
    echo "$name: not built ($bin missing; scripts/fuzz.sh --build makes it): skipped"
    return 77
  fi
  local corpus="$dir/corpus/$name" findings="$dir/findings/$name" log="$dir/logs/$name.log"
  mkdir -p "$corpus" "$findings" "$dir/logs"
  local args=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=8192
              -print_final_stats=1 -artifact_prefix="$findings/")
  [[ -f "$here/tests/fuzz/$name.dict" ]] && args+=(-dict="$here/tests/fuzz/$name.dict")
  local seeds=()
  [[ -d "$here/tests/fuzz/corpus/$name" ]] && seeds=("$here/tests/fuzz/corpus/$name")
  local rc=0
  ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    "$bin" "${args[@]}" "$corpus" "${seeds[@]}" >"$log" 2>&1 || rc=$?
  local runs
  runs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1 || true)"
  if [[ $rc -eq 72 ]]; then  # libFuzzer's exit code when interrupted (SIGINT/SIGTERM): no finding
    echo "$name: interrupted after ${runs:-?} executions, no finding"
    return 1
  fi
  if [[ $rc -ne 0 ]]; then
    echo "$name: FINDING after ${runs:-?} executions (exit $rc); log $log, input in $findings/"
    grep -m3 -E 'ERROR|runtime error|SUMMARY' "$log" || true
    return 1
  fi
  echo "$name: ${runs:-?} executions in ${seconds} s, no finding ($(ls "$corpus" | wc -l) corpus files)"
}

if [[ "${1:-}" == "--one" ]]; then
  run_one "$2" "$3" "${4:-$build}"
  exit $?
fi

build_only=0
seconds=30
if [[ "${1:-}" == "--build" ]]; then build_only=1; shift; fi
if [[ "${1:-}" =~ ^[0-9]+$ ]]; then seconds="$1"; shift; fi

if ! command -v clang++ >/dev/null; then
  echo "fuzz.sh: clang++ not found (Debian: apt-get install clang libfuzzer-14-dev libclang-rt-14-dev)" >&2
  exit 1
fi
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
CC=clang CXX=clang++ cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DNDSID_FUZZ=ON -DNDSID_BUILD_TESTS=OFF -DNDSID_BUILD_BENCH=OFF "${launcher[@]}" >/dev/null
cmake --build "$build" -j "${NDSID_JOBS:-$(nproc)}" --target ndsid_fuzzers
[[ $build_only == 1 ]] && exit 0

targets=("$@")
if [[ ${#targets[@]} -eq 0 ]]; then
  for f in "$build"/tests/fuzz/*_fuzz; do targets+=("$(basename "$f" _fuzz)"); done
fi
failed=0
for t in "${targets[@]}"; do run_one "$t" "$seconds" "$build" || failed=1; done
exit $failed
