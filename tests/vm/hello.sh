#!/bin/sh
# Smoke test of the VM test bed itself: tests/vm/run_vm.sh [--systemd] tests/vm/hello.sh
# (kernel, vcan, the writable overlay, the results share; under --systemd the unit state).
set -e
echo "kernel $(uname -r), NDSID_VM=$NDSID_VM"
ip link add dev vcan0 type vcan
ip link set up vcan0
ip -br link show vcan0
touch /usr/ndsid-vm-overlay-probe
echo ok >"$VM_RESULTS/hello.txt"
if [ "$NDSID_VM" = systemd ]; then systemctl --failed --no-legend || true; fi
