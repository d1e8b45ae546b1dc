#!/usr/bin/env bash
# Boots a throw-away qemu VM from Debian packages and runs one test script in it
# (docs/daemon.md, "The VM test bed"):
#
#   tests/vm/run_vm.sh [--systemd] [--timeout S] [--mem MB] [--smp N] [--keep]
#                      [--arch amd64|arm64] [--root DIR] [--rw-root] [--share DIR]... [--icount]
#                      TEST_SCRIPT [ARGS...]
#
# - kernel: the newest <root>/boot/vmlinuz-<ver> with its modules in <root>/lib/modules/<ver>
#   (Debian linux-image-amd64 / linux-image-arm64); NDSID_VM_KERNEL=<ver> picks another one.
# - initramfs, built on the fly in a temporary folder: the root's busybox-static plus the modules
#   for virtio/9p/overlay/CAN (with their dependencies from modules.dep).
# - root file system: this machine's / (or --root DIR, e.g. the arm64 root that
#   tests/vm/arm64_root.sh makes) read-only over 9p (virtfs), under a tmpfs overlay, so every
#   write inside the VM goes to RAM and is gone afterwards; --rw-root mounts DIR writable
#   without the overlay (how arm64_root.sh installs its packages). Each --share DIR is mounted
#   read-only at the same path inside (the project's source tree, a package's folder).
# - --arch arm64: qemu-system-aarch64, machine virt with Cortex-A53 cores; --icount counts
#   instructions: one instruction is one nanosecond of the guest's clock (-icount shift=0,
#   one CPU), so a process's CPU time inside is its instruction count (docs/install.md).
# - results: a second, writable 9p share, mounted at /vmresults inside (the directory
#   $NDSID_VM_RESULTS, default a temporary one that is removed unless --keep).
# - without --systemd: the init runs TEST_SCRIPT in a chroot of the overlay (proc, sys, dev,
#   tmpfs /tmp and /run; the vcan module loaded; lo up with multicast) and powers off.
#   With --systemd: switch_root into the overlay with /sbin/init (systemd as PID 1); a unit
#   runs TEST_SCRIPT once multi-user.target is reached, then powers off.
# The NDSID* environment variables are passed in (and VM_RESULTS=/vmresults, NDSID_VM=shell|systemd).
# Exit status: the test's, 124 when the VM timed out (default 600 s), 77 when qemu or a
# kernel is missing (skipped, with the reason). KVM is not used (TCG): it hangs on these hosts.
# Prints the boot times it measured (boot-to-shell / boot-to-multi-user) on stderr.
set -euo pipefail

systemd=0 timeout_s=600 mem=1024 smp=2 keep=0 arch=amd64 vmroot=/ rwroot=0 icount=0
shares=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --systemd) systemd=1; shift ;;
    --timeout) timeout_s="$2"; shift 2 ;;
    --mem) mem="$2"; shift 2 ;;
    --smp) smp="$2"; shift 2 ;;
    --keep) keep=1; shift ;;
    --arch) arch="$2"; shift 2 ;;
    --root) vmroot="$(cd "$2" && pwd)"; shift 2 ;;
    --rw-root) rwroot=1; shift ;;
    --share) shares+=("$(cd "$2" && pwd)"); shift 2 ;;
    --icount) icount=1; smp=1; shift ;;
    -h|--help) sed -n '2,31p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --) shift; break ;;
    -*) echo "run_vm: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
[[ $# -ge 1 ]] || { echo "usage: run_vm.sh [--systemd] [--timeout S] TEST_SCRIPT [ARGS...]" >&2; exit 2; }
test_script="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"; shift  # symlinks kept (a venv python)
[[ -x "$test_script" ]] || { echo "run_vm: $test_script is not executable" >&2; exit 2; }
# The script's path inside the VM: under --root DIR without DIR, under a --share as it is.
vm_script="$test_script"
if [[ "$vmroot" != / ]]; then
  vm_script=""
  [[ "$test_script" == "$vmroot"/* ]] && vm_script="${test_script#"$vmroot"}"
  for d in "${shares[@]}"; do [[ "$test_script" == "$d"/* ]] && vm_script="$test_script"; done
  [[ -n "$vm_script" ]] || { echo "run_vm: $test_script is neither in --root nor in a --share" >&2; exit 2; }
fi

skip() { echo "run_vm: SKIPPED: $*" >&2; exit 77; }
case "$arch" in
  amd64) qemu_bin=qemu-system-x86_64 qemu_pkg=qemu-system-x86 machine=() console=ttyS0 ;;
  arm64) qemu_bin=qemu-system-aarch64 qemu_pkg=qemu-system-arm machine=(-M virt -cpu cortex-a53) console=ttyAMA0 ;;
  *) echo "run_vm: --arch $arch: amd64 or arm64" >&2; exit 2 ;;
esac
qemu="$(command -v "$qemu_bin" || true)"
[[ -n "$qemu" ]] || skip "$qemu_bin not installed (Debian package $qemu_pkg)"
rp="${vmroot%/}"  # the root's prefix on this host ("" for /)
busybox=""
for b in "$rp/bin/busybox" "$rp/usr/bin/busybox"; do
  if [[ -x "$b" ]] && file -L "$b" 2>/dev/null | grep -q "statically linked"; then busybox="$b"; break; fi
done
[[ -n "$busybox" ]] || skip "no static busybox in $vmroot (Debian package busybox-static)"
kver="${NDSID_VM_KERNEL:-}"
if [[ -z "$kver" ]]; then
  for k in $(ls "$rp"/boot/vmlinuz-* 2>/dev/null | sed "s|^$rp/boot/vmlinuz-||" | sort -V -r); do
    if [[ -f "$rp/lib/modules/$k/modules.dep" ]]; then kver="$k"; break; fi
  done
fi
[[ -n "$kver" && -r "$rp/boot/vmlinuz-$kver" && -f "$rp/lib/modules/$kver/modules.dep" ]] ||
  skip "no readable kernel with modules in $vmroot (boot/vmlinuz-<ver> + lib/modules/<ver>; Debian package linux-image-$arch)"

work="$(mktemp -d /tmp/ndsid-vm.XXXXXX)"
results="${NDSID_VM_RESULTS:-$work/results}"
mkdir -p "$results"
cleanup() {
  if [[ $keep -eq 0 ]]; then rm -rf "$work"; else echo "run_vm: kept $work" >&2; fi
}
trap cleanup EXIT

# --- initramfs ---------------------------------------------------------------------------
root="$work/initramfs"
mkdir -p "$root"/{bin,dev,proc,sys,mnt/host,mnt/rw,mnt/root,lib/modules}
cp "$busybox" "$root/bin/busybox"
for applet in sh mount umount insmod mkdir sleep cat echo reboot poweroff switch_root chroot ip ln mknod cp date sync sed rm; do
  ln -s busybox "$root/bin/$applet"
done
moddir="$rp/lib/modules/$kver"
# Modules in load order: each one's dependencies (modules.dep lists them, deepest last) first.
declare -A seen=()
order=()
add_module() {
  local name="$1" line path deps d
  line="$(grep -E "(^|/)${name}\.ko(\.[a-z]+)?:" "$moddir/modules.dep" | head -1 || true)"
  [[ -n "$line" ]] || return 0  # built into this kernel
  path="${line%%:*}"
  [[ -n "${seen[$path]:-}" ]] && return 0
  seen[$path]=1
  deps="${line#*:}"
  local rev=()
  for d in $deps; do rev=("$d" "${rev[@]}"); done
  for d in "${rev[@]}"; do
    if [[ -z "${seen[$d]:-}" ]]; then add_module "$(basename "${d%%.ko*}")"; fi
  done
  order+=("$path")
}
for m in virtio_pci 9pnet_virtio 9p overlay can can-raw can_raw vcan can-dev; do add_module "$m"; done
: >"$root/modules.order"
for p in "${order[@]}"; do
  f="$root/lib/modules/$(basename "$p")"
  case "$p" in
    *.ko) cp "$moddir/$p" "$f" ;;
    *.ko.xz) xz -dc "$moddir/$p" >"${f%.xz}"; f="${f%.xz}" ;;
    *.ko.zst) zstd -qdc "$moddir/$p" >"${f%.zst}"; f="${f%.zst}" ;;
    *.ko.gz) gzip -dc "$moddir/$p" >"${f%.gz}"; f="${f%.gz}" ;;
  esac
  basename "$f" >>"$root/modules.order"
done

cat >"$root/init" <<'INIT'
#!/bin/sh
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
ms() { read up _ </proc/uptime; echo "$up"; }
for m in $(cat /modules.order); do insmod /lib/modules/$m 2>/dev/null; done
mode=$(sed -n 's/.*ndsid.mode=\([a-z]*\).*/\1/p' /proc/cmdline)
if grep -q ndsid.rwroot /proc/cmdline; then
  # The root itself, writable (arm64_root.sh installs its packages into it).
  mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000 hostroot /mnt/root || { echo "vm-init: 9p root failed"; reboot -f; }
else
  mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=512000,cache=loose hostroot /mnt/host || { echo "vm-init: 9p root failed"; reboot -f; }
  mount -t tmpfs -o size=70% tmpfs /mnt/rw
  mkdir -p /mnt/rw/upper /mnt/rw/work
  mount -t overlay -o lowerdir=/mnt/host,upperdir=/mnt/rw/upper,workdir=/mnt/rw/work overlay /mnt/root || { echo "vm-init: overlay failed"; reboot -f; }
fi
mkdir -p /mnt/root/vmresults
mount -t 9p -o trans=virtio,version=9p2000.L,msize=512000 results /mnt/root/vmresults || { echo "vm-init: results share failed"; reboot -f; }
# The --share folders, read-only at their own paths (mounted last: a share under /tmp stays seen).
mount_shares() {
  while read -r tag dir; do
    mkdir -p "/mnt/root$dir"
    mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=512000,cache=loose "$tag" "/mnt/root$dir" || { echo "vm-init: share $dir failed"; reboot -f; }
  done </mnt/root/vmresults/.shares
}
echo "$(ms) $(date +%s)" >/mnt/root/vmresults/boot_shell_s
test_cmd=$(cat /mnt/root/vmresults/.cmd)
if [ "$mode" = systemd ]; then
  # The unit that runs the test once the system is up, then powers the VM off.
  u=/mnt/root/etc/systemd/system
  mkdir -p $u/multi-user.target.wants
  cat >$u/ndsid-vmtest.service <<UNIT
[Unit]
Description=ndsid VM test
After=multi-user.target
[Service]
Type=oneshot
Environment=NDSID_VM=systemd VM_RESULTS=/vmresults
ExecStart=/bin/sh /vmtest-run.sh
ExecStartPost=/bin/sync
ExecStartPost=/usr/bin/systemctl --no-block poweroff --force --force
StandardOutput=journal+console
TimeoutStartSec=infinity
[Install]
WantedBy=multi-user.target
UNIT
  cat >/mnt/root/vmtest-run.sh <<RUN
systemctl show -p ActiveEnterTimestampMonotonic --value multi-user.target >/vmresults/multi_user_us
. /vmresults/.env
$test_cmd >/vmresults/test.log 2>&1
echo \$? >/vmresults/rc
RUN
  ln -sf ../ndsid-vmtest.service $u/multi-user.target.wants/ndsid-vmtest.service
  # Only what a test needs: this machine's own extra services, timers and gettys stay off.
  for w in /mnt/root/etc/systemd/system/*.wants/*; do
    case "$w" in *ndsid-vmtest.service) ;; *) rm -f "$w" ;; esac
  done
  for m in postgresql.service postgresql@.service e2scrub_reap.service systemd-timesyncd.service \
           timers.target remote-fs.target getty.target serial-getty@.service getty@.service \
           systemd-pstore.service apt-daily.timer apt-daily-upgrade.timer man-db.timer \
           cron.service ssh.service systemd-networkd-wait-online.service; do
    ln -sf /dev/null $u/$m
  done
  mount_shares
  exec switch_root /mnt/root /sbin/init
fi
# Shell mode: the test in a chroot of the overlay.
mount -t proc proc /mnt/root/proc
mount -t sysfs sys /mnt/root/sys
mount -t devtmpfs dev /mnt/root/dev
mkdir -p /mnt/root/dev/pts /mnt/root/dev/shm
mount -t devpts devpts /mnt/root/dev/pts
mount -t tmpfs tmpfs /mnt/root/dev/shm
mount -t tmpfs tmpfs /mnt/root/tmp
mount -t tmpfs tmpfs /mnt/root/run
mount_shares
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
chroot /mnt/root /usr/bin/env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin HOME=/root \
  NDSID_VM=shell VM_RESULTS=/vmresults /bin/sh -c ". /vmresults/.env; $test_cmd" >/mnt/root/vmresults/test.log 2>&1
echo $? >/mnt/root/vmresults/rc
cat /mnt/root/vmresults/test.log
sync
reboot -f
INIT
chmod +x "$root/init"
(cd "$root" && find . | cpio --quiet -o -H newc | gzip -1) >"$work/initramfs.gz"

# The command the VM runs: the script and its arguments, shell-quoted.
printf '{ cd %q 2>/dev/null || cd /; } && %q ' "$PWD" "$vm_script" >"$results/.cmd"  # in the caller's folder
[[ $# -gt 0 ]] && printf '%q ' "$@" >>"$results/.cmd"
# The NDSID* variables of this environment (binaries, folders of the build) go in with it.
: >"$results/.env"
while IFS= read -r name; do
  printf 'export %s=%q\n' "$name" "${!name}" >>"$results/.env"
done < <(compgen -e | grep '^NDSID' || true)
rm -f "$results/rc" "$results/boot_shell_s" "$results/multi_user_us"
: >"$results/.shares"
share_args=()
for i in "${!shares[@]}"; do
  echo "share$i ${shares[$i]}" >>"$results/.shares"
  share_args+=(-virtfs "local,path=${shares[$i]},mount_tag=share$i,security_model=none,readonly=on,multidevs=remap")
done

mode=shell
[[ $systemd -eq 1 ]] && mode=systemd
append="console=$console panic=-1 no_timer_check quiet loglevel=3 rdinit=/init ndsid.mode=$mode"
[[ $rwroot -eq 1 ]] && append="$append ndsid.rwroot"
extra=()
[[ $icount -eq 1 ]] && extra+=(-icount shift=0,sleep=off)
[[ $systemd -eq 1 ]] && append="$append systemd.show_status=0"
echo "run_vm: $arch, kernel $kver, $smp CPUs, ${mem} MB, TCG$([[ $icount -eq 1 ]] && echo ", icount"), mode $mode, root $vmroot, timeout ${timeout_s} s: $vm_script $*" >&2
start=$(date +%s.%N)
set +e
root_ro=",readonly=on"
[[ $rwroot -eq 1 ]] && root_ro=""
timeout --kill-after=10 "$timeout_s" "$qemu" "${machine[@]}" -accel tcg -smp "$smp" -m "$mem" "${extra[@]}" \
  -nographic -no-reboot -kernel "$rp/boot/vmlinuz-$kver" -initrd "$work/initramfs.gz" -append "$append" \
  -virtfs "local,path=$vmroot,mount_tag=hostroot,security_model=none$root_ro,multidevs=remap" \
  -virtfs local,path="$results",mount_tag=results,security_model=none "${share_args[@]}" \
  -nic none </dev/null >"$work/console.log" 2>&1
qrc=$?
set -e
end=$(date +%s.%N)
wall=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
if [[ $keep -eq 1 || -n "${NDSID_VM_CONSOLE:-}" ]]; then cat "$work/console.log" >&2; fi
[[ -f "$results/test.log" ]] && cat "$results/test.log"
shell_s="?" shell_wall="?"
if [[ -f "$results/boot_shell_s" ]]; then
  read -r shell_s shell_epoch <"$results/boot_shell_s"
  shell_wall=$(awk -v a="$start" -v b="$shell_epoch" 'BEGIN { printf "%.0f", b - a }')
fi
mu=""
if [[ -f "$results/multi_user_us" ]]; then
  mu=", multi-user.target $(awk '{ printf "%.1f", $1 / 1e6 }' "$results/multi_user_us") s"
fi
echo "run_vm: boot to shell ${shell_s} s guest uptime, ~${shell_wall} s wall (1 s resolution, qemu start included)${mu}; VM wall time ${wall} s" >&2
if [[ $qrc -eq 124 || $qrc -eq 137 ]]; then
  echo "run_vm: TIMEOUT after ${timeout_s} s; console tail:" >&2
  tail -40 "$work/console.log" >&2
  exit 124
fi
if [[ ! -f "$results/rc" ]]; then
  echo "run_vm: the test did not finish (qemu exit $qrc); console tail:" >&2
  tail -40 "$work/console.log" >&2
  exit 1
fi
rc="$(cat "$results/rc")"
echo "run_vm: test exit $rc" >&2
exit "$rc"
