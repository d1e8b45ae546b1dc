#!/usr/bin/env bash
# The arm64 package under systemd as PID 1 in the arm64 VM (docs/daemon.md, "The arm64 VM test
# bed"; ctest -L vm: vm_Arm64SystemdUnit):
#
#   tests/vm/arm64_unit_test.sh [DEB]
#
# DEB (default $NDSID_ARM64_DEB, else the newest dist/ndsid_*_arm64.deb of the source tree):
# the package scripts/package.sh --arch arm64 makes. The root comes from tests/vm/arm64_root.sh
# (made on the first run, then cached); the source tree is shared read-only into the VM at its
# own path. In the VM, tests/vm/systemd_unit_test.sh installs the package with dpkg -i and runs
# the same checks as on amd64 (notify, watchdog, SIGKILL restart with the learned state,
# MemoryMax, config error 78, the vcan can0 from networkd fed by canplayer, LCM recorded by
# lcm-logger). That VM has no Python LCM module: the log it recorded is decoded here.
# Exit: the test's; 77 (skipped, with the reason) without the package, qemu or mmdebstrap.
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
src="${NDSID_SOURCE_DIR:-$(cd "$here/../.." && pwd)}"
skip() { echo "arm64_unit_test: SKIPPED: $*"; exit 77; }
deb="${1:-${NDSID_ARM64_DEB:-$(ls -t "$src"/dist/ndsid_*_arm64.deb 2>/dev/null | head -1)}}"
[[ -n "$deb" && -r "$deb" ]] ||
  skip "no arm64 package (make it with: scripts/setup.sh --arch arm64 && scripts/package.sh --arch arm64)"
deb="$(cd "$(dirname "$deb")" && pwd)/$(basename "$deb")"
command -v qemu-system-aarch64 >/dev/null || skip "qemu-system-aarch64 not installed (Debian package qemu-system-arm)"
if [[ ! -f "$("$here/arm64_root.sh" --print)/.ndsid-vm-root.sha256" ]]; then
  command -v mmdebstrap >/dev/null || skip "no arm64 VM root and no mmdebstrap to make one (scripts/setup.sh --arch arm64)"
fi
root="$("$here/arm64_root.sh" --deb "$deb")" || { echo "arm64_unit_test: the VM root could not be made"; exit 1; }

shares=(--share "$src")
[[ "$deb" == "$src"/* ]] || shares+=(--share "$(dirname "$deb")")
results="$(mktemp -d /tmp/ndsid-arm64-unit.XXXXXX)"
trap 'rm -rf "$results"' EXIT
NDSID_DEB="$deb" NDSID_SOURCE_DIR="$src" NDSID_VM_RESULTS="$results" \
  "$here/run_vm.sh" --arch arm64 --root "$root" "${shares[@]}" --systemd --timeout "${NDSID_VM_TIMEOUT:-2400}" \
  "$here/systemd_unit_test.sh"
rc=$?
if [[ -f "$results/ndsid.lcmlog" ]]; then
  py="${NDSID_PYTHON:-$src/.venv/bin/python3}"
  types="${NDSID_LCMTYPES_PYTHONPATH:-$src/build/lcmtypes/python}"
  if decoded="$(PYTHONPATH="$types" "$py" "$here/lcmlog_summary.py" "$results/ndsid.lcmlog")"; then
    echo "RESULT lcm (decoded on the host): $decoded"
  else
    echo "FAIL: no decoded status with frames from the arm64 VM's lcm-logger log: $decoded"
    [[ $rc -eq 0 ]] && rc=1
  fi
fi
echo "arm64_unit_test: exit $rc"
exit "$rc"
