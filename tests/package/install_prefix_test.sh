#!/usr/bin/env bash
# `cmake --install BUILD --prefix P` with a prefix other than the configured one: the unit and
# the default config must name P's paths, and every absolute path they name must exist in the
# install. Catches: the unit pointing at /usr/local/sbin/ndsidd after `--prefix /usr` (the
# service exited 78), a config whose DBC or log source does not exist after install.
#   install_prefix_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build="$1"
work="$2"
fail() { echo "FAIL: $*" >&2; exit 1; }

check_prefix() {
  local prefix="$1" etc="$2"
  local dest="$work/$(echo "$prefix" | tr / _)"
  rm -rf "$dest"
  DESTDIR="$dest" cmake --install "$build" --prefix "$prefix" >"$dest.log" 2>&1 || { cat "$dest.log"; fail "install to $prefix"; }
  local unit="$dest$prefix/lib/systemd/system/ndsidd.service" cfg="$dest$etc/ndsid/vehicle.yaml"
  [[ -f "$unit" ]] || fail "no unit at ${unit#$dest}"
  [[ -f "$cfg" ]] || fail "no config at ${cfg#$dest}"
  grep -qx "ExecStart=$prefix/sbin/ndsidd --config $etc/ndsid/vehicle.yaml" "$unit" ||
    fail "$prefix: ExecStart is: $(grep '^ExecStart=' "$unit")"
  # No ExecStartPre=: ndsidd itself exits 78 on a bad config, which RestartPreventExitStatus=
  # covers; a failing ExecStartPre= is restarted in a loop (docs/daemon.md, tests/vm).
  if grep -q "^ExecStartPre=" "$unit"; then fail "$prefix: ExecStartPre is back: $(grep '^ExecStartPre=' "$unit")"; fi
  grep -q "^  type: socketcan" "$cfg" || fail "$prefix: the installed config is not on socketcan"
  grep -q "^  interface: can0" "$cfg" || fail "$prefix: the installed config is not on can0"
  grep -q "^dbc: $prefix/share/ndsid/dbc/ndsid_example.dbc" "$cfg" || fail "$prefix: dbc is: $(grep '^dbc:' "$cfg")"
  if grep -Eq "^[a-z_]+: *\.\.?/|^ +- *\.\.?/" "$cfg"; then fail "$prefix: relative path left in the installed config"; fi
  # Every absolute path in the unit's Exec lines and Documentation, and the config's dbc, exists.
  local n=0 p
  for p in $(cat "$unit" "$cfg" | sed 's|file://| |g' | grep -oE '(^|[ =(])/(usr|etc|opt)[^ ]*' |
             sed -E 's/^[ =(]//; s/[:,.;)]+$//' | sort -u); do
    [[ -e "$dest$p" ]] || fail "$prefix: $p is named but not installed"
    n=$((n + 1))
  done
  (( n >= 4 )) || fail "$prefix: only $n installed paths found in unit+config (the check would prove nothing)"
  [[ "$(stat -c %a "$cfg")" == 644 && "$(stat -c %a "$unit")" == 644 ]] || fail "$prefix: config/unit modes $(stat -c %a "$cfg" "$unit")"
  echo "PASS: --prefix $prefix: unit and $etc/ndsid/vehicle.yaml name $n paths, all installed"
  rm -rf "$dest"   # ~160 MB of unstripped binaries each
}

mkdir -p "$work"
umask 077   # the install must not depend on the installer's umask
check_prefix /usr /etc
check_prefix /usr/local /usr/local/etc
check_prefix /opt/ndsid /etc/opt/ndsid
