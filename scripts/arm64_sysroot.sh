#!/usr/bin/env bash
# Makes the arm64 sysroot for the cross build (cmake/toolchain-arm64.cmake, docs/install.md,
# "arm64 (cross build)"): Debian 12's arm64 -dev packages the build links against, and their
# dependencies, unpacked by mmdebstrap --variant=extract (no maintainer scripts run, so no
# emulation is needed to make it). Several of these -dev packages (liblcm-dev, libyaml-cpp-dev,
# libgoogle-glog-dev, libgflags-dev, libmetis-dev) are not Multi-Arch: same, so they cannot be
# installed beside the amd64 ones with dpkg --add-architecture; a separate root can hold them.
#
#   scripts/arm64_sysroot.sh          make the sysroot unless it is there and up to date
#   scripts/arm64_sysroot.sh --print  print its path only
#   NDSID_ARM64_SYSROOT=dir           where it goes (default ~/.cache/ndsid/sysroot-arm64)
#
# Downloads about 150 MB of .debs from the host's Debian mirror on the first run (a few
# minutes); later runs reuse it. This script is part of the stamp: changing it (the package
# list, the fix-ups) remakes the sysroot.
set -euo pipefail
sysroot="${NDSID_ARM64_SYSROOT:-${XDG_CACHE_HOME:-$HOME/.cache}/ndsid/sysroot-arm64}"
if [[ "${1:-}" == "--print" ]]; then echo "$sysroot"; exit 0; fi
log() { printf '[arm64-sysroot] %s\n' "$*" >&2; }

# What CMakeLists.txt finds (find_package, pkg_check_modules) and the tests link, for arm64.
# Not here: pybind11 and python3-dev (the cross build leaves the Python module out), Java
# (the jar is architecture-independent and comes from an amd64 build), libbenchmark-dev
# (no benchmarks in the cross build).
SYSROOT_PACKAGES=(
  libc6-dev libstdc++-12-dev
  libceres-dev libeigen3-dev
  liblcm-dev libglib2.0-dev
  libspdlog-dev libyaml-cpp-dev libgtest-dev libgmock-dev libcli11-dev libsystemd-dev
  nlohmann-json3-dev zlib1g-dev
)
suite=bookworm
mirror="http://deb.debian.org/debian"
security="http://deb.debian.org/debian-security"

want="$(printf '%s\n' "$suite" "$mirror" "${SYSROOT_PACKAGES[@]}" | cat - "${BASH_SOURCE[0]}" | sha256sum | cut -d' ' -f1)"
stamp="$sysroot/.ndsid-sysroot.sha256"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$want" ]]; then
  log "up to date: $sysroot"
  echo "$sysroot"
  exit 0
fi

command -v mmdebstrap >/dev/null || { log "mmdebstrap missing: scripts/setup.sh --arch arm64 installs it"; exit 1; }
log "making $sysroot (mmdebstrap --variant=extract, arm64, $suite)"
tmp="$sysroot.tmp"
rm -rf "$tmp"
mkdir -p "$(dirname "$sysroot")"
include="$(IFS=,; echo "${SYSROOT_PACKAGES[*]}")"
# --variant=extract: only the named packages and their dependencies, unpacked, nothing run.
# --skip=cleanup/reproducible: keep what extract unpacked as it is.
mmdebstrap --variant=extract --architectures=arm64 --include="$include" \
  --aptopt='Acquire::Retries "3"' --skip=cleanup/apt/cache \
  "$suite" "$tmp" \
  "deb $mirror $suite main" "deb $mirror $suite-updates main" "deb $security $suite-security main" >&2

# Which package shipped which file, and its shlibs/symbols files: extract runs no dpkg, so
# the sysroot has no dpkg database; scripts/deb_depends.sh reads these to write the arm64
# package's Depends. One folder: <package>.list (paths), <package>.shlibs, <package>.symbols.
meta="$tmp/var/lib/ndsid-packages"
mkdir -p "$meta"
for deb in "$tmp"/var/cache/apt/archives/*.deb; do
  pkg="$(dpkg-deb -f "$deb" Package)"
  dpkg-deb -c "$deb" | awk '{print $6}' | sed 's#^\./#/#' >"$meta/$pkg.list"
  ctrl="$(mktemp -d)"
  dpkg-deb -e "$deb" "$ctrl"
  for f in shlibs symbols; do
    if [[ -f "$ctrl/$f" ]]; then cp "$ctrl/$f" "$meta/$pkg.$f"; fi
  done
  rm -rf "$ctrl"
done
log "package metadata of $(ls "$meta"/*.list | wc -l) packages in ${meta#"$tmp"}"

# Only what the build reads: qemu-aarch64-static -L looks up every absolute path in the sysroot
# first, so folders made for a running system (/dev, /tmp, /run, ...) would hide the host's.
rm -rf "$tmp/dev" "$tmp/tmp" "$tmp/run" "$tmp/proc" "$tmp/sys" "$tmp/var/cache" "$tmp/var/log"

# The linker and the compiler resolve symbolic links on the host: an absolute link inside the
# sysroot (/usr/lib/aarch64-linux-gnu/libfoo.so -> /lib/...) would point at the host's amd64
# files. Rewrite each into a link relative to its own folder.
fixed=0
while IFS= read -r -d '' link; do
  target="$(readlink "$link")"
  [[ "$target" == /* ]] || continue
  rel="$(realpath -m --relative-to="$(dirname "$link")" "$tmp$target")"
  ln -sfn "$rel" "$link"
  fixed=$((fixed + 1))
done < <(find "$tmp" -type l -print0)
log "absolute symlinks made relative: $fixed"

# What the skipped maintainer scripts would have done that the build needs:
# - update-alternatives for BLAS/LAPACK: libblas.so(.3) and liblapack.so(.3) -> ATLAS, the
#   provider Debian 12 picks (the amd64 host's choice too; the package Depends on libatlas3-base).
lib="$tmp/usr/lib/aarch64-linux-gnu"
for so in libblas.so libblas.so.3 liblapack.so liblapack.so.3; do
  [[ -e "$lib/atlas/$so" ]] || { log "missing $lib/atlas/$so"; exit 1; }
  ln -sfn "atlas/$so" "$lib/$so"
done
# - Ceres's exported target names BLAS/LAPACK by absolute path (/usr/lib/aarch64-linux-gnu/...),
#   which the linker would look for on the host: put it under CMAKE_SYSROOT.
sed -i 's#;/usr/lib/aarch64-linux-gnu/#;${CMAKE_SYSROOT}/usr/lib/aarch64-linux-gnu/#g' \
  "$lib/cmake/Ceres/CeresTargets.cmake"

rm -rf "$sysroot"
mv "$tmp" "$sysroot"
echo "$want" >"$stamp"
log "done: $(du -sh "$sysroot" | cut -f1) in $sysroot"
echo "$sysroot"
