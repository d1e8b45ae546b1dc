#!/usr/bin/env bash
# ndsidd under systemd as PID 1, inside the VM test bed:
#
#   tests/vm/run_vm.sh --systemd tests/vm/systemd_unit_test.sh     (ctest -L vm: vm_SystemdUnit)
#
# Installs the project the way a user does (the package $NDSID_DEB with `dpkg -i`, else the
# Debian package built by cpack from $NDSID_BINARY_DIR, else `cmake --install --prefix /usr`;
# into the VM's RAM overlay), brings up a vcan named can0 with systemd-networkd from the files in systemd/, enables the unit and checks, each with its numbers (`RESULT name: ...`):
# verify + security score, Type=notify readiness, journal, DynamicUser state directory, LCM over
# udpm recorded by lcm-logger and decoded, SIGHUP reload, SIGTERM restart + SIGKILL restart with
# the learned state, watchdog (SIGSTOP), MemoryMax= enforced, a config error -> 78 and no
# restart loop. Exit 0 = all passed, 1 = a failure, 77 = not in the VM.
set -uo pipefail

if [[ "${NDSID_VM:-}" != systemd ]]; then
  echo "systemd_unit_test: SKIPPED: runs inside the VM test bed with systemd (tests/vm/run_vm.sh --systemd)"
  exit 77
fi
src="${NDSID_SOURCE_DIR:?}"
bin="${NDSID_BINARY_DIR:-/nonexistent}"
py="${NDSID_PYTHON:-$src/.venv/bin/python3}"
failures=0
result() { echo "RESULT $*"; echo "RESULT $*" >>"${VM_RESULTS:-/tmp}/systemd_results.txt"; }
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
prop() { systemctl show -p "$2" --value "$1"; }
mono_us() { awk '{ printf "%d", $1 * 1e6 }' /proc/uptime; }
wait_for() {  # wait_for SECONDS COMMAND...: until COMMAND succeeds
  local until=$(($(date +%s) + $1)); shift
  while ! "$@" >/dev/null 2>&1; do
    (($(date +%s) >= until)) && return 1
    sleep 0.5
  done
}
journal_has() { journalctl -u ndsidd --no-pager -o cat | grep -q "$1"; }
journal_count() { journalctl -u ndsidd --no-pager -o cat | grep -c "$1"; }

# --- install: the project's Debian package (cpack from the build tree), else cmake --install ---
t0=$(date +%s.%N)
how=""
if [[ -n "${NDSID_DEB:-}" ]]; then  # a package built beforehand (the arm64 one)
  dpkg -i "$NDSID_DEB" >/tmp/install.log 2>&1 || { cat /tmp/install.log; exit 1; }
  how="dpkg -i $(basename "$NDSID_DEB") ($(dpkg --print-architecture))"
elif [[ -f "$bin/CPackConfig.cmake" ]] && command -v cpack >/dev/null; then
  if cpack -G DEB --config "$bin/CPackConfig.cmake" -B /tmp/dist >/tmp/install.log 2>&1 &&
     deb=$(ls /tmp/dist/ndsid_*.deb 2>/dev/null | head -1) && [[ -n "$deb" ]] &&
     dpkg -i "$deb" >>/tmp/install.log 2>&1; then
    how="dpkg -i $(basename "$deb") (cpack -G DEB)"
  else
    echo "package build/install failed, falling back to cmake --install:"; tail -20 /tmp/install.log
  fi
fi
if [[ -z "$how" ]]; then
  cmake --install "$bin" --prefix /usr >/tmp/install.log 2>&1 || { cat /tmp/install.log; exit 1; }
  how="cmake --install --prefix /usr"
fi
unit=$(ls /usr/lib/systemd/system/ndsidd.service /usr/local/lib/systemd/system/ndsidd.service 2>/dev/null | head -1)
[[ -n "$unit" ]] || { echo "no ndsidd.service installed"; cat /tmp/install.log; exit 1; }
cfg_dir=$(sed -n 's|^ExecStart=[^ ]* --config \(.*\)/vehicle.yaml$|\1|p' "$unit")
mkdir -p "$cfg_dir"
# The example config on the live bus can0 (what a user edits after installing).
awk '/^source:/ { print "source:\n  type: socketcan\n  interface: can0"; skip = 1; next }
     skip && /^[^ #]/ { skip = 0 }
     !skip { print }' "$cfg_dir/vehicle.yaml" >/tmp/vehicle.yaml
sed -i 's/min_drive_km: 2.0/min_drive_km: 0.5/' /tmp/vehicle.yaml
install -m 0644 /tmp/vehicle.yaml "$cfg_dir/vehicle.yaml"
good_cfg=/tmp/vehicle.yaml
result "install: $how in $(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s; unit $unit, config $cfg_dir/vehicle.yaml"

# --- can0: a vcan from systemd-networkd -------------------------------------------------------
mkdir -p /etc/systemd/network
sed 's/^Name=vcan0/Name=can0/' "$src/systemd/80-vcan0.netdev" >/etc/systemd/network/80-can0.netdev
cp "$src/systemd/80-can0.network" /etc/systemd/network/80-can0.network
systemctl enable --now systemd-networkd >/dev/null 2>&1
if wait_for 30 sh -c 'ip -br link show can0 | grep -q UP'; then
  result "networkd: $(ip -br link show can0 | tr -s ' ') ($(networkctl status can0 --no-pager 2>/dev/null | sed -n 's/^ *State: //p'))"
else
  fail "networkd did not bring can0 up: $(ip -br link show can0 2>&1); $(journalctl -u systemd-networkd --no-pager -o cat | tail -5)"
  ip link add dev can0 type vcan 2>/dev/null; ip link set up can0
fi
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo 2>/dev/null

# --- verify and security ------------------------------------------------------------------------
systemctl daemon-reload
v=$(systemd-analyze verify "$unit" 2>&1)
[[ -z "$v" ]] && result "verify: clean" || { fail "systemd-analyze verify: $v"; }
score=$(systemd-analyze security ndsidd --no-pager 2>/dev/null | sed -n 's/.*Overall exposure level for ndsidd.service: \([0-9.]*\).*/\1/p')
result "security: exposure $score"
awk -v s="$score" 'BEGIN { exit !(s != "" && s <= 2.0) }' || fail "security exposure $score > 2.0"

# --- start: Type=notify -----------------------------------------------------------------------
systemctl enable ndsidd >/dev/null 2>&1
t=$(mono_us)
systemctl start ndsidd
ready_us=$(prop ndsidd ActiveEnterTimestampMonotonic)
start_us=$(prop ndsidd ExecMainStartTimestampMonotonic)
[[ "$(prop ndsidd ActiveState)" == active ]] || fail "not active after start: $(systemctl status ndsidd --no-pager | tail -5)"
result "notify: active (READY=1) $(awk -v a="$start_us" -v b="$ready_us" 'BEGIN { printf "%.2f", (b - a) / 1e6 }') s after exec, $(awk -v a="$t" -v b="$ready_us" 'BEGIN { printf "%.2f", (b - a) / 1e6 }') s after systemctl start; status: $(prop ndsidd StatusText)"
pid=$(prop ndsidd MainPID)
user=$(ps -o user= -p "$pid")
result "dynamic user: MainPID $pid runs as '$user' (uid $(ps -o uid= -p "$pid" | tr -d ' ')); /var/lib/ndsid -> $(readlink /var/lib/ndsid)"
[[ "$user" != root ]] || fail "runs as root"
journal_has "ndsidd: vehicle" && result "journal: $(journalctl -u ndsidd --no-pager -o cat | grep -m1 'ndsidd: vehicle')" || fail "no start line in the journal"

# --- data: 2 x 60 s of the recorded drive into can0 at recorded speed -----------------------------
# (180-240 s gates 0.0156 h as a file; 240-300 s follows it in the same drive)
zcat "$src/replay/clean/drive.log.gz" 2>/dev/null | awk 'NR == 1 { t0 = substr($1, 2) + 0 } { t = substr($1, 2) + 0 - t0 }
  t >= 180 && t < 240 { print >"/tmp/slice_a.log" } t >= 240 && t < 300 { print >"/tmp/slice_b.log" } t >= 300 { exit }'

# LCM recorded by lcm-logger over udpm while the first half plays, decoded with the Python types.
lcm-logger --quiet --force "--lcm-url=udpm://239.255.76.67:7667?ttl=0" /tmp/ndsid.lcmlog >/dev/null 2>&1 &
logger_pid=$!
canplayer -I /tmp/slice_a.log can0=can0
result "played: $(wc -l </tmp/slice_a.log) frames into can0: $(ip -s -br link show can0 2>/dev/null | tr -s ' ' | head -1); ndsidd: $(prop ndsidd StatusText)"
kill -INT "$logger_pid"; wait "$logger_pid" 2>/dev/null
if [[ -x "$py" ]] && PYTHONPATH="$bin/lcmtypes/python" "$py" -c "import lcm, ndsid" 2>/dev/null; then
  decoded=$(PYTHONPATH="$bin/lcmtypes/python" "$py" "$src/tests/vm/lcmlog_summary.py" /tmp/ndsid.lcmlog)
  result "lcm: lcm-logger recorded and decoded: $decoded"
  [[ "$decoded" == *"frames_read"* && "$decoded" != *"frames_read 0,"* ]] || fail "no decoded status with frames from lcm-logger's log"
else
  # No Python LCM module in this VM (the arm64 one): the caller decodes the log on the host.
  cp /tmp/ndsid.lcmlog "${VM_RESULTS:-/tmp}/ndsid.lcmlog"
  result "lcm: lcm-logger recorded $(stat -c %s /tmp/ndsid.lcmlog) bytes, decoded on the host (no Python LCM module here)"
  [[ -s /tmp/ndsid.lcmlog ]] || fail "lcm-logger recorded nothing"
fi

# --- SIGHUP reload ----------------------------------------------------------------------------
systemctl reload ndsidd
wait_for 20 journal_has "configuration reloaded" && result "reload: '$(journalctl -u ndsidd --no-pager -o cat | grep -m1 'configuration reloaded')', MainPID $(prop ndsidd MainPID) (was $pid)" || fail "reload not logged"
[[ "$(prop ndsidd MainPID)" == "$pid" ]] || fail "reload changed the main PID"

# --- SIGTERM restart persists; SIGKILL restart keeps what was persisted ---------------------------
systemctl restart ndsidd
state=$(ls /var/lib/private/ndsid/*.ndsid-state 2>/dev/null | head -1)
[[ -n "$state" ]] || fail "no state file in /var/lib/private/ndsid after a restart"
persisted=$(ndsidd --config "$cfg_dir/vehicle.yaml" --show-state 2>/dev/null | sed -n 's/^gated_hours: //p')
result "state: after systemctl restart (SIGTERM): $state ($(stat -c '%s bytes, mode %a, owner %U' "$state")), gated_hours $persisted"
canplayer -I /tmp/slice_b.log can0=can0
before=$(prop ndsidd NRestarts); pid=$(prop ndsidd MainPID)
systemctl kill -s KILL ndsidd
wait_for 30 sh -c "[ \"\$(systemctl show -p NRestarts --value ndsidd)\" -gt $before ] && [ \"\$(systemctl show -p ActiveState --value ndsidd)\" = active ]" ||
  fail "no restart after SIGKILL"
loaded=$(journalctl -u ndsidd --no-pager -o cat _PID="$(prop ndsidd MainPID)" | grep -m1 "gated h," || true)
# What the file held at the kill: the SIGTERM's state plus whatever a persist wrote while the
# second half played (ndsidd persists after every identification and every 300 s).
on_disk=$(ndsidd --config "$cfg_dir/vehicle.yaml" --show-state 2>/dev/null | sed -n 's/^gated_hours: //p')
result "sigkill: restarted (NRestarts $before -> $(prop ndsidd NRestarts), PID $pid -> $(prop ndsidd MainPID)); loaded: $loaded; on disk $on_disk h (after SIGTERM $persisted h); what was played after the last persist is lost"
[[ "$loaded" == *"$(printf '%.4f' "$on_disk") gated h"* ]] || fail "restart did not load the state on disk ($on_disk h): $loaded"
awk -v a="$on_disk" -v b="$persisted" 'BEGIN { exit !(a + 0 >= b + 0) }' || fail "the state on disk ($on_disk h) lost what the SIGTERM persisted ($persisted h)"

# --- watchdog: a stopped process is restarted ---------------------------------------------------
before=$(prop ndsidd NRestarts); pid=$(prop ndsidd MainPID)
t=$(date +%s.%N)
systemctl kill -s STOP ndsidd
if wait_for 60 sh -c "[ \"\$(systemctl show -p NRestarts --value ndsidd)\" -gt $before ] && [ \"\$(systemctl show -p ActiveState --value ndsidd)\" = active ]"; then
  result "watchdog: SIGSTOP -> restarted after $(awk -v a="$t" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s (WatchdogSec=$(prop ndsidd WatchdogUSec), RestartSec 5 s); journal: $(journalctl -u ndsidd --no-pager -o cat | grep -m1 -i 'watchdog timeout' || echo '-')"
else
  fail "no watchdog restart after SIGSTOP"
fi

# --- MemoryMax: the unit's limit, then a tiny one to show it enforced ----------------------------
peak=$(prop ndsidd MemoryPeak 2>/dev/null); cur=$(prop ndsidd MemoryCurrent)
result "memory: MemoryMax=$(prop ndsidd MemoryMax), MemoryCurrent $cur, VmHWM $(sed -n 's/VmHWM: *//p' /proc/"$(prop ndsidd MainPID)"/status)"
[[ "$(prop ndsidd MemoryMax)" != infinity ]] || fail "no MemoryMax= in the unit"
mkdir -p /run/systemd/system/ndsidd.service.d
printf '[Service]\nMemoryMax=1M\nMemorySwapMax=0\n' >/run/systemd/system/ndsidd.service.d/tiny.conf
systemctl daemon-reload
systemctl restart ndsidd >/dev/null 2>&1
canplayer -I /tmp/slice_a.log can0=can0 &
player=$!
wait_for 60 sh -c "systemctl show -p Result --value ndsidd | grep -q oom-kill || journalctl -u ndsidd --no-pager -o cat | grep -qi 'oom'"
oom=$(journalctl -u ndsidd --no-pager -o cat | grep -m1 -i "oom" || true)
kill "$player" 2>/dev/null; wait "$player" 2>/dev/null
result "memorymax: with MemoryMax=1M: Result=$(prop ndsidd Result); journal: ${oom:--}"
[[ -n "$oom" ]] || fail "MemoryMax=1M not enforced (no OOM kill)"
rm -rf /run/systemd/system/ndsidd.service.d
systemctl daemon-reload
systemctl reset-failed ndsidd 2>/dev/null
systemctl restart ndsidd

# --- a configuration error: 78, no restart loop ---------------------------------------------------
printf 'vehicle: [unclosed\n' >"$cfg_dir/vehicle.yaml"
systemctl reset-failed ndsidd 2>/dev/null
before=$(prop ndsidd NRestarts)
systemctl restart ndsidd 2>/dev/null
sleep 20
result "config error: ActiveState $(prop ndsidd ActiveState), Result $(prop ndsidd Result), ExecMainStatus $(prop ndsidd ExecMainStatus), NRestarts $before -> $(prop ndsidd NRestarts) in 20 s; journal: $(journalctl -u ndsidd --no-pager -o cat | grep -m1 'vehicle.yaml:' || true)"
[[ "$(prop ndsidd ExecMainStatus)" == 78 ]] || fail "exit status $(prop ndsidd ExecMainStatus), not 78"
[[ "$(prop ndsidd NRestarts)" == "$before" ]] || fail "restarted on a config error"
[[ "$(prop ndsidd ActiveState)" == failed ]] || fail "not failed on a config error"
# The same with the old unit's ExecStartPre= --check-config (why the unit has none): under
# systemd 252 a failing ExecStartPre= is not covered by RestartPreventExitStatus=.
mkdir -p /run/systemd/system/ndsidd.service.d
printf '[Service]\nExecStartPre=%s --config %s/vehicle.yaml --check-config\n' "$(command -v ndsidd)" "$cfg_dir" \
  >/run/systemd/system/ndsidd.service.d/pre.conf
systemctl daemon-reload
systemctl reset-failed ndsidd 2>/dev/null
before=$(prop ndsidd NRestarts)
systemctl restart ndsidd 2>/dev/null
sleep 20
result "config error with ExecStartPre=: ActiveState $(prop ndsidd ActiveState), NRestarts $before -> $(prop ndsidd NRestarts) in 20 s (RestartSec 5 s; the StartLimitBurst= backstop is not waited for here)"
rm -rf /run/systemd/system/ndsidd.service.d
systemctl daemon-reload
install -m 0644 "$good_cfg" "$cfg_dir/vehicle.yaml"
systemctl reset-failed ndsidd 2>/dev/null
systemctl restart ndsidd
[[ "$(prop ndsidd ActiveState)" == active ]] && result "recovered: active again with the good config" || fail "not active with the good config again"

echo "systemd_unit_test: $failures failure(s)"
[[ $failures -eq 0 ]]
