#!/usr/bin/env bash
# README command 2: install what is missing, build, and run the test suite with CTest.
#   scripts/test.sh           every test except those labelled "long" or "vm" (the CI default)
#   scripts/test.sh --vm      only the VM test bed (label "vm", 11-17 min on 2 cores; docs/daemon.md)
#   scripts/test.sh --all     everything, including the long accuracy studies and the VM tests
#   extra arguments go to ctest (e.g. -R Dbc)
# With clang present it also builds the fuzz targets (build-fuzz/, scripts/fuzz.sh --build), so
# the label "fuzz" runs each for 20 s (docs/reliability.md); NDSID_SKIP_FUZZ=1 leaves that out.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
if [[ "${NDSID_SKIP_FUZZ:-0}" != 1 ]] && command -v clang++ >/dev/null; then
  "$here/scripts/fuzz.sh" --build
fi
args=(-LE "long|vm")
if [[ "${1:-}" == "--all" ]]; then args=(); shift; fi
if [[ "${1:-}" == "--vm" ]]; then args=(-L vm); shift; fi
cd "${NDSID_BUILD_DIR:-$here/build}"
exec ctest --output-on-failure -j "$(nproc)" --timeout 1500 "${args[@]}" "$@"
