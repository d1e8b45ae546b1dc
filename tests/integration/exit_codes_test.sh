#!/usr/bin/env bash
# Exit codes of the binaries on faults (docs/reliability.md), each case one ctest:
#   exit_codes_test.sh <case> <ndsid> <ndsidd> <source dir>
#   TruncatedGzipDecode   ndsid decode of a cut-short gzip log: 74 and a message naming it
#   TruncatedGzipDaemon   ndsidd over a cut-short gzip log: 74 (the run is incomplete)
#   FinalSaveFails        ndsidd whose state_dir cannot be created: 74 and a message
#   CompleteLogExitsZero  ndsidd over a complete (short) log with a writable state_dir: 0
#   ComplexYamlKey        a YAML complex key: 78 from --check-config, not 1
set -uo pipefail
case_name="$1" ndsid="$2" ndsidd="$3" src="$4"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# ~3 MB of the bundled drive, compressed; cut at half for the truncated copy.
zcat "$src/replay/clean/drive.log.gz" | head -n 60000 | gzip -1 > "$tmp/full.log.gz"
head -c $(( $(stat -c %s "$tmp/full.log.gz") / 2 )) "$tmp/full.log.gz" > "$tmp/cut.log.gz"

config() {  # log state_dir -> $tmp/vehicle.yaml
  sed -e "s#- ../replay/clean/drive.log.gz#- $1#" -e "s#^state_dir:.*#state_dir: $2#" \
      -e "s#^dbc: ../dbc#dbc: $src/dbc#" -e 's#udpm://239.255.76.67:7667?ttl=0#udpm://239.255.76.67:7690?ttl=0#' \
      "$src/config/example_vehicle.yaml" > "$tmp/vehicle.yaml"
}

case "$case_name" in
  TruncatedGzipDecode)
    "$ndsid" decode --dbc "$src/dbc/ndsid_example.dbc" --log "$tmp/cut.log.gz" > "$tmp/out.csv" 2> "$tmp/err"
    rc=$?
    cat "$tmp/err" | tail -3
    [[ $rc == 74 ]] || fail "exit $rc, want 74"
    grep -q "not read to its end" "$tmp/err" || fail "no message"
    [[ $(wc -l < "$tmp/out.csv") -gt 1000 ]] || fail "the frames before the cut were not decoded"
    ;;
  TruncatedGzipDaemon)
    config "$tmp/cut.log.gz" "$tmp/state"
    "$ndsidd" --config "$tmp/vehicle.yaml" > /dev/null 2> "$tmp/err"
    rc=$?
    grep -E "stopped early|exit 74" "$tmp/err"
    [[ $rc == 74 ]] || fail "exit $rc, want 74"
    [[ -f "$tmp/state/example-cmax.ndsid-state" ]] || fail "what was read must still be saved"
    ;;
  FinalSaveFails)
    config "$tmp/full.log.gz" "/proc/ndsid-no-such-dir/state"
    "$ndsidd" --config "$tmp/vehicle.yaml" > /dev/null 2> "$tmp/err"
    rc=$?
    grep -E "cannot write learned state|exit 74" "$tmp/err"
    [[ $rc == 74 ]] || fail "exit $rc, want 74"
    ;;
  CompleteLogExitsZero)
    config "$tmp/full.log.gz" "$tmp/state"
    "$ndsidd" --config "$tmp/vehicle.yaml" > /dev/null 2> "$tmp/err"
    rc=$?
    [[ $rc == 0 ]] || { tail -5 "$tmp/err"; fail "exit $rc, want 0"; }
    ;;
  ComplexYamlKey)
    config "$tmp/full.log.gz" "$tmp/state"
    printf '? [a, b]\n: 1\n' >> "$tmp/vehicle.yaml"
    "$ndsidd" --config "$tmp/vehicle.yaml" --check-config > /dev/null 2> "$tmp/err"
    rc=$?
    cat "$tmp/err"
    [[ $rc == 78 ]] || fail "exit $rc, want 78"
    grep -q "vehicle.yaml:[0-9]" "$tmp/err" || fail "the error does not name file:line"
    ;;
  *) fail "unknown case $case_name" ;;
esac
echo "PASS $case_name"
