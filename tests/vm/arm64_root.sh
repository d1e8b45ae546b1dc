#!/usr/bin/env bash
# Makes the root file system of the arm64 VM test bed (docs/daemon.md, "The arm64 VM test bed"):
# a small Debian 12 arm64 system with systemd, Debian's arm64 kernel, can-utils, lcm-logger and
# the runtime packages the arm64 ndsid package depends on, so that `dpkg -i` of that package
# resolves inside the VM as on a logger.
#
#   tests/vm/arm64_root.sh [--deb PACKAGE.deb]   make it unless it is there and up to date;
#                                                prints its path
#   tests/vm/arm64_root.sh --print               print its path only
#   NDSID_VM_ROOT_ARM64=dir                      where it goes (default ~/.cache/ndsid/vm-root-arm64)
#
# Two stages, as debootstrap --foreign does, because this host cannot run arm64 programs in a
# chroot (binfmt_misc is not mounted, so the maintainer scripts could not run):
#   1. on the host: mmdebstrap --variant=extract unpacks the packages and keeps their .debs;
#   2. in the arm64 VM (tests/vm/run_vm.sh --arch arm64 --rw-root), under the busybox init:
#      dpkg installs those .debs for real (base-passwd and base-files first, then unpack all,
#      then configure all), so every maintainer script runs natively on the emulated CPU.
# The first run downloads about 150 MB from the host's Debian mirror and takes 20-40 minutes on
# 2 cores (stage 2 is emulated); later runs reuse the root. The stamp covers this script, the
# package list and the package's Depends: a change remakes the root.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="${NDSID_VM_ROOT_ARM64:-${XDG_CACHE_HOME:-$HOME/.cache}/ndsid/vm-root-arm64}"
log() { printf '[arm64-root] %s\n' "$*" >&2; }
deb="" stamp_only=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --print) echo "$root"; exit 0 ;;
    --deb) deb="$2"; shift 2 ;;
    --stamp) stamp_only=1; shift ;;  # the stamp an up-to-date root carries (for a root made by hand)
    *) log "unknown argument $1"; exit 2 ;;
  esac
done

# What the VM runs: Debian's essential set, systemd as PID 1 with networkd and udev, the kernel
# and its modules (vcan, can-raw), the static busybox for the initramfs, the tools the tests
# call (canplayer, lcm-logger, ps, ip, time), and the run-time libraries of ndsid and ndsidd.
VM_PACKAGES=(
  base-files base-passwd bash bsdutils coreutils dash debconf debianutils diffutils dpkg
  findutils grep gzip hostname init-system-helpers libc-bin login mawk ncurses-base
  ncurses-bin perl-base sed sysvinit-utils tar util-linux
  systemd systemd-sysv udev dbus kmod iproute2 procps time
  linux-image-arm64 busybox-static can-utils liblcm-bin
  libatlas3-base libcholmod3 libcxsparse3 libfmt9 libgoogle-glog0v6 liblcm1 libspdlog1.10
  libstdc++6 libsystemd0 libyaml-cpp0.7
)
# The package's Depends clauses ("a (>= 1) | b"): a root in which one of them is satisfied by no
# installed package (nor by what one Provides) is made again with the clause's first package.
deb_clauses=()
if [[ -n "$deb" ]]; then
  [[ -r "$deb" ]] || { log "cannot read $deb"; exit 1; }
  while IFS= read -r d; do
    [[ -n "$d" ]] && deb_clauses+=("$d")
  done < <(dpkg-deb -f "$deb" Depends | tr ',' '\n' | sed 's/([^)]*)//g; s/:any//g; s/ //g')
fi
# unsatisfied STATUS_FILE: the first package of each clause that nothing in the root satisfies.
unsatisfied() {
  local names clause alt ok
  names="$(sed -n 's/^Package: //p; s/^Provides: //p' "$1" 2>/dev/null | tr ',' '\n' | sed 's/([^)]*)//g; s/ //g')"
  for clause in "${deb_clauses[@]}"; do
    ok=0
    for alt in ${clause//|/ }; do grep -qx "$alt" <<<"$names" && ok=1; done
    [[ $ok -eq 1 ]] || echo "${clause%%|*}"
  done
}
suite=bookworm
mirror="http://deb.debian.org/debian"
security="http://deb.debian.org/debian-security"

want="$(printf '%s\n' "$suite" "$mirror" "${VM_PACKAGES[@]}" | cat - "${BASH_SOURCE[0]}" | sha256sum | cut -d' ' -f1)"
stamp="$root/.ndsid-vm-root.sha256"
if [[ "$stamp_only" -eq 1 ]]; then echo "$want"; exit 0; fi
if [[ -f "$stamp" && "$(cat "$stamp")" == "$want" ]]; then
  mapfile -t lacking < <(unsatisfied "$root/var/lib/dpkg/status")
  if [[ ${#lacking[@]} -eq 0 ]]; then
    log "up to date: $root"
    echo "$root"
    exit 0
  fi
  log "the root lacks the package's dependencies ${lacking[*]}: making it again"
  VM_PACKAGES+=("${lacking[@]}")
fi

command -v mmdebstrap >/dev/null || { log "mmdebstrap missing: scripts/setup.sh --arch arm64 installs it"; exit 1; }
tmp="$root.tmp"
rm -rf "$tmp"
mkdir -p "$(dirname "$root")"
log "stage 1: mmdebstrap --variant=extract, arm64, $suite, ${#VM_PACKAGES[@]} packages and their dependencies"
include="$(IFS=,; echo "${VM_PACKAGES[*]}")"
mmdebstrap --variant=extract --architectures=arm64 --include="$include" \
  --aptopt='Acquire::Retries "3"' --skip=cleanup/apt/cache \
  "$suite" "$tmp" \
  "deb $mirror $suite main" "deb $mirror $suite-updates main" "deb $security $suite-security main" >&2
ndebs=$(ls "$tmp"/var/cache/apt/archives/*.deb | wc -l)
log "stage 1: $ndebs packages unpacked ($(du -sh "$tmp" | cut -f1))"

# An empty dpkg database for stage 2, and the script it runs (in a chroot of the root).
mkdir -p "$tmp"/var/lib/dpkg/{info,updates,triggers,alternatives} "$tmp"/tmp "$tmp"/proc "$tmp"/sys "$tmp"/dev "$tmp"/run
: >"$tmp/var/lib/dpkg/status"
: >"$tmp/var/lib/dpkg/available"
echo arm64 >"$tmp/var/lib/dpkg/arch"
cat >"$tmp/ndsid-second-stage.sh" <<'STAGE2'
#!/bin/sh
# Runs in the arm64 VM, chrooted into the root: installs the unpacked packages for real.
set -e
# INITRD=No: the kernel's postinst makes no initramfs (the bed boots with its own; emulated,
# making one takes half an hour).
export PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive \
  DEBCONF_NONINTERACTIVE_SEEN=true LC_ALL=C LANG=C INITRD=No
cd /var/cache/apt/archives
opts="--force-depends --force-confold --force-unsafe-io"
# After a timeout the root stays in <root>.tmp with this script: run again by hand
# (run_vm.sh --arch arm64 --root DIR.tmp --rw-root DIR.tmp/ndsid-second-stage.sh), it only
# configures; this script itself starts over.
if [ ! -e /var/lib/dpkg/ndsid-unpacked ]; then
  dpkg $opts --install base-passwd_*.deb
  dpkg $opts --install base-files_*.deb
  dpkg $opts --unpack ./*.deb
  touch /var/lib/dpkg/ndsid-unpacked
fi
dpkg $opts --force-configure-any --configure -a
dpkg --audit
rm -f ./*.deb /var/lib/dpkg/ndsid-unpacked
echo ndsid-arm64 >/etc/hostname
: >/etc/machine-id
echo "stage 2: $(dpkg-query -W | wc -l) packages installed"
STAGE2
chmod +x "$tmp/ndsid-second-stage.sh"
# No later update of an initramfs either (the postinst's triggers).
conf="$tmp/etc/initramfs-tools/update-initramfs.conf"
if [[ -f "$conf" ]]; then sed -i 's/^update_initramfs=.*/update_initramfs=no/' "$conf"; fi
# modules.dep for the initramfs of stage 2 (the kernel's postinst makes it again in the VM).
for m in "$tmp"/lib/modules/*; do depmod -b "$tmp" "$(basename "$m")"; done

log "stage 2: dpkg in the arm64 VM (emulated; about 30 min on 2 cores)"
NDSID_VM_RESULTS="$(mktemp -d /tmp/ndsid-root-stage2.XXXXXX)" \
  "$here/run_vm.sh" --arch arm64 --root "$tmp" --rw-root --timeout "${NDSID_VM_ROOT_TIMEOUT:-5400}" \
  "$tmp/ndsid-second-stage.sh" >&2 || { log "stage 2 failed (the root stays in $tmp)"; exit 1; }
rm -f "$tmp/ndsid-second-stage.sh"
rm -rf "$root"
mv "$tmp" "$root"
echo "$want" >"$stamp"
log "done: $(du -sh "$root" | cut -f1) in $root"
echo "$root"
