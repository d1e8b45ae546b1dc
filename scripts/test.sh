#!/usr/bin/env bash
# README command 2: install what is missing, build, and run the test suite with CTest.
#   scripts/test.sh           every test except those labelled "long" or "vm" (the CI default),
#                             then the arm64 part: ndsid, ndsidd and the unit tests cross built
#                             into build-arm64/, the unit tests and the replay run under qemu-user
#                             and the arm64 package built and checked (label "arm64"; docs/install.md,
#                             "arm64 (cross build)")
#   scripts/test.sh --vm      only the VM test bed (label "vm", 11-17 min on 2 cores; docs/daemon.md)
#   scripts/test.sh --all     everything, including the long accuracy studies, the VM tests and the
#                             whole arm64 part (with the estimates against the simulator's truth)
#   extra arguments go to ctest (e.g. -R Dbc), in both builds
# With clang present it also builds the fuzz targets (build-fuzz/, scripts/fuzz.sh --build), so
# the label "fuzz" runs each for 20 s (docs/reliability.md); NDSID_SKIP_FUZZ=1 leaves that out.
# NDSID_SKIP_ARM64=1 leaves the arm64 part out (it installs the cross compiler and qemu-user,
# downloads the arm64 sysroot once, and takes about 12 min on 2 cores from an empty compiler cache).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
if [[ "${NDSID_SKIP_FUZZ:-0}" != 1 ]] && command -v clang++ >/dev/null; then
  "$here/scripts/fuzz.sh" --build
fi
mode=default
args=(-LE "long|vm")
if [[ "${1:-}" == "--all" ]]; then mode=all; args=(); shift; fi
if [[ "${1:-}" == "--vm" ]]; then mode=vm; args=(-L vm); shift; fi
rc=0
(cd "${NDSID_BUILD_DIR:-$here/build}" && ctest --output-on-failure -j "$(nproc)" --timeout 1500 "${args[@]}" "$@") || rc=$?
if [[ "$mode" == vm || "${NDSID_SKIP_ARM64:-0}" == 1 ]]; then exit "$rc"; fi

# The arm64 part: the label arm64 by default (unit tests, replay, package), everything arm64 with --all.
arm64_dir="${NDSID_ARM64_BUILD_DIR:-$here/build-arm64}"
setup_args=(--arch arm64 --unit-tests)
arm64_args=(-L arm64 -LE long)
if [[ "$mode" == all ]]; then setup_args=(--arch arm64); arm64_args=(-L arm64); fi
NDSID_BUILD_DIR="$arm64_dir" "$here/scripts/setup.sh" "${setup_args[@]}" || exit 1
(cd "$arm64_dir" && ctest --output-on-failure -j "$(nproc)" --timeout 1800 "${arm64_args[@]}" "$@") || rc=$?
exit "$rc"
