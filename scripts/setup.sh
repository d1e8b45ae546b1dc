#!/usr/bin/env bash
# Installs what is missing (Debian 12 packages, the project's Python venv), then configures
# and builds ndsid. Idempotent: a second run installs nothing and rebuilds only what changed.
#
#   scripts/setup.sh            install + configure + build (build/)
#   scripts/setup.sh --arch arm64
#                               the arm64 cross build (docs/install.md, "arm64 (cross build)"):
#                               the host tools below, the arm64 sysroot (scripts/arm64_sysroot.sh,
#                               downloads on its first run), configures build-arm64/ with
#                               cmake/toolchain-arm64.cmake and builds ndsid, ndsidd and the
#                               tests labelled arm64 (no venv, no Python module, no benchmarks)
#   scripts/setup.sh --arch arm64 --unit-tests
#                               the same, but builds only ndsid, ndsidd and the arm64 unit tests
#                               (target ndsid_arm64_unit_tests, label arm64; what scripts/test.sh
#                               runs: with the programs, the package and the replay against amd64)
#   NDSID_BUILD_DIR=dir         build somewhere else
#   NDSID_SKIP_INSTALL=1        only configure + build (no apt, no pip)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"

# Debian 12 packages: build tools, libraries, tools the tests drive (can-utils, lcm-*), the
# Python venv's base. Keep this list the single source of truth (docs/install.md refers to it).
DEB_PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libceres-dev libeigen3-dev
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev default-jre-headless default-jdk-headless
  libspdlog-dev libyaml-cpp-dev libgtest-dev libgmock-dev libcli11-dev libsystemd-dev
  libbenchmark-dev nlohmann-json3-dev zlib1g-dev
  pybind11-dev python3-dev                 # the Python package ndsid (docs/python.md)
  can-utils iproute2 systemd
  libjchart2d-java xvfb file unzip          # ndsid-lcm-spy's charts; tests/package (xvfb-run, dpkg-deb checks)
  clang libfuzzer-14-dev libclang-rt-14-dev       # scripts/fuzz.sh (libFuzzer, ASan, UBSan)
  qemu-system-x86 linux-image-amd64 busybox-static   # tests/vm: the VM test bed
  chromium                                 # ReportRendersInHeadlessChromium (the HTML report in a real browser)
  python3 python3-venv python3-pip
)

# The arm64 cross build's host tools: the cross GCC 12, mmdebstrap for the sysroot and the VM
# root, qemu-user to run the arm64 programs and tests, dpkg-dev for dpkg-shlibdeps (the
# package's Depends), qemu-system-arm for the arm64 VM test bed (tests/vm/arm64_unit_test.sh).
ARM64_HOST_PACKAGES=(crossbuild-essential-arm64 mmdebstrap qemu-user-static dpkg-dev qemu-system-arm)

arch=amd64
if [[ "${1:-}" == "--arch" ]]; then
  arch="${2:?--arch needs amd64 or arm64}"
  shift 2
fi
arm64_targets=(ndsid ndsidd ndsid_arm64_tests)
if [[ "${1:-}" == "--unit-tests" ]]; then
  [[ "$arch" == arm64 ]] || { echo "setup.sh: --unit-tests goes with --arch arm64" >&2; exit 2; }
  arm64_targets=(ndsid ndsidd ndsid_arm64_unit_tests)
  shift
fi
case "$arch" in
  amd64) ;;
  arm64) DEB_PACKAGES+=("${ARM64_HOST_PACKAGES[@]}") ;;
  *) echo "setup.sh: --arch $arch: amd64 or arm64" >&2; exit 2 ;;
esac

log() { printf '[setup] %s\n' "$*" >&2; }

install_debian_packages() {
  local missing=()
  for p in "${DEB_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  if ((${#missing[@]} == 0)); then
    log "Debian packages: all present"
    return
  fi
  log "Debian packages missing: ${missing[*]}"
  local sudo=""
  if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

install_python_venv() {
  local venv="$here/.venv" req="$here/requirements.txt"
  local stamp="$venv/.requirements.sha256"
  if [[ ! -x "$venv/bin/python3" ]]; then
    log "creating Python venv in .venv"
    /usr/bin/python3 -m venv "$venv"
  fi
  local want; want="$(sha256sum "$req" | cut -d' ' -f1)"
  if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$want" ]]; then
    log "installing Python packages from requirements.txt"
    "$venv/bin/pip" install -q --disable-pip-version-check -r "$req"
    echo "$want" >"$stamp"
  else
    log "Python venv: up to date"
  fi
}

build() {
  local dir="${NDSID_BUILD_DIR:-$here/build}"
  if [[ ! -f "$dir/build.ninja" ]]; then
    cmake -S "$here" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >&2
  fi
  cmake --build "$dir" -j "$(nproc)" >&2
  # The Python package ndsid (built into $dir/python) importable in the project venv.
  local venv="$here/.venv"
  if [[ -d "$dir/python/ndsid" && -x "$venv/bin/python3" ]]; then
    local site; site="$("$venv/bin/python3" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
    echo "$dir/python" >"$site/ndsid-build.pth"
  fi
}

# The cross build: build-arm64/ (NDSID_BUILD_DIR moves it), only what runs on the logger and
# the arm64 tests (target ndsid_arm64_tests, tests/CMakeLists.txt). Two jobs at most and niced:
# about 40 min on 2 free cores with an empty compiler cache.
build_arm64() {
  local dir="${NDSID_BUILD_DIR:-$here/build-arm64}"
  "$here/scripts/arm64_sysroot.sh" >/dev/null
  if [[ ! -f "$dir/build.ninja" ]]; then
    local launcher=()
    if command -v ccache >/dev/null; then
      launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
    fi
    cmake -S "$here" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_TOOLCHAIN_FILE="$here/cmake/toolchain-arm64.cmake" -DNDSID_BUILD_BENCH=OFF "${launcher[@]}" >&2
  fi
  nice -n 10 cmake --build "$dir" -j "${NDSID_JOBS:-2}" --target "${arm64_targets[@]}" >&2
}

if [[ "${NDSID_SKIP_INSTALL:-0}" != 1 ]]; then
  install_debian_packages
  if [[ "$arch" == amd64 ]]; then install_python_venv; fi
fi
if [[ "$arch" == arm64 ]]; then build_arm64; else build; fi
