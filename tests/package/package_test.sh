#!/usr/bin/env bash
# The Debian package, end to end (docs/install.md):
#   1. cpack -G DEB from this build tree (under umask 077: the package must not depend on it)
#   2. control data (dpkg-deb -I): Depends covers every shared library the binaries link and
#      is satisfiable on this Debian 12 system (apt-get install -s), the conffile, the
#      maintainer scripts
#   3. contents (dpkg-deb -c): the expected files with their modes, root-owned, nothing
#      outside /usr and /etc
#   4. dpkg --root into a scratch root (systemd is not PID 1 there), maintainer scripts run
#      chroot-less with DPKG_ROOT; the root holds only the binaries' shared libraries, systemd's
#      units and /bin/kill (copied from this system, standing in for the Debian 12 packages)
#   5. chroot ROOT ndsidd --config /etc/ndsid/vehicle.yaml --check-config: exit 0;
#      systemd-analyze verify --root=ROOT on the installed unit: no findings; the LCM types
#      load in Python and compile in C++
#   6. remove keeps the edited conffile; purge leaves the root exactly as before the install
# Exit 77 (skipped) without root (dpkg --root and chroot need it) or dpkg-deb.
#   package_test.sh BUILD_DIR WORK_DIR
set -u   # no pipefail: `cmd | grep -q` would fail on SIGPIPE; exit codes are checked where they matter
build="$(cd "$1" && pwd)"
work="$2"
fail() { echo "FAIL: $*" >&2; exit 1; }
pass() { echo "ok: $*"; }

[[ $(id -u) -eq 0 ]] || { echo "SKIP: needs root (dpkg --root, chroot)"; exit 77; }
for t in dpkg-deb dpkg cpack chroot; do
  command -v "$t" >/dev/null || { echo "SKIP: $t not installed"; exit 77; }
done

rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

# --- 1. build ------------------------------------------------------------------------------
start=$(date +%s)
(umask 077 && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/dist") >cpack.log 2>&1 ||
  { cat cpack.log; fail "cpack"; }
debs=("$work"/dist/ndsid_*.deb)
[[ ${#debs[@]} -eq 1 && -f "${debs[0]}" ]] || fail "expected one ndsid_*.deb in $work/dist, got: ${debs[*]}"
deb="${debs[0]}"
pass "built $(basename "$deb") ($(stat -c %s "$deb") bytes) in $(($(date +%s) - start)) s"

# --- 2. control data -----------------------------------------------------------------------
dpkg-deb -I "$deb" >info.txt || fail "dpkg-deb -I"
dpkg-deb -f "$deb" Package | grep -qx ndsid || fail "Package: $(dpkg-deb -f "$deb" Package)"
depends="$(dpkg-deb -f "$deb" Depends)"
echo "Depends: $depends"
dpkg-deb -e "$deb" control
grep -qx /etc/ndsid/vehicle.yaml control/conffiles || fail "vehicle.yaml is not a conffile"
for s in postinst prerm postrm; do
  [[ "$(stat -c %a "control/$s")" == 755 ]] || fail "control/$s mode $(stat -c %a "control/$s")"
  sh -n "control/$s" || fail "control/$s: shell syntax"
done
# Every shared library the binaries link directly (ELF NEEDED) comes from a package named in
# Depends, by name or by what it Provides (libspdlog1.10 provides libspdlog1.10-fmt9); dpkg -S
# on this Debian 12 system maps library -> package. Libraries those pull in are their
# packages' own Depends.
dpkg-deb -x "$deb" extracted
mapfile -t depnames < <(echo "$depends" | tr ',|' '\n\n' | sed -E 's/\(.*\)//; s/^ +//; s/ +$//' | grep -v '^$')
in_depends() { local n d; for n in "$@"; do for d in "${depnames[@]}"; do [[ "$n" == "$d" ]] && return 0; done; done; return 1; }
needed=0
missing=0
for exe in extracted/usr/sbin/ndsidd extracted/usr/bin/ndsid; do
  for soname in $(readelf -d "$exe" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    # "name => path"; the dynamic loader (NEEDED by position-independent code using TLS) is listed
    # by its path alone, "/lib64/ld-linux-x86-64.so.2 (0x...)".
    lib="$(ldd "$exe" | awk -v s="$soname" '$1 == s {print $3; exit} $1 ~ ("/" s "$") {print $1; exit}')"
    [[ -n "$lib" ]] || fail "$exe: $soname not found by ldd"
    pkg=""
    for candidate in "$lib" "$(readlink -f "$lib")"; do
      for variant in "$candidate" "/usr${candidate#/usr}" "${candidate#/usr}"; do
        [[ -n "$pkg" ]] || pkg="$(dpkg -S "$variant" 2>/dev/null | head -1 | cut -d: -f1)"
      done
    done
    [[ -n "$pkg" ]] || fail "$lib belongs to no package"
    provides="$(dpkg-query -W -f='${Provides}' "$pkg" 2>/dev/null | tr ',' '\n' | sed -E 's/\(.*\)//; s/ //g')"
    # shellcheck disable=SC2086
    if ! in_depends "$pkg" $provides; then
      echo "  $(basename "$exe") needs $soname ($pkg${provides:+, provides $provides}): not in Depends" >&2
      missing=$((missing + 1))
    fi
    needed=$((needed + 1))
  done
done
(( needed >= 10 )) || fail "only $needed NEEDED entries found (the check would prove little)"
(( missing == 0 )) || fail "$missing needed libraries' packages are missing from Depends"
pass "Depends names the package of each of the $needed libraries ndsidd and ndsid link (ELF NEEDED)"
# ... and this Debian 12 system's packages satisfy Depends, versions and virtual names included.
if command -v apt-get >/dev/null; then
  apt-get install -s "$deb" >apt-simulate.txt 2>&1 || { cat apt-simulate.txt; fail "apt-get install -s: Depends not satisfiable"; }
  grep -q "^Inst ndsid " apt-simulate.txt || { cat apt-simulate.txt; fail "apt-get install -s would not install ndsid"; }
  extra="$(grep '^Inst ' apt-simulate.txt | grep -v '^Inst ndsid ' || true)"
  pass "apt-get install -s: Depends satisfied by this Debian 12 system${extra:+ after installing: $(echo "$extra" | cut -d' ' -f2 | tr '\n' ' ')}"
fi

# --- 3. contents ---------------------------------------------------------------------------
dpkg-deb -c "$deb" >contents.txt || fail "dpkg-deb -c"
expect_mode() {  # expect_mode MODE PATH
  grep -Eq "^$1 root/root +[0-9]+ [0-9-]+ [0-9:]+ \./${2#/}$" contents.txt ||
    fail "$2: expected $1 root/root, got: $(grep -E " \./${2#/}$" contents.txt || echo 'not in the package')"
}
for f in /usr/sbin/ndsidd /usr/bin/ndsid /usr/bin/ndsid-lcm-spy /usr/bin/ndsid-foxglove; do expect_mode -rwxr-xr-x "$f"; done
for f in /etc/ndsid/vehicle.yaml /usr/lib/systemd/system/ndsidd.service /usr/share/ndsid/dbc/ndsid_example.dbc \
         /usr/share/ndsid/java/ndsid_lcmtypes.jar /usr/include/ndsid/estimate_t.hpp \
         /usr/include/ndsid/status_t.hpp /usr/include/ndsid/monitor_t.hpp \
         /usr/lib/python3/dist-packages/ndsid/__init__.py /usr/lib/python3/dist-packages/ndsid/estimate_t.py \
         /usr/share/ndsid/systemd/80-can0.network /usr/share/doc/ndsid/install.md /usr/share/doc/ndsid/daemon.md \
         /usr/share/doc/ndsid/monitoring.md /usr/share/doc/ndsid/configuration.md /usr/share/doc/ndsid/changelog.Debian.gz \
         /usr/share/ndsid/foxglove/foxglove_bridge.py /usr/share/ndsid/foxglove/ndsid-layout.json \
         /usr/share/ndsid/foxglove/requirements.txt; do
  expect_mode -rw-r--r-- "$f"
done
bad_dirs="$(grep '^d' contents.txt | grep -v '^drwxr-xr-x root/root ' || true)"
[[ -z "$bad_dirs" ]] || fail "folders not 0755 root/root:"$'\n'"$bad_dirs"
bad_owner="$(grep -v ' root/root ' contents.txt || true)"
[[ -z "$bad_owner" ]] || fail "entries not owned by root:"$'\n'"$bad_owner"
outside="$(awk '{print $6}' contents.txt | grep -Ev '^\./$|^\./(usr|etc)(/|$)' || true)"
[[ -z "$outside" ]] || fail "files outside /usr and /etc:"$'\n'"$outside"
file extracted/usr/sbin/ndsidd | grep -q "stripped" && ! file extracted/usr/sbin/ndsidd | grep -q "not stripped" ||
  fail "ndsidd is not stripped: $(file extracted/usr/sbin/ndsidd)"
pass "$(grep -vc '^d' contents.txt) files, modes and owners as expected, nothing outside /usr and /etc"

# --- 4. install into a scratch root --------------------------------------------------------
root="$work/root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/var/lib/dpkg/triggers" "$root/var/lib/private"
touch "$root/var/lib/dpkg/status"
chmod 0700 "$root/var/lib/private"
# The shared libraries of the binaries (the dynamic loader included), in the same paths.
for exe in extracted/usr/sbin/ndsidd extracted/usr/bin/ndsid; do
  ldd "$exe" | grep -oE '/[^ ]+' | while read -r lib; do
    [[ -e "$root$lib" ]] || cp -L --parents "$lib" "$root/" 2>/dev/null || true
  done
done
# systemd's units (sysinit.target, multi-user.target, ...) and /bin/kill (ExecReload): what the
# systemd package would have put there, for systemd-analyze verify --root.
if [[ -d /usr/lib/systemd/system ]]; then
  mkdir -p "$root/usr/lib/systemd"
  cp -a /usr/lib/systemd/system "$root/usr/lib/systemd/"
  rm -f "$root/usr/lib/systemd/system/ndsidd.service"   # in case this machine has ndsid installed
  cp --parents -L /bin/kill "$root/" 2>/dev/null || true
fi
snapshot() { (cd "$root" && find . -path ./var/lib/dpkg -prune -o -print | sort); }
snapshot >before.txt
dpkg_root() { dpkg --root="$root" --log="$work/dpkg.log" --force-script-chrootless "$@"; }
dpkg_root --force-depends -i "$deb" >dpkg-install.log 2>&1 || { cat dpkg-install.log; fail "dpkg --root -i"; }
dpkg --root="$root" -s ndsid | grep -qx "Status: install ok installed" || fail "ndsid not installed in the root"
pass "dpkg --root $root -i: $(dpkg --root="$root" -L ndsid | wc -l) paths"

# --- 5. the installed files work -----------------------------------------------------------
cfg="$root/etc/ndsid/vehicle.yaml"
dbc="$(sed -n 's/^dbc: *//p' "$cfg")"
[[ "$dbc" == /* && -f "$root$dbc" ]] || fail "the config's dbc '$dbc' is not an installed file"
out="$(chroot "$root" /usr/sbin/ndsidd --config /etc/ndsid/vehicle.yaml --check-config 2>&1)"
rc=$?
echo "$out"
[[ $rc -eq 0 ]] || fail "installed ndsidd --check-config exited $rc"
echo "$out" | grep -q "configuration OK (vehicle example-cmax, DBC $dbc, socketcan can0)" || fail "check-config said: $out"
chroot "$root" /usr/bin/ndsid --help >/dev/null 2>&1 || fail "installed ndsid --help"
pass "chroot: ndsidd --check-config exit 0 on the installed config (socketcan can0, DBC $dbc)"

if command -v systemd-analyze >/dev/null; then
  verify="$(systemd-analyze verify --man=no --root="$root" /usr/lib/systemd/system/ndsidd.service 2>&1)"
  rc=$?
  [[ $rc -eq 0 && -z "$verify" ]] || fail "systemd-analyze verify --root (exit $rc): $verify"
  pass "systemd-analyze verify --root=ROOT /usr/lib/systemd/system/ndsidd.service: no findings"
else
  echo "note: systemd-analyze not installed, unit not verified"
fi

PYTHONPATH="$root/usr/lib/python3/dist-packages" python3 -c '
import ndsid
m = ndsid.estimate_t()
m.vehicle = "x"
b = m.encode()
assert ndsid.estimate_t.decode(b).vehicle == "x", "round trip"
print("python: ndsid.estimate_t round trip,", len(b), "bytes")' || fail "the installed Python module"
if [[ -f /usr/include/lcm/lcm-cpp.hpp ]] && command -v c++ >/dev/null; then
  # Value-initialised (LCM's C++ types have no constructor: a plain `estimate_t e;` leaves
  # num_params indeterminate, and encoding it reads past the empty arrays).
  cat >types.cc <<'CC'
#include <ndsid/estimate_t.hpp>
#include <ndsid/status_t.hpp>
#include <ndsid/monitor_t.hpp>
#include <vector>
int main() {
  ndsid::estimate_t e{};
  e.vehicle = "x";
  e.num_params = 1;
  e.param_name = {"m"};
  e.param_unit = {"kg"};
  e.param_value = {1500.0};
  e.param_sigma = {10.0};
  e.param_fixed = {0};
  e.param_at_bound = {0};
  std::vector<char> buf(e.getEncodedSize());
  if (buf.empty() || e.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) return 1;
  ndsid::estimate_t d{};
  if (d.decode(buf.data(), 0, static_cast<int>(buf.size())) < 0) return 2;
  return d.vehicle == "x" && d.num_params == 1 && d.param_value[0] == 1500.0 ? 0 : 3;
}
CC
  c++ -std=c++17 -I"$root/usr/include" types.cc -o types && ./types || fail "the installed C++ headers"
  pass "C++: the installed headers compile, encode and decode"
fi
unzip -l "$root/usr/share/ndsid/java/ndsid_lcmtypes.jar" 2>/dev/null | grep -q "ndsid/estimate_t.class" ||
  fail "ndsid_lcmtypes.jar lacks ndsid/estimate_t.class"
# The installed launcher finds the installed jar next to itself (headless: it stops at the window).
if command -v java >/dev/null && [[ -f /usr/share/java/lcm.jar && -f /usr/share/java/jchart2d.jar ]]; then
  spy="$(env -u DISPLAY -u NDSID_LCMTYPES_JAR -u CLASSPATH timeout 60 "$root/usr/bin/ndsid-lcm-spy" 2>&1)"
  echo "$spy" | grep -q "Found $(ls "$root"/usr/share/ndsid/lcmtypes/*.lcm | wc -l) LCM types" ||
    fail "installed ndsid-lcm-spy did not load the installed types: $spy"
  pass "installed ndsid-lcm-spy loads the installed type jar"
fi
# The installed Foxglove bridge: without its Python environment it says how to make one; after
# `ndsid-foxglove --setup DIR` (a venv with the pinned foxglove-sdk and lcm from PyPI) it starts
# on the installed script and the installed LCM types (in-process LCM: memq, no network needed).
fg="$root/usr/bin/ndsid-foxglove"
grep -Eq '^foxglove-sdk==[0-9.]+$' "$root/usr/share/ndsid/foxglove/requirements.txt" &&
  grep -Eq '^lcm==[0-9.]+$' "$root/usr/share/ndsid/foxglove/requirements.txt" ||
  fail "the installed foxglove requirements: $(cat "$root/usr/share/ndsid/foxglove/requirements.txt")"
rc=0; out="$(env -u NDSID_PYTHON NDSID_FOXGLOVE_VENV="$work/no-venv" "$fg" 2>&1)" || rc=$?
[[ $rc -eq 1 ]] && echo "$out" | grep -q -- "--setup" ||
  fail "ndsid-foxglove without its environment: exit $rc, said: $out"
if command -v python3 >/dev/null && python3 -c "import venv, ensurepip" 2>/dev/null; then
  env -u NDSID_PYTHON "$fg" --setup "$work/fg-venv" >fg-setup.log 2>&1 || { cat fg-setup.log; fail "ndsid-foxglove --setup"; }
  out="$(env -u NDSID_PYTHON NDSID_FOXGLOVE_VENV="$work/fg-venv" timeout -s INT 8 "$fg" --lcm-url memq:// --port 0 2>&1 || true)"
  echo "$out" | grep -q "^ndsid-foxglove: ws://127.0.0.1:[0-9]* <- LCM memq://" &&
    echo "$out" | grep -q "0 messages forwarded" || fail "installed ndsid-foxglove did not start and stop: $out"
  pass "installed ndsid-foxglove: --setup made its venv ($(grep -c . "$root/usr/share/ndsid/foxglove/requirements.txt") pins), the bridge served and stopped on SIGINT"
else
  echo "note: python3-venv missing, ndsid-foxglove --setup not exercised"
fi

# --- 6. remove, purge ----------------------------------------------------------------------
echo "# edited by the administrator" >>"$cfg"
# What the running service would have left: its learned state under DynamicUser=.
mkdir -p "$root/var/lib/private/ndsid" && echo state >"$root/var/lib/private/ndsid/example-cmax.ndsid-state"
ln -s private/ndsid "$root/var/lib/ndsid"
dpkg_root -r ndsid >dpkg-remove.log 2>&1 || { cat dpkg-remove.log; fail "dpkg -r"; }
[[ ! -e "$root/usr/sbin/ndsidd" ]] || fail "remove left /usr/sbin/ndsidd"
grep -q "edited by the administrator" "$cfg" || fail "remove did not keep the edited conffile"
dpkg_root -P ndsid >dpkg-purge.log 2>&1 || { cat dpkg-purge.log; fail "dpkg -P"; }
snapshot >after.txt
leftover="$(diff before.txt after.txt)"
[[ -z "$leftover" ]] || fail "purge left the root different from before the install:"$'\n'"$leftover"
pass "remove kept the edited /etc/ndsid/vehicle.yaml; purge left the root as before ($(wc -l <before.txt) paths)"
rm -rf "$root" extracted dist/_CPack_Packages   # kept on failure, for a look
echo "PASS: package test in $(($(date +%s) - start)) s"
