#!/usr/bin/env bash
# scripts/ndsid-lcm-spy on this system's Java (Debian 12: 17), with the built type jar.
# With xvfb-run (Debian package xvfb): lcm.spy.Spy must find all our LCM types, open its
# window on the virtual display and still be running after 12 s (killed then). Without it:
# headless, Spy must find the types and fail only at the window (HeadlessException); also
# with a headless JRE (no libawt_xawt.so: default-jre-headless), which cannot open windows.
# Then (display only) SpyProbe.java runs the spy in its JVM, publishes every ndsid type 20 times
# and reads the spy's table: each channel decoded as our type, nothing undecodable.
# Catches: Debian's lcm-spy options (-Xincgc: "Unrecognized option", the JVM never starts),
# a missing jchart2d (NoClassDefFoundError in the spy's classes), types not on the class path.
#   lcm_spy_test.sh SOURCE_DIR TYPES_JAR
set -uo pipefail
src="$1"
jar="$2"
[[ -n "$jar" && -f "$jar" ]] || { echo "SKIP: no ndsid_lcmtypes.jar (javac or liblcm-java missing at configure time)"; exit 77; }
for f in /usr/share/java/lcm.jar /usr/share/java/jchart2d.jar; do
  [[ -f "$f" ]] || { echo "SKIP: $f missing (apt-get install liblcm-java libjchart2d-java)"; exit 77; }
done
command -v java >/dev/null || { echo "SKIP: no java"; exit 77; }
ntypes=$(ls "$src"/lcmtypes/*.lcm | wc -l)
out="$(mktemp)"
trap 'rm -f "$out"' EXIT
export NDSID_LCMTYPES_JAR="$jar"
url='udpm://239.255.76.67:7699?ttl=0'   # not the daemon tests' port: the table must hold only ours
java_home="$(dirname "$(dirname "$(readlink -f "$(command -v java)")")")"
if command -v xvfb-run >/dev/null && [[ -f "$java_home/lib/libawt_xawt.so" ]]; then
  timeout -s TERM 12 xvfb-run -a "$src/scripts/ndsid-lcm-spy" --lcm-url="$url" >"$out" 2>&1
  rc=$?
  cat "$out"
  [[ $rc -eq 124 ]] || { echo "FAIL: ndsid-lcm-spy ended by itself (exit $rc) instead of running"; exit 1; }
  mode="under xvfb-run: window open, still running after 12 s"
else
  timeout -s TERM 60 env -u DISPLAY "$src/scripts/ndsid-lcm-spy" --lcm-url="$url" >"$out" 2>&1
  cat "$out"
  grep -q "java.awt.HeadlessException" "$out" || { echo "FAIL: expected to stop only for lack of a display"; exit 1; }
  mode="headless (no xvfb-run or a headless JRE): stopped only for lack of a display"
fi
grep -q "Found $ntypes LCM types" "$out" || { echo "FAIL: the spy did not find our $ntypes LCM types"; exit 1; }
if grep -Eq "Unrecognized option|NoClassDefFoundError|ClassNotFoundException|Could not create the Java" "$out"; then
  echo "FAIL: JVM or class path error"; exit 1
fi
echo "ok: ndsid-lcm-spy on $(java -version 2>&1 | head -1): $ntypes LCM types found, $mode"

# The spy's channel table with live messages of every type (SpyProbe.java, same class path).
if [[ "$mode" == under* ]]; then
  timeout -s TERM 90 xvfb-run -a java -cp "$jar:/usr/share/java/lcm.jar:/usr/share/java/jchart2d.jar" \
    "$(dirname "$0")/SpyProbe.java" "$url" 2>&1
  rc=$?
  if [[ $rc -eq 2 ]]; then echo "SKIP: the launcher works; the decode check received nothing (multicast)"; exit 77; fi
  [[ $rc -eq 0 ]] || { echo "FAIL: lcm-spy did not decode our messages (exit $rc)"; exit 1; }
fi
echo "PASS"
