#!/usr/bin/env bash
# Builds the Debian package ndsid_<version>-1_<arch>.deb into dist/ (CPack DEB, see
# cmake/package.cmake and docs/install.md). Installs under /usr and /etc whatever prefix the
# build tree was configured with.
#
#   scripts/package.sh              use build/ (configured and built if needed), write dist/
#   scripts/package.sh BUILD_DIR    use another build tree
#   scripts/package.sh --arch arm64 [BUILD_DIR]
#                                   ndsid_<version>-1_arm64.deb from the cross build
#                                   (build-arm64/, cmake/toolchain-arm64.cmake; the sysroot from
#                                   scripts/setup.sh --arch arm64); Depends from the sysroot's
#                                   package data (scripts/deb_depends.sh)
#   NDSID_DIST_DIR=dir              write the .deb somewhere else
#
# Then: apt install ./dist/ndsid_*.deb      (docs/install.md)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
arch=amd64
if [[ "${1:-}" == "--arch" ]]; then
  arch="${2:?--arch needs amd64 or arm64}"
  shift 2
fi
case "$arch" in
  amd64) build="${1:-$here/build}"; configure=() ;;
  arm64) build="${1:-$here/build-arm64}"
         configure=(-DCMAKE_TOOLCHAIN_FILE="$here/cmake/toolchain-arm64.cmake") ;;
  *) echo "package.sh: --arch $arch: amd64 or arm64" >&2; exit 2 ;;
esac
dist="${NDSID_DIST_DIR:-$here/dist}"
log() { printf '[package] %s\n' "$*" >&2; }

if [[ ! -f "$build/CPackConfig.cmake" ]]; then
  log "configuring $build ($arch, Release, no tests, no benchmarks)"
  cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNDSID_BUILD_TESTS=OFF -DNDSID_BUILD_BENCH=OFF \
    "${configure[@]}"
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
cpack_args=()
if [[ "$arch" == arm64 ]]; then
  # dpkg-shlibdeps sees only the host's libraries: Depends from the sysroot instead.
  sysroot="$(sed -n 's/^NDSID_ARM64_SYSROOT:PATH=//p' "$build/CMakeCache.txt")"
  bins=("$build/bin/ndsid" "$build/bin/ndsidd")
  depends="$("$here/scripts/deb_depends.sh" "$sysroot" "${bins[@]}")"
  log "Depends (arm64 sysroot): $depends"
  cpack_args=(-D "CPACK_DEBIAN_PACKAGE_DEPENDS=$depends")
fi
mkdir -p "$dist"
log "cpack -G DEB -> $dist"
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$dist" "${cpack_args[@]}" >"$dist/cpack.log" 2>&1 ||
  { cat "$dist/cpack.log"; exit 1; }
rm -rf "$dist/_CPack_Packages"
deb="$(ls -t "$dist"/ndsid_*_"$arch".deb | head -1)"
log "$deb"
dpkg-deb -f "$deb" Package Version Architecture Depends
echo "$deb"
