#!/bin/sh
# Runs inside the arm64 VM with qemu's instruction clock (bench/arm64_cost.sh starts it): installs
# the arm64 package and replays each log with ndsidd under /usr/bin/time. One instruction is one
# nanosecond of this VM's clock, so CPU seconds here are 1e9 instructions.
#   arm64_cost_vm.sh CONFIG LOG...
set -e
cfg_in="$1"; shift
cfg_dir=$(dirname "$cfg_in")
dpkg -i "$NDSID_DEB" >/tmp/install.log 2>&1 || { cat /tmp/install.log; exit 1; }
echo "RESULT installed: $(dpkg-query -W ndsid) on $(uname -m), $(nproc) CPU"
i=0
for log in "$@"; do
  i=$((i + 1))
  dir=/tmp/case$i
  mkdir -p "$dir/state"
  # The config with this log, absolute paths and a state folder of its own.
  awk -v logf="$log" -v st="$dir/state" -v cd="$cfg_dir" '
    /^source:/ { print "source:\n  type: log\n  logs:\n    - " logf; skip = 1; next }
    skip && /^[^ #]/ { skip = 0 }
    skip { next }
    /^dbc:/ { sub(/dbc: */, "dbc: " cd "/"); print; next }
    /^state_dir:/ { print "state_dir: " st; next }
    /^report_dir:/ { print "report_dir: " st; next }
    { print }' "$cfg_in" >"$dir/vehicle.yaml"
  /usr/bin/time -f "%U %S %M" -o "$dir/time" ndsidd --config "$dir/vehicle.yaml" --persist-interval-s 1e9 \
    >"$dir/out.log" 2>&1 || { tail -20 "$dir/out.log"; exit 1; }
  read -r user sys rss <"$dir/time"
  frames=$(sed -n 's/.* done: \([0-9]*\) frames.*/\1/p' "$dir/out.log" | head -1)
  final=$(grep -m1 "final estimate" "$dir/out.log" | sed 's/.*final estimate: //')
  echo "RESULT case $i: log $log; user_s $user sys_s $sys maxrss_kb $rss frames $frames; $final"
  # Each identification's own duration (guest seconds = 1e9 instructions) and its gated hours.
  sed -n 's/.*identification \([0-9]*\): .*, \([0-9.]*\) gated h, [A-Z_]* (\([0-9.]*\) s.*/RESULT ident \1: gated_h \2 s \3/p' \
    "$dir/out.log" | sed "s/^RESULT ident/RESULT case $i ident/"
done
