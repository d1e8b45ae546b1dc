#!/usr/bin/env bash
# Sanitizer builds (docs/reliability.md):
#   scripts/sanitize.sh asan [ctest args]   build-asan/: ASan + UBSan, the non-long test suite
#   scripts/sanitize.sh tsan [ctest args]   build-tsan/: TSan, the daemon's threaded tests
# Compiler: $CXX or the default (gcc); any sanitizer report fails the test that triggered it.
# Prints the build and test times. Extra arguments go to ctest (e.g. -R Dbc);
# NDSID_SANITIZE_TARGETS="dbc_test config_test" builds only those targets (with -R to match).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="${1:-}"
shift || true
case "$mode" in
  asan)
    flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
    targets=(all)
    tests=(-LE "long|fuzz")
    export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}"
    export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
    ;;
  tsan)
    flags="-fsanitize=thread -fno-omit-frame-pointer"
    # The threaded parts: the daemon (reader, identification and persist threads), in process
    # and as ndsidd under the Python harness; `ndsid replay`'s fits beside the reading.
    targets=(ndsidd daemon_state_store_test daemon_socketcan_test daemon_monitor_test ndsid_daemon_make_log ndsid_slow_fsync
             integration_replay_overlap_test)
    tests=(-R "AccumulatorPersistence|StateTest|DaemonSocketCan|daemon_|ReplayOverlap" -LE long)
    export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=0:second_deadlock_stack=1}"
    ;;
  *)
    echo "usage: scripts/sanitize.sh asan|tsan [ctest args]" >&2
    exit 2
    ;;
esac
build="$here/build-$mode"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
start=$(date +%s)
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DNDSID_BUILD_BENCH=OFF \
  -DCMAKE_C_FLAGS="$flags" -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="${flags%% -fno*}" -DCMAKE_SHARED_LINKER_FLAGS="${flags%% -fno*}" \
  "${launcher[@]}" >/dev/null
if [[ -n "${NDSID_SANITIZE_TARGETS:-}" ]]; then read -r -a targets <<< "$NDSID_SANITIZE_TARGETS"; fi
cmake --build "$build" -j "${NDSID_JOBS:-$(nproc)}" --target "${targets[@]}"
built=$(date +%s)
cd "$build"
rc=0
ctest --output-on-failure -j "$(nproc)" --timeout 1500 "${tests[@]}" "$@" || rc=$?
done_at=$(date +%s)
echo "sanitize.sh $mode: build $((built - start)) s, tests $((done_at - built)) s, ctest exit $rc"
exit $rc
