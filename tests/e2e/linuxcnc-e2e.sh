# A real LinuxCNC for the end-to-end tests that drive it as a user does (session-e2e.sh,
# panel/tests/panel-e2e.sh): sourced, with `build` (the build tree) and `top` (the source
# tree) set.
#   e2e_sandbox SCRIPT ARGS...  outside the sandbox: needs root (else exit 77), makes the work
#                               folder (ARGS' second, else a temporary one, removed after a
#                               pass) and runs SCRIPT ARGS... again inside scripts/hal-sandbox
#                               with the build's HAL modules (E2E_INSIDE=1, E2E_WORK); exits
#   e2e_machine CONFIG          inside: LinuxCNC's realtime threads boosted, the programs'
#                               environment, configs/CONFIG copied to $machine without circlog
#                               and with demo.sh's errors (scale X 50 ppm, cyclic Y 2 um), its
#                               display configs/idle-display
#   start_linuxcnc, stop_linuxcnc, operator MODE, fail TEXT
e2e_sandbox() {
  local script=$1 rc=0 hc=$build/hal-component
  [ "$(id -u)" = 0 ] || { echo "SKIP: needs root (hal-sandbox)"; exit 77; }
  work=${3:-$(mktemp -d /tmp/circtest-e2e.XXXXXX)}
  mkdir -p "$work"
  chmod 755 "$work"
  E2E_INSIDE=1 E2E_WORK=$work "$top/scripts/hal-sandbox" --work "$work" --net \
    --module "$hc/circlog.so" --module "$hc/circdrive.so" --module "$hc/circtest_kins.so" \
    --module "$hc/circfric.so" -- "$@" || rc=$?
  [ "$rc" != 0 ] || [ -n "${3:-}" ] || rm -rf "$work"
  [ "$rc" = 0 ] || echo "(work files kept in $work)" >&2
  exit "$rc"
}

e2e_machine() {
  config=$1
  work=$E2E_WORK
  # LinuxCNC's realtime threads SCHED_FIFO, as configs/circtest-run makes them
  # (scripts/rt-boost says why: at normal priority, builds and tests beside this one stall its
  # servo thread).
  "$top/scripts/rt-boost" &
  boost_pid=$!
  trap 'kill "$boost_pid" 2>/dev/null || true' EXIT
  export HOME=$work/home CIRCTEST_BIN=$build
  mkdir -p "$HOME"
  # circcomp apply checks that the modules a plan loads are where this LinuxCNC loads them.
  export CIRCTEST_KINS_MODULE=$build/hal-component/circtest_kins.so
  export CIRCTEST_FRIC_MODULE=$build/hal-component/circfric.so
  circtest=$build/session/circtest
  ini_tool=$build/core/circtest-ini
  machine=$work/machine ini=$work/machine/$config.ini
  rm -rf "$machine"
  cp -rL "$top/configs/$config" "$machine"
  sed -i -e '/^HALFILE *= *circlog.hal/d' -e '/^\[CIRCTEST\]/,/^\[/{/^COLUMNS/d}' "$ini"
  rm -f "$machine/circlog.hal" "$machine/ui.py"
  "$ini_tool" set "$ini" SIM SCALE_X 50e-6
  "$ini_tool" set "$ini" SIM CYCLIC_Y 0.002
  "$ini_tool" set "$ini" DISPLAY DISPLAY "$top/configs/idle-display"
  export CIRCTEST_DISPLAY_PID=$work/display.pid
}

fail() { echo "FAIL: $*"; tail -n 20 "$work/linuxcnc.log" 2>/dev/null; exit 1; }

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

# Its display ended, LinuxCNC shuts down; done when the linuxcnc script removed its lock file
# (scripts/hal-sandbox makes it the work folder's), its last step: so also when another
# process started it (the panel's test restarts LinuxCNC through panel-e2e.sh).
stop_linuxcnc() {
  kill "$(cat "$CIRCTEST_DISPLAY_PID")"
  if [ -n "${lcnc_pid:-}" ]; then wait "$lcnc_pid" 2>/dev/null || true; fi
  local lock=$work/.linuxcnc.lock
  [ -f "$work/.linuxcnc" ] || lock=/tmp/linuxcnc.lock
  for _ in $(seq 600); do
    [ -e "$lock" ] || return 0
    sleep 0.1
  done
  fail "LinuxCNC did not shut down in 60 s"
}

# The operator: E-stop released, machine on, and (with `home`) homed, through LinuxCNC's
# Python interface; `mdi=LINE` runs LINE by MDI (a touch-off); `jam=PIN=VALUE`,
# `jam-at-start=PIN=VALUE`, `estop-at-start` (below). As the command prefix e2e_as
# (an array) when it is set: a script's own user.
operator() {
  ${e2e_as[@]+"${e2e_as[@]}"} /usr/bin/python3 - "$1" <<'PY'
import os, sys, time, linuxcnc
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
if mode == "estop-at-start":
    # An E-stop as soon as the program starts: before its operator pause, so before the
    # marker output of its first run can come on.
    end = time.time() + 180
    while time.time() < end:
        s.poll()
        if s.interp_state != linuxcnc.INTERP_IDLE: break
        time.sleep(0.005)
    else:
        sys.exit("the program did not start")
    c.state(linuxcnc.STATE_ESTOP)
    sys.exit(0)
if mode in ("abort", "estop", "quit"):
    # Mid-run: 0.3 s into the program's first run when CIRCTEST_MARKER names its marker output,
    # else 3 s after it starts; as an operator pressing Stop or E-stop, or LinuxCNC quitting
    # (its display ends).
    end = time.time() + 180
    while time.time() < end:
        s.poll()
        if s.interp_state != linuxcnc.INTERP_IDLE: break
        time.sleep(0.02)
    else:
        sys.exit("the program did not start")
    if os.environ.get("CIRCTEST_MARKER"):
        # Inside a run, whatever the load: once the program's marker output is on (never at
        # another moment: without the marker, no quit).
        # Its rising edge: an aborted program before this one may have left it on until circtest
        # switches it off.
        marker = int(os.environ["CIRCTEST_MARKER"])
        end = time.time() + 180
        seen_off = False
        while time.time() < end:
            s.poll()
            seen_off = seen_off or not s.dout[marker]
            if seen_off and s.dout[marker]: break
            time.sleep(0.005)
        else:
            sys.exit("the program's marker output did not come on")
        time.sleep(0.3)
    else:
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
if mode.startswith("jam-at-start="):
    # A jammed axis as the program starts (`jam-at-start=PIN=VALUE`): before its first run's
    # marker, so its first move trips the following error.
    import subprocess
    pin, value = mode[len("jam-at-start="):].split("=")
    wait(lambda: s.interp_state != linuxcnc.INTERP_IDLE, "the program's start")
    subprocess.run(["halcmd", "setp", pin, value], check=True)
    sys.exit(0)
if mode.startswith("jam="):
    # A jammed axis mid-run (`jam=PIN=VALUE`, e.g. a pid's Pgain to 0: its drive stops while
    # the command goes on): once the program's marker output is on, 0.3 s later, by halcmd.
    import subprocess
    pin, value = mode[4:].split("=")
    marker = int(os.environ["CIRCTEST_MARKER"])
    wait(lambda: s.dout[marker], "the marker output")
    time.sleep(0.3)
    subprocess.run(["halcmd", "setp", pin, value], check=True)
    sys.exit(0)
if mode.startswith("mdi="):
    c.mode(linuxcnc.MODE_MDI); c.wait_complete()
    c.mdi(mode[4:]); c.wait_complete(30)
    wait(lambda: s.interp_state == linuxcnc.INTERP_IDLE, "MDI " + mode[4:])
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
