#!/usr/bin/env bash
# Rebuilds the bundled drives in replay/ bit-identically with `ndsid simulate`.
#   replay/regenerate.sh            regenerate replay/clean and replay/steer_offset in place
#   replay/regenerate.sh --check    regenerate into a temporary directory and compare the bytes
# The ndsid binary: $NDSID_BIN, else build/bin/ndsid. Paths in the commands are relative to
# the repository root, so the recorded command lines (truth.yaml) are the same wherever it runs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="${NDSID_BIN:-$root/build/bin/ndsid}"
[[ -x "$bin" ]] || { echo "regenerate.sh: no ndsid binary at $bin (build first or set NDSID_BIN)" >&2; exit 2; }

generate() {  # $1: directory standing in for the repository root (has config/, dbc/, replay/)
  (
    cd "$1"
    "$bin" --log-level warn simulate --config config/sim_cmax.yaml --dbc dbc/ndsid_example.dbc \
      --seed 3 --drives 4 --gzip --out replay/clean
    "$bin" --log-level warn simulate --config config/sim_cmax.yaml --dbc dbc/ndsid_example.dbc \
      --seed 15 --drives 3 --effect steer_offset_deg=1.5 --gzip --out replay/steer_offset
  )
}

if [[ "${1:-}" == "--check" ]]; then
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  ln -s "$root/config" "$tmp/config"
  ln -s "$root/dbc" "$tmp/dbc"
  mkdir -p "$tmp/replay"
  generate "$tmp" > /dev/null
  status=0
  for f in clean/drive.log.gz clean/truth.yaml steer_offset/drive.log.gz steer_offset/truth.yaml; do
    if cmp -s "$root/replay/$f" "$tmp/replay/$f"; then
      echo "identical: replay/$f ($(stat -c %s "$root/replay/$f") bytes)"
    else
      echo "DIFFERS:   replay/$f" >&2
      status=1
    fi
  done
  exit $status
fi
generate "$root"
du -ch "$root"/replay/*/drive.log.gz | tail -1
