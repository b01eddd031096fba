# circcomp apply on the servo and stepper fixtures, then the configuration's HAL files loaded
# by a real halcmd with the INI (as LinuxCNC loads them, circtest-fric.hal last): circfric
# loads, runs right after motion-controller, sits between the position command and the pid
# or stepgen, and takes the INI's values. Run by run-hal-test.sh with the build's circfric.so.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
for fixture in servo-mill stepper-mill; do
  rm -rf "$fixture"
  cp -r "$FRIC_FIXTURES/$fixture" "$fixture"
  sha=$(sha256sum "$fixture/$fixture.ini" | cut -d' ' -f1)
  cat >d.json <<JSON
{"schema": "circtest.diagnosis/1", "plane": "XY", "axes": ["X", "Y"],
 "reversal_spike_mm": {"X": 0.0047, "Y": 0.0031}, "reversal_spike_ms": {"X": 18.5, "Y": 22.0},
 "standard_error": {"reversal_spike_mm": {"X": 0.0001, "Y": 0.0001}},
 "ini_sha256": "$sha"}
JSON
  "$CIRCCOMP" apply --ini "$fixture/$fixture.ini" d.json >&2
  echo "$fixture: HALFILEs $(grep '^HALFILE' "$fixture/$fixture.ini" | sed 's/.*= //' | tr '\n' ' ')"
  (
    cd "$fixture"
    halrun -U >/dev/null 2>&1 || true
    "$REALTIME" start >&2
    # What the linuxcnc script loads before the HAL files (motmod needs them).
    halcmd loadrt tpmod >&2
    halcmd loadrt homemod >&2
    for f in $(grep '^HALFILE' "$fixture.ini" | sed 's/.*= //'); do
      halcmd -i "$fixture.ini" -f "$f" >&2
    done
    echo "  servo-thread: $(halcmd show thread servo-thread | awk 'NF == 2 && $1 ~ /^[0-9]+$/ { print $2 }' | tr '\n' ' ')"
    for pin in pid.x.command pid.y.command stepgen.0.position-cmd stepgen.1.position-cmd \
               fric-x.pos-in fric-x.vel-cmd fric-x.enable fric-y.pos-in; do
      # The signal a pin is on (a pin of the other fixture's kind does not exist: no line).
      signal=$(halcmd show pin "$pin" | awk 'NR > 2 && NF >= 6 { print $NF }' | head -1)
      [ -z "$signal" ] || echo "  $pin: $signal"
    done
    for p in amplitude amplitude-max decay-ms; do
      echo "  fric-x.$p = $(halcmd getp fric-x.$p), fric-y.$p = $(halcmd getp fric-y.$p)"
    done
    halcmd start
    sleep 0.2
    halcmd stop
    echo "  rejected after 0.2 s running: x $(halcmd getp fric-x.rejected), y $(halcmd getp fric-y.rejected)"
    hal_stop
  )
  "$CIRCCOMP" revert --ini "$fixture/$fixture.ini" >&2
  echo "  reverted byte-identical: $(diff -r -x .circcomp "$FRIC_FIXTURES/$fixture" "$fixture" >&2 && echo yes || echo NO)"
done
