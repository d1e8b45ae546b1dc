#!/bin/sh
# Smoke test of the VM test bed: kernel, vcan, the overlay, the results share.
set -e
echo "kernel $(uname -r), NDSID_VM=$NDSID_VM"
ip link add dev vcan0 type vcan
ip link set up vcan0
ip -br link show vcan0
touch /usr/ndsid-vm-overlay-probe
echo ok >"$VM_RESULTS/hello.txt"
if [ "$NDSID_VM" = systemd ]; then systemctl is-system-running || true; systemd-analyze time || true; systemctl --failed --no-legend || true; fi
