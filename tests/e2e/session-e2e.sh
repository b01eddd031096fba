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
#   circtest run --start --yes        measured, diagnosed, corrections applied
#   restart LinuxCNC
#   circtest verify                   the same program again (the operator's cycle start):
#                                     before/after
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

if [ "${SESSION_E2E_INSIDE:-}" != 1 ]; then
  [ "$(id -u)" = 0 ] || { echo "SKIP: needs root (hal-sandbox)"; exit 77; }
  work=${2:-$(mktemp -d /tmp/circtest-session-e2e.XXXXXX)}
  mkdir -p "$work"
  chmod 755 "$work"
  hc=$build/hal-component
  rc=0
  SESSION_E2E_INSIDE=1 SESSION_WORK=$work "$top/scripts/hal-sandbox" --work "$work" --net \
    --module "$hc/circlog.so" --module "$hc/circdrive.so" --module "$hc/circtest_kins.so" \
    --module "$hc/circfric.so" -- "$0" "$@" || rc=$?
  [ "$rc" != 0 ] || [ -n "${2:-}" ] || rm -rf "$work"
  [ "$rc" = 0 ] || echo "(work files kept in $work)" >&2
  exit "$rc"
fi

work=$SESSION_WORK
# LinuxCNC's realtime threads SCHED_FIFO, as configs/circtest-run makes them (scripts/rt-boost
# says why: at normal priority, builds and tests beside this one stall its servo thread).
"$top/scripts/rt-boost" &
boost_pid=$!
trap 'kill "$boost_pid" 2>/dev/null || true' EXIT
export HOME=$work/home CIRCTEST_BIN=$build
mkdir -p "$HOME"
# circcomp apply checks that the modules a plan loads are where this LinuxCNC loads them.
export CIRCTEST_KINS_MODULE=$build/hal-component/circtest_kins.so
export CIRCTEST_FRIC_MODULE=$build/hal-component/circfric.so
circtest=$build/session/circtest ini_tool=$build/core/circtest-ini
config=${SESSION_E2E_CONFIG:-sim-servo}
machine=$work/machine ini=$work/machine/$config.ini
rm -rf "$machine"
cp -rL "$top/configs/$config" "$machine"
sed -i -e '/^HALFILE *= *circlog.hal/d' -e '/^\[CIRCTEST\]/,/^\[/{/^COLUMNS/d}' "$ini"
rm -f "$machine/circlog.hal" "$machine/ui.py"
"$ini_tool" set "$ini" SIM SCALE_X 50e-6
"$ini_tool" set "$ini" SIM CYCLIC_Y 0.002
"$ini_tool" set "$ini" DISPLAY DISPLAY "$top/configs/idle-display"

fail() { echo "FAIL: $*"; tail -n 20 "$work/linuxcnc.log" 2>/dev/null; exit 1; }
export CIRCTEST_DISPLAY_PID=$work/display.pid
start_linuxcnc() {
  rm -f "$CIRCTEST_DISPLAY_PID"
  (cd "$machine" && exec linuxcnc -r "$config.ini") >>"$work/linuxcnc.log" 2>&1 &
  lcnc_pid=$!
  for _ in $(seq 300); do
    [ -f "$CIRCTEST_DISPLAY_PID" ] && "$build/session/circtest-linuxcnc" status >/dev/null 2>&1 &&
      return 0
    kill -0 $lcnc_pid 2>/dev/null || fail "LinuxCNC did not start"
    sleep 0.2
  done
  fail "LinuxCNC did not come up in 60 s"
}
stop_linuxcnc() {
  kill "$(cat "$CIRCTEST_DISPLAY_PID")"
  wait $lcnc_pid || true
}
# The operator: E-stop released, machine on, and (with `home`) homed, through LinuxCNC's
# Python interface.
operator() {
  /usr/bin/python3 - "$1" <<'PY'
import sys, time, linuxcnc
c, s = linuxcnc.command(), linuxcnc.stat()
def wait(p, what):
    end = time.time() + 60
    while time.time() < end:
        s.poll()
        if p(): return
        time.sleep(0.05)
    e = linuxcnc.error_channel().poll()
    sys.exit("timed out: %s (task state %s, estop %s, last error %s)" % (what, s.task_state, s.estop, e))
# Out of E-stop and on: each command again while the state does not follow (right after start
# the task may not have written its first status, or take commands, yet).
end = time.time() + 60
while True:
    s.poll()
    if s.task_state == linuxcnc.STATE_ON: break
    if time.time() > end:
        sys.exit("timed out: machine on (task state %s, estop %s)" % (s.task_state, s.estop))
    if s.task_state == linuxcnc.STATE_ESTOP: c.state(linuxcnc.STATE_ESTOP_RESET)
    elif s.task_state in (linuxcnc.STATE_ESTOP_RESET, linuxcnc.STATE_OFF): c.state(linuxcnc.STATE_ON)
    time.sleep(0.5)
mode = sys.argv[1]
if mode in ("abort", "estop", "quit"):
    # Mid-run: once the program runs, 3 s into it, as an operator pressing Stop or E-stop,
    # or LinuxCNC quitting (its display ends).
    end = time.time() + 60
    while time.time() < end:
        s.poll()
        if s.interp_state != linuxcnc.INTERP_IDLE: break
        time.sleep(0.02)
    else:
        sys.exit("the program did not start")
    time.sleep(3)
    if mode == "quit":
        import os, signal
        os.kill(int(open(os.environ["CIRCTEST_DISPLAY_PID"]).read()), signal.SIGTERM)
    elif mode == "abort": c.abort()
    else: c.state(linuxcnc.STATE_ESTOP)
    sys.exit(0)
if mode == "cycle-start":
    # The operator at the machine: cycle start once the program is open, and again at each of
    # its operator pauses, until it has run to its end.
    end = time.time() + 300
    while time.time() < end:
        s.poll()
        if s.file.endswith("program.ngc") and s.interp_state == linuxcnc.INTERP_IDLE: break
        time.sleep(0.05)
    time.sleep(0.5)
    c.auto(linuxcnc.AUTO_RUN, 0)
    wait(lambda: s.interp_state != linuxcnc.INTERP_IDLE, "cycle start")
    while time.time() < end:
        s.poll()
        if s.interp_state == linuxcnc.INTERP_PAUSED or s.task_paused:
            time.sleep(0.3)
            c.auto(linuxcnc.AUTO_RESUME)
            wait(lambda: s.interp_state != linuxcnc.INTERP_PAUSED and not s.task_paused, "resume")
        if s.interp_state == linuxcnc.INTERP_IDLE: sys.exit(0)
        time.sleep(0.05)
    sys.exit("timed out: the program did not end")
if mode == "latency":
    # A PC that wakes the servo thread late: once the program's marker output is on, on every
    # CPU a SCHED_FIFO busy loop above LinuxCNC's threads (rt-boost: 50 and below) for the same
    # 30 ms, three times, 200 ms apart.
    import os
    marker = int(os.environ["CIRCTEST_MARKER"])
    end = time.time() + 60
    while time.time() < end:
        s.poll()
        if s.dout[marker]: break
        time.sleep(0.005)
    else:
        sys.exit("the marker output did not come on")
    for _ in range(3):
        children = []
        # Each CPU's loop sleeps to one common start (the forks take their time under load),
        # then, above every other thread, spins 30 ms: no CPU is left for the servo thread.
        start = time.monotonic() + 0.15
        for cpu in sorted(os.sched_getaffinity(0)):
            pid = os.fork()
            if pid == 0:
                os.sched_setaffinity(0, {cpu})
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(90))
                time.sleep(max(0.0, start - time.monotonic()))
                while time.monotonic() < start + 0.03: pass
                os._exit(0)
            children.append(pid)
        for pid in children: os.waitpid(pid, 0)
        time.sleep(0.2)
    sys.exit(0)
if mode.startswith("override="):
    c.feedrate(float(mode[9:])); wait(lambda: abs(s.feedrate - float(mode[9:])) < 1e-6, "override")
    sys.exit(0)
if mode == "home" and not all(s.homed[i] for i in range(s.joints)):
    c.mode(linuxcnc.MODE_MANUAL); c.wait_complete()
    c.teleop_enable(0); c.wait_complete()
    c.home(-1); wait(lambda: all(s.homed[i] for i in range(s.joints)), "homing")
    c.teleop_enable(1); c.wait_complete()
PY
}

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
# An abort and an E-stop mid-run (a short program): incomplete, nothing analysed or applied.
for fault in abort estop; do
  operator "$fault" &
  op=$!
  expect_refusal 5 "the test is incomplete" run --ini "$ini" --start --yes --d 20 --f 2000
  wait $op || fail "the $fault did not happen"
  s=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
  [ -s "$s/trace.csv" ] || fail "$fault: the trace is not kept"
  [ ! -e "$s/diagnosis.json" ] && [ ! -e "$s/apply.txt" ] || fail "$fault: analysed or applied"
  rm -rf "$s"
  operator home
done
# The servo thread made late mid-run (busy loops above LinuxCNC's priority): said in one line,
# servo-period.json counts the late periods, nothing analysed or applied, exit 5.
CIRCTEST_MARKER=$(sed -n 's/^MARKER_OUTPUT *= *//p' "$ini")
export CIRCTEST_MARKER
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
"$circtest" run --ini "$ini" --start --yes --d 100 --f 1000 >"$work/run.out" ||
  { rc=$?; cat "$work/run.out"; fail "circtest run (exit $rc)"; }
cat "$work/run.out"
# The progress without a terminal: plain lines per run and quarter; the servo thread's line.
for text in "XY run 1 of 2 (CCW F1000): recording" "XY run 2 of 2 (CW F1000): 75 % of the path" \
  "XY run 2 of 2 (CW F1000): recorded (" "circtest: the servo thread "; do
  grep -qF "$text" "$work/run.out" || fail "circtest run does not say '$text'"
done
session=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
grep -q "^Stored as test 1 of machine" "$session/history.txt" || fail "not stored in the history"
for f in program.ngc trace.csv results.json diagnosis.json plan.diff apply.txt report.html; do
  [ -s "$session/$f" ] || fail "the session folder has no $f"
done
stop_linuxcnc
start_linuxcnc
operator home
# verify as an operator runs it: circtest opens the program, the operator presses cycle start.
operator cycle-start &
op=$!
"$circtest" verify --ini "$ini" >"$work/verify.out" ||
  { rc=$?; cat "$work/verify.out"; fail "circtest verify (exit $rc)"; }
cat "$work/verify.out"
wait $op || fail "the operator's cycle start"
grep -q "press cycle start on the machine" "$work/verify.out" || fail "verify did not ask for cycle start"
# LinuxCNC quitting mid-run: said, the trace kept, exit 7.
operator quit &
expect_refusal 7 "the test is incomplete" run --ini "$ini" --start --yes --d 20 --f 2000
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
