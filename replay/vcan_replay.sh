#!/usr/bin/env bash
# Replays a candump log through a virtual CAN interface into ndsidd, exercising the live
# SocketCAN path end to end:
#
#   replay/vcan_replay.sh LOG [CONFIG]      (CONFIG defaults to config/example_vehicle.yaml)
#
# 1. creates vcan0 (`ip link add dev vcan0 type vcan && ip link set up vcan0`; root + the vcan
#    kernel module) unless it exists,
# 2. starts ndsidd on vcan0 with a temporary copy of CONFIG whose source is `socketcan vcan0`
#    (written to a temporary folder: CONFIG's folder may be read-only),
# 3. plays LOG into vcan0 with `canplayer -I LOG vcan0=<bus of the log>` at recorded speed
#    (canplayer's <send interface>=<log interface> mapping), then stops ndsidd with SIGTERM.
# Where vcan is unavailable (no module, no root, a container) it says so and falls back to
# running ndsidd on the log file itself (type log): same pipeline, no socket.
#
# Environment: NDSIDD (default: build/bin/ndsidd, else ndsidd on PATH), VCAN (default vcan0).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [[ $# -lt 1 || $# -gt 2 ]]; then
  sed -n '2,16p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
  exit 2
fi
log="$(realpath "$1")"
config="$(realpath "${2:-$here/config/example_vehicle.yaml}")"
vcan="${VCAN:-vcan0}"
ndsidd="${NDSIDD:-$here/build/bin/ndsidd}"
[[ -x "$ndsidd" ]] || ndsidd="$(command -v ndsidd || true)"
[[ -x "$ndsidd" ]] || { echo "vcan_replay: ndsidd not found (build it, or set NDSIDD)" >&2; exit 1; }
[[ -r "$log" ]] || { echo "vcan_replay: cannot read $log" >&2; exit 1; }

# The temporary config lives in a temporary folder (CONFIG's folder may be read-only); its
# relative paths (dbc, state_dir, report_dir) are made absolute against CONFIG's folder.
tmp_dir="$(mktemp -d)"
tmp_config="$tmp_dir/vehicle.yaml"
config_dir="$(dirname "$config")"
daemon_pid=""
cleanup() {
  [[ -n "$daemon_pid" ]] && kill -TERM "$daemon_pid" 2>/dev/null && wait "$daemon_pid" 2>/dev/null
  rm -rf "$tmp_dir"
}
trap cleanup EXIT

# CONFIG with its `source:` block replaced by the lines given.
write_config() {
  awk -v block="$1" '
    /^source:/ { print "source:"; printf "%s\n", block; skip = 1; next }
    skip && /^[^ #]/ { skip = 0 }
    skip { next }
    /^(dbc|state_dir|report_dir):[ \t]*[^ \t\/#"]/ {
      key = $0; sub(/:.*/, "", key)
      rest = $0; sub(/^[^:]*:[ \t]*/, "", rest)
      print key ": " dir "/" rest; next
    }
    { print }
  ' dir="$config_dir" "$config" >"$tmp_config"
}

log_fallback() {
  echo "vcan_replay: $1" >&2
  echo "vcan_replay: FALLBACK: running ndsidd on the log file directly (the SocketCAN path is not exercised)" >&2
  write_config "  type: log
  logs: [\"$log\"]"
  "$ndsidd" --config "$tmp_config"
  exit $?
}

command -v canplayer >/dev/null || log_fallback "canplayer not installed (Debian package can-utils)"
command -v ip >/dev/null || log_fallback "ip not installed (Debian package iproute2)"
if ! ip link show "$vcan" >/dev/null 2>&1; then
  if ! err="$(ip link add dev "$vcan" type vcan 2>&1)"; then
    log_fallback "cannot create $vcan ($err): no vcan kernel module here (modprobe vcan), or not root"
  fi
fi
if ! err="$(ip link set up "$vcan" 2>&1)"; then
  log_fallback "cannot bring $vcan up ($err)"
fi

# canplayer reads plain logs only.
plain="$log"
if [[ "$(head -c2 "$log" | od -An -tx1 | tr -d ' ')" == "1f8b" ]]; then
  plain="$tmp_dir/replay.log"
  zcat "$log" >"$plain"
fi
bus="$(awk '$1 ~ /^\(/ { print $2; exit }' "$plain")"
[[ -n "$bus" ]] || { echo "vcan_replay: no frames in $log" >&2; exit 1; }

write_config "  type: socketcan
  interface: $vcan"
echo "vcan_replay: ndsidd on $vcan; playing $log ($bus -> $vcan) at recorded speed" >&2
"$ndsidd" --config "$tmp_config" &
daemon_pid=$!
sleep 1
kill -0 "$daemon_pid" 2>/dev/null || { wait "$daemon_pid"; exit $?; }
canplayer -I "$plain" "$vcan=$bus"
sleep 1  # let the last frames through sync and gate
kill -TERM "$daemon_pid"
wait "$daemon_pid"
rc=$?
daemon_pid=""
echo "vcan_replay: done (ndsidd exit $rc); learned state in the config's state_dir" >&2
exit $rc
