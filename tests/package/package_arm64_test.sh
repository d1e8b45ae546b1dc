#!/usr/bin/env bash
# The arm64 Debian package against the amd64 one (docs/install.md, "arm64 (cross build)"):
#   1. scripts/package.sh --arch arm64 BUILD_DIR (cpack, Depends from the sysroot) and
#      scripts/package.sh HOST_BUILD_DIR (the amd64 package, dpkg-shlibdeps), into WORK_DIR
#   2. control: Architecture arm64, the amd64 package's Version, the conffile and maintainer
#      scripts; Depends names the same packages as the amd64 package's Depends (computed
#      independently: dpkg-shlibdeps on the host's libraries there, the sysroot's shlibs here)
#   3. contents (dpkg-deb -c): the same paths with the same modes and owners as the amd64
#      package; ndsidd and ndsid aarch64 ELF, stripped
#   4. the unpacked package on the sysroot's libraries, under qemu-aarch64-static -L:
#      ndsidd --check-config on the installed /etc/ndsid/vehicle.yaml exits 0, ndsid --help runs
# Exit 77 (skipped) without the host build (HOST_BUILD_DIR/build.ninja) or dpkg-deb.
#   package_arm64_test.sh SOURCE_DIR BUILD_DIR HOST_BUILD_DIR SYSROOT WORK_DIR
set -u
src="$1" build="$2" host="$3" sysroot="$4" work="$5"
fail() { echo "FAIL: $*" >&2; exit 1; }
pass() { echo "ok: $*"; }
for t in dpkg-deb qemu-aarch64-static readelf file; do
  command -v "$t" >/dev/null || { echo "SKIP: $t not installed"; exit 77; }
done
[[ -f "$host/build.ninja" ]] || { echo "SKIP: no host build at $host (the amd64 package to compare with)"; exit 77; }

rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

# --- 1. both packages ----------------------------------------------------------------------
NDSID_DIST_DIR="$work/arm64" "$src/scripts/package.sh" --arch arm64 "$build" >package-arm64.log 2>&1 ||
  { cat package-arm64.log; fail "scripts/package.sh --arch arm64"; }
NDSID_DIST_DIR="$work/amd64" "$src/scripts/package.sh" "$host" >package-amd64.log 2>&1 ||
  { cat package-amd64.log; fail "scripts/package.sh (amd64)"; }
arm="$(ls "$work"/arm64/ndsid_*_arm64.deb)" && amd="$(ls "$work"/amd64/ndsid_*_amd64.deb)" ||
  fail "expected ndsid_*_arm64.deb and ndsid_*_amd64.deb"
pass "built $(basename "$arm") ($(stat -c %s "$arm") bytes) and $(basename "$amd") ($(stat -c %s "$amd") bytes)"

# --- 2. control ------------------------------------------------------------------------------
[[ "$(dpkg-deb -f "$arm" Architecture)" == arm64 ]] || fail "Architecture: $(dpkg-deb -f "$arm" Architecture)"
[[ "$(dpkg-deb -f "$arm" Version)" == "$(dpkg-deb -f "$amd" Version)" ]] || fail "Version differs"
dpkg-deb -e "$arm" control
grep -qx /etc/ndsid/vehicle.yaml control/conffiles || fail "vehicle.yaml is not a conffile"
for s in postinst prerm postrm; do
  [[ "$(stat -c %a "control/$s")" == 755 ]] || fail "control/$s mode $(stat -c %a "control/$s")"
done
names() { dpkg-deb -f "$1" Depends | tr ',|' '\n\n' | sed -E 's/\(.*\)//; s/ //g' | grep -v '^$' | sort -u; }
names "$arm" >depends-arm64.txt
names "$amd" >depends-amd64.txt
diff depends-amd64.txt depends-arm64.txt >depends.diff ||
  fail "Depends names other packages than the amd64 package's:"$'\n'"$(cat depends.diff)"
echo "Depends (arm64): $(dpkg-deb -f "$arm" Depends)"
echo "Depends (amd64): $(dpkg-deb -f "$amd" Depends)"
pass "Depends names the amd64 package's $(wc -l <depends-arm64.txt) packages"

# --- 3. contents -----------------------------------------------------------------------------
# mode, owner, path (sizes and times differ between the architectures)
listing() { dpkg-deb -c "$1" | awk '{print $1, $2, $6}' | sort -k3; }
listing "$arm" >contents-arm64.txt
listing "$amd" >contents-amd64.txt
diff contents-amd64.txt contents-arm64.txt >contents.diff ||
  fail "dpkg-deb -c differs from the amd64 package:"$'\n'"$(cat contents.diff)"
dpkg-deb -x "$arm" extracted
for exe in usr/sbin/ndsidd usr/bin/ndsid; do
  info="$(file "extracted/$exe")"
  [[ "$info" == *"ARM aarch64"* && "$info" == *", stripped"* ]] || fail "$exe: $info"
done
pass "$(wc -l <contents-arm64.txt) entries, the same paths, modes and owners as the amd64 package; binaries aarch64, stripped"

# --- 4. the installed files run --------------------------------------------------------------
# The package unpacked over a hard-linked copy of the sysroot (its libraries stand in for the
# Debian 12 arm64 packages Depends names).
root="$work/root"
cp -al "$sysroot/." "$root/" || fail "copy of the sysroot"
dpkg-deb -x "$arm" "$root" || fail "dpkg-deb -x into the root"
out="$(cd / && qemu-aarch64-static -L "$root" "$root/usr/sbin/ndsidd" --config /etc/ndsid/vehicle.yaml --check-config 2>&1)"
rc=$?
echo "$out"
[[ $rc -eq 0 ]] || fail "arm64 ndsidd --check-config exited $rc"
echo "$out" | grep -q "configuration OK (vehicle example-cmax, DBC /usr/share/ndsid/dbc/ndsid_example.dbc, socketcan can0)" ||
  fail "check-config said: $out"
qemu-aarch64-static -L "$root" "$root/usr/bin/ndsid" --help >/dev/null 2>&1 || fail "arm64 ndsid --help"
pass "qemu-aarch64-static: the installed ndsidd --check-config exit 0 on the installed config; ndsid --help"
rm -rf "$root" extracted
echo "PASS: arm64 package test"
