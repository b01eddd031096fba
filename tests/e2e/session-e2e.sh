#!/bin/bash
# circtest on a running LinuxCNC, as a user runs it: configs/sim-servo (with demo.sh's errors:
# scale X 50 ppm, cyclic Y 2 um) started with `linuxcnc` and a display that does nothing
# (configs/idle-display), then
#   circtest install --yes            circlog wired into the configuration (table channels named)
#   restart LinuxCNC
#   circtest run (not homed)          refused, exit 7, nothing run
#   circtest run (feed override 80 %) refused, exit 7
#   circtest run --d 700              beyond the soft limits: circgen refuses, exit 6
#   circtest run, aborted / E-stop    incomplete, exit 5: the trace kept, nothing applied
#   circtest run, E-stop at its start named (before the first run), exit 5
#   circtest run --start --yes --limits  measured, diagnosed, corrections applied, verdict
#   restart LinuxCNC
#   circtest verify, work offset moved   refused, exit 7, the session's offset said
#   circtest verify                   the same program again (the operator's cycle start):
#                                     before/after, verdict by the session's limits (exit 0
#                                     within them, else 9), stored in the history as the
#                                     session's verify
#   LinuxCNC quitting mid-run         incomplete, exit 7
# Checked against the injected errors (the diagnosis's backlash, squareness, scale of X) and
# the corrections' effect (G after well below G before).
# With SESSION_E2E_CONFIG=sim-stepper the stepper machine instead (configs/sim-stepper): install
# says that its feedback is the step count; not homed, then run (a D60 circle); no faults, no
# verify.
#   session-e2e.sh BUILD_DIR [WORK_DIR]
# Runs as root inside scripts/hal-sandbox (the build's modules beside the system's).
set -euo pipefail
build=$(readlink -f "$1")
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/../.." && pwd)
# shellcheck source=linuxcnc-e2e.sh
. "$here/linuxcnc-e2e.sh"

[ "${E2E_INSIDE:-}" = 1 ] || e2e_sandbox "$0" "$@"
e2e_machine "${SESSION_E2E_CONFIG:-sim-servo}"

# The diagnosis DIAGNOSIS.json against the errors the INI's [SIM] injects: backlash X,
# squareness XY, scale X.
check_diagnosis() {
  /usr/bin/python3 - "$1" "$ini" <<'PY'
import json, sys
def ini_value(sec, key):
    cur = None
    for line in open(sys.argv[2]):
        line = line.strip()
        if line.startswith("["): cur = line.strip("[]")
        elif cur == sec and "=" in line and line.split("=")[0].strip() == key:
            return float(line.split("=", 1)[1])
d = json.load(open(sys.argv[1]))
bx, sq, sx = d["backlash_mm"]["X"], d["squareness_urad"], d["scale_ppm"]["X"]
print("diagnosis: backlash X %.1f um, squareness %.1f urad, scale X %.1f ppm" % (bx * 1e3, sq, sx))
errors = []
if abs(bx - ini_value("SIM", "BACKLASH_X")) * 1e3 > 1.0: errors.append("backlash X")
if abs(sq - ini_value("SIM", "SQUARENESS_XY") * 1e6) > 5.0: errors.append("squareness")
if abs(sx - ini_value("SIM", "SCALE_X") * 1e6) > 5.0: errors.append("scale X")
if errors:
    sys.exit("FAIL: the diagnosis misses " + ", ".join(errors))
PY
}

# circtest ARGS... must exit CODE saying TEXT (on stdout or stderr).
expect_refusal() {
  local code=$1 text=$2 rc=0
  shift 2
  "$circtest" "$@" >"$work/refusal.out" 2>&1 || rc=$?
  cat "$work/refusal.out"
  [ $rc = "$code" ] || fail "circtest $*: exit $rc, expected $code"
  grep -qF "$text" "$work/refusal.out" || fail "circtest $*: does not say '$text'"
}

t0=$SECONDS
"$circtest" install --ini "$ini" --yes --instrument x=simx-tab.out --instrument y=simy-tab.out \
  --instrument z=simz-tab.out >"$work/install.out" || fail "install (exit $?)"
start_linuxcnc
operator on
expect_refusal 7 "not homed" run --ini "$ini" --start --yes
[ ! -d "$machine/circtest-sessions" ] || fail "a refused run left a session folder"
operator home
if [ "$config" = sim-stepper ]; then
  grep -q "a stepper: its feedback (stepgen.0.position-fb) is the step count" "$work/install.out" ||
    fail "install does not say that the stepper's feedback is the step count"
  # A simulated machine: late servo periods (this PC under load) are said, not refused.
  "$ini_tool" set "$ini" CIRCTEST LATE_SERVO_PERIODS note
  "$circtest" run --ini "$ini" --start --yes --d 60 --f 1000 >"$work/run.out" ||
    { rc=$?; cat "$work/run.out"; fail "circtest run (exit $rc)"; }
  stop_linuxcnc
  session=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
  check_diagnosis "$session/diagnosis.json"
  grep -q "^Stored as test 1 of machine" "$session/history.txt" || fail "not stored in the history"
  echo "session e2e ($config): $((SECONDS - t0)) s"
  exit 0
fi
# Feed override not at 100 %: refused before any motion.
operator override=0.8
expect_refusal 7 "feed override at 80 %" run --ini "$ini" --start --yes
operator override=1.0
# A program beyond the soft limits (X +-300 mm) from the work offset in use: circgen refuses it.
expect_refusal 6 "MIN_LIMIT" run --ini "$ini" --start --yes --d 700
[ ! -d "$machine/circtest-sessions" ] || [ -z "$(ls "$machine/circtest-sessions")" ] ||
  fail "a refused program left a session folder"
# The operator's faults come inside a run, whatever the load: once the marker output is on.
CIRCTEST_MARKER=$(sed -n 's/^MARKER_OUTPUT *= *//p' "$ini")
export CIRCTEST_MARKER
# An abort and an E-stop mid-run (a short program): incomplete, nothing analysed or applied;
# an E-stop as the program starts, before its first run's marker: named as such, exit 5 too.
for fault in abort estop estop-at-start; do
  operator "$fault" &
  op=$!
  said="the test is incomplete"
  [ "$fault" != estop-at-start ] ||
    said="the test is incomplete (E-stop in program.ngc, before its first run was recorded)"
  expect_refusal 5 "$said" run --ini "$ini" --start --yes --d 20 --f 2000
  wait $op || fail "the $fault did not happen"
  s=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
  [ "$fault" = estop-at-start ] || [ -s "$s/trace.csv" ] || fail "$fault: the trace is not kept"
  [ ! -e "$s/diagnosis.json" ] && [ ! -e "$s/apply.txt" ] || fail "$fault: analysed or applied"
  rm -rf "$s"
  operator home
done
# The servo thread made late mid-run (busy loops above LinuxCNC's priority): said in one line,
# servo-period.json counts the late periods, nothing analysed or applied, exit 5.
operator latency &
op=$!
expect_refusal 5 "the servo thread missed its period" run --ini "$ini" --start --yes --d 20 --f 2000
wait $op || fail "the servo thread was not made late"
s=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
/usr/bin/python3 - "$s/servo-period.json" <<'PY' || fail "servo-period.json"
import json, sys
j = json.load(open(sys.argv[1]))
print("late servo periods: %d, longest %.0f us of %.0f us" % (j["late_periods"],
      j["longest_period_us"], j["nominal_period_us"]))
# The loops spin 30 ms; on the development VM they held the servo thread 4.3 to 15.8 ms in
# four tries, and its load alone makes late periods too: late ones counted is what is asked.
if not (j["late_periods"] >= 1 and j["longest_period_us"] > 1500 and not j["run_usable"]):
    sys.exit("FAIL: the late periods are not counted")
PY
[ ! -e "$s/diagnosis.json" ] && [ ! -e "$s/apply.txt" ] || fail "late periods: analysed or applied"
rm -rf "$s"
# sim-servo is a simulated machine (its motion is computed per servo period): from here on
# late periods (this PC under load; with the build beside it the servo thread stalled 100 ms)
# are said and the session goes on.
"$ini_tool" set "$ini" CIRCTEST LATE_SERVO_PERIODS note
limits=H=0.015,G=0.020
"$circtest" run --ini "$ini" --start --yes --d 100 --f 1000 --limits $limits >"$work/run.out" ||
  { rc=$?; cat "$work/run.out"; fail "circtest run (exit $rc)"; }
cat "$work/run.out"
# The progress without a terminal: plain lines per run and quarter; the servo thread's line.
for text in "XY run 1 of 2 (CCW F1000): recording" "XY run 2 of 2 (CW F1000): 75 % of the path" \
  "XY run 2 of 2 (CW F1000): recorded (" "circtest: the servo thread "; do
  grep -qF "$text" "$work/run.out" || fail "circtest run does not say '$text'"
done
session=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
grep -q "^Stored as test 1 of machine" "$session/history.txt" || fail "not stored in the history"
for f in program.ngc trace.csv results.json diagnosis.json plan.diff apply.txt report.html \
  limits.txt; do
  [ -s "$session/$f" ] || fail "the session folder has no $f"
done
# The verdict against the limits, said as the report states it (its banner); with an exit
# status (verify's): 0 within the limits, else 9.
check_verdict() {
  local said expected=9
  said=$(grep -o "^circtest: verdict against $limits (ISO 14253-1, U k = 2): [A-Za-z ]*" "$1" |
    sed 's/.*: //') || fail "$1: no verdict against $limits"
  echo "verdict: $said"
  case "$said" in
  "within the limits") grep -q 'data-verdict="PASS"' "$session/report.html" ;;
  "OUT OF TOLERANCE") grep -q 'data-verdict="FAIL"' "$session/report.html" ;;
  "NOT DECIDED") grep -q 'data-verdict="OPEN"' "$session/report.html" ;;
  *) false ;;
  esac || fail "the report's verdict is not the one said ($said)"
  [ "$said" != "within the limits" ] || expected=0
  [ $# -lt 2 ] || [ "$2" = $expected ] || fail "$1: exit $2 for the verdict $said"
}
check_verdict "$work/run.out"
stop_linuxcnc
start_linuxcnc
operator home
# The work offset is not the session's (LinuxCNC did not save a touch-off at its shutdown, or
# it was changed): refused before any motion, with the session's offset and what to do.
read -r x0 _ <"$session/work-origin.txt"
operator "mdi=G10 L2 P1 X$(/usr/bin/python3 -c "print('%.6f' % ($x0 + 5))")"
expect_refusal 7 "LinuxCNC may not have saved its work offsets at the last shutdown" \
  verify --ini "$ini"
grep -qF "work-origin.txt): X " "$work/refusal.out" || fail "the session's offset is not said"
operator "mdi=G10 L2 P1 X$(/usr/bin/python3 -c "print('%.6f' % $x0)")"
# verify as an operator runs it: circtest opens the program, the operator presses cycle start.
operator cycle-start &
op=$!
verify_rc=0
"$circtest" verify --ini "$ini" >"$work/verify.out" || verify_rc=$?
cat "$work/verify.out"
[ $verify_rc = 0 ] || [ $verify_rc = 9 ] || fail "circtest verify (exit $verify_rc)"
wait $op || fail "the operator's cycle start"
grep -q "press cycle start on the machine" "$work/verify.out" || fail "verify did not ask for cycle start"
# verify judged by the session's limits (not given again), its test stored in the history
# beside the run's, marked as the verify of that session.
check_verdict "$work/verify.out" $verify_rc
grep -q "^Stored as test 2 of machine" "$session/verify-history.txt" ||
  fail "verify's test not stored in the history"
title=$(sed -n 's/^MACHINE *= *//p' "$ini" | head -n 1)
"$build/analysis/circana" history --machine "$title" --json >"$work/history.json" ||
  fail "circana history (exit $?)"
/usr/bin/python3 - "$work/history.json" "$(basename "$session")" <<'PY' || fail "the history"
import json, sys
tests = json.load(open(sys.argv[1]))["tests"]
steps = [(t["conditions"].get("circtest_step"), t["conditions"].get("circtest_session"))
         for t in tests]
print("history: %s" % steps)
if steps != [("run", sys.argv[2]), ("verify", sys.argv[2])]:
    sys.exit("FAIL: expected the session's run and verify tests")
PY
# LinuxCNC quitting mid-run: said, the trace kept, exit 7 (F600: each run 6 s, so that LinuxCNC,
# slow to shut down beside a build, stops inside the program).
operator quit &
expect_refusal 7 "the test is incomplete" run --ini "$ini" --start --yes --d 20 --f 600
wait $lcnc_pid || true
echo "session e2e: $((SECONDS - t0)) s"

check_diagnosis "$session/diagnosis.json"
/usr/bin/python3 - "$session" <<'PY'
import json, sys
session = sys.argv[1]
before = json.load(open(session + "/results.json"))
after = json.load(open(session + "/verify-results.json"))
g = lambda r: max(run["G"] for run in r["runs"])
print("H %.1f -> %.1f um, G %.1f -> %.1f um" % (before["H"] * 1e3, after["H"] * 1e3,
      g(before) * 1e3, g(after) * 1e3))
if not g(after) < 0.5 * g(before):
    sys.exit("FAIL: G did not halve after the corrections")
print("PASS")
PY
