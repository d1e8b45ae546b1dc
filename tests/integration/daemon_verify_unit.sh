#!/usr/bin/env bash
# systemd-analyze verify UNIT: exit 0 only when it succeeds AND prints nothing (it reports
# unknown keys and bad values as warnings with exit status 0). 77 = skipped.
set -u
unit="$1"
if ! command -v systemd-analyze >/dev/null; then
  echo "SKIP: systemd-analyze not installed (Debian package systemd)"
  exit 77
fi
out="$(systemd-analyze verify --man=no "$unit" 2>&1)"
rc=$?
if [[ $rc -ne 0 || -n "$out" ]]; then
  echo "FAIL: systemd-analyze verify $unit (exit $rc):"
  echo "$out"
  exit 1
fi
echo "PASS: systemd-analyze verify $unit: no findings"
