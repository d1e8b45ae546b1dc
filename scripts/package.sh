#!/usr/bin/env bash
# Builds the Debian package ndsid_<version>-1_<arch>.deb into dist/ (CPack DEB, see
# cmake/package.cmake and docs/install.md). Installs under /usr and /etc whatever prefix the
# build tree was configured with.
#
#   scripts/package.sh              use build/ (configured and built if needed), write dist/
#   scripts/package.sh BUILD_DIR    use another build tree
#   NDSID_DIST_DIR=dir              write the .deb somewhere else
#
# Then: apt install ./dist/ndsid_*.deb      (docs/install.md)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$here/build}"
dist="${NDSID_DIST_DIR:-$here/dist}"
log() { printf '[package] %s\n' "$*" >&2; }

if [[ ! -f "$build/CPackConfig.cmake" ]]; then
  log "configuring $build (Release, no tests, no benchmarks)"
  cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNDSID_BUILD_TESTS=OFF -DNDSID_BUILD_BENCH=OFF
fi
# Only what the package installs: the two programs and the generated LCM types.
targets=(ndsid ndsidd ndsid_lcmtypes_cpp_gen ndsid_lcmtypes_python)
if grep -q "ndsid_lcmtypes_java" "$build/build.ninja" 2>/dev/null || grep -q "ndsid_lcmtypes_java" "$build/Makefile" 2>/dev/null; then
  targets+=(ndsid_lcmtypes_java)
else
  log "warning: no Java type jar (javac or /usr/share/java/lcm.jar missing): the package lacks ndsid_lcmtypes.jar"
fi
log "building ${targets[*]}"
cmake --build "$build" -j "${NDSID_JOBS:-2}" --target "${targets[@]}"
mkdir -p "$dist"
log "cpack -G DEB -> $dist"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$dist" >"$dist/cpack.log" 2>&1 || { cat "$dist/cpack.log"; exit 1; }
rm -rf "$dist/_CPack_Packages"
deb="$(ls -t "$dist"/ndsid_*.deb | head -1)"
log "$deb"
dpkg-deb -f "$deb" Package Version Architecture Depends
echo "$deb"
