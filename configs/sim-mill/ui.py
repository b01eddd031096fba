#!/usr/bin/python3
"""Headless LinuxCNC driver for circtest-run (the [DISPLAY] program of the sim config).

Resets estop, switches the machine on, homes, opens the program, starts the recorder,
runs the program to its end and stops the recorder. LinuxCNC exits with this script's
exit code. Glue only: the logging is circlog-record, the analysis circana.

circgen's programs stop at operator pauses (M0, each after an (MSG, ...)): the driver logs
every operator message and resumes the program when it pauses, as an operator pressing
cycle start would. The number of pauses answered is logged at the end.

Environment (set by circtest-run):
  CIRCTEST_PROGRAM   the G-code program to run (required)
  CIRCTEST_RECORD    the recorder command line, run through the shell (optional)
  CIRCTEST_TIMEOUT   seconds the program may run (default 600)
  CIRCTEST_DEBUG     when set, print the interpreter and motion state once a second
"""
import os
import shlex
import signal
import subprocess
import sys
import time

import linuxcnc


START = time.monotonic()


def log(msg):
    print("circtest-run: [%6.1f s] %s" % (time.monotonic() - START, msg), file=sys.stderr,
          flush=True)


def wait_for(predicate, timeout, what, stat):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        stat.poll()
        if predicate(stat):
            return
        time.sleep(0.02)
    raise RuntimeError("timed out waiting for " + what)


def recorder_attached():
    r = subprocess.run(["halcmd", "getp", "circlog.0.reading"], capture_output=True, text=True)
    return r.returncode == 0 and r.stdout.strip() == "TRUE"


def main():
    program = os.environ.get("CIRCTEST_PROGRAM")
    if not program:
        log("error: CIRCTEST_PROGRAM is not set")
        return 2
    record = os.environ.get("CIRCTEST_RECORD", "")
    timeout = float(os.environ.get("CIRCTEST_TIMEOUT", "600"))

    cmd = linuxcnc.command()
    stat = linuxcnc.stat()
    err = linuxcnc.error_channel()
    wait_for(lambda s: s.task_state is not None, 30, "LinuxCNC task", stat)

    cmd.state(linuxcnc.STATE_ESTOP_RESET)
    wait_for(lambda s: s.task_state == linuxcnc.STATE_ESTOP_RESET, 10, "estop reset", stat)
    cmd.state(linuxcnc.STATE_ON)
    wait_for(lambda s: s.task_state == linuxcnc.STATE_ON, 10, "machine on", stat)

    cmd.mode(linuxcnc.MODE_MANUAL)
    cmd.wait_complete()
    cmd.home(-1)
    wait_for(lambda s: all(s.homed[i] for i in range(s.joints)), 30, "homing", stat)
    # Teleop (world) mode is needed before AUTO on a machine with trivkins.
    cmd.teleop_enable(1)
    cmd.wait_complete()

    cmd.mode(linuxcnc.MODE_AUTO)
    cmd.wait_complete()
    cmd.program_open(program)
    cmd.wait_complete()

    recorder = None
    if record:
        log("recording: " + record)
        # No shell in between: the SIGINT below must reach the recorder itself.
        recorder = subprocess.Popen(shlex.split(record), start_new_session=True)
        # The program starts once the recorder reads circlog's stream (circlog.0.reading),
        # so that the first run's start is in the trace however slowly the recorder starts.
        end = time.monotonic() + 30
        while not recorder_attached():
            if recorder.poll() is not None:
                log("error: the recorder exited at once with code %d" % recorder.returncode)
                return 7
            if time.monotonic() > end:
                log("error: the recorder did not attach to circlog within 30 s")
                recorder.kill()
                return 7
            time.sleep(0.1)

    log("homed; running " + program)
    cmd.auto(linuxcnc.AUTO_RUN, 0)
    # Wait until the interpreter has started, then until it and motion are idle again.
    wait_for(lambda s: s.interp_state != linuxcnc.INTERP_IDLE, 10, "program start", stat)
    failed = None
    pauses = 0
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        stat.poll()
        e = err.poll()
        if e and e[0] in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            failed = e[1]
            break
        if e and e[0] in (linuxcnc.OPERATOR_DISPLAY, linuxcnc.OPERATOR_TEXT,
                          linuxcnc.NML_DISPLAY, linuxcnc.NML_TEXT):
            log("message: " + str(e[1]).strip())
            continue  # read every queued message before acting on a pause
        if stat.interp_state == linuxcnc.INTERP_PAUSED or stat.task_paused:
            # An M0 pause: the operator would read the message and press cycle start.
            pauses += 1
            log("program paused (M0 #%d, line %d): resuming" % (pauses, stat.motion_line))
            cmd.auto(linuxcnc.AUTO_RESUME)
            wait_for(lambda s: s.interp_state != linuxcnc.INTERP_PAUSED and not s.task_paused,
                     10, "resume after M0", stat)
            continue
        if stat.interp_state == linuxcnc.INTERP_IDLE and stat.queue == 0 and stat.inpos:
            break
        if os.environ.get("CIRCTEST_DEBUG") and int(time.monotonic() * 20) % 20 == 0:
            log("interp %s queue %s inpos %s line %s pos %s state %s" % (
                stat.interp_state, stat.queue, stat.inpos, stat.motion_line,
                [round(v, 3) for v in stat.actual_position[:3]], stat.exec_state))
        time.sleep(0.05)
    else:
        failed = "program still running after %.0f s" % timeout

    log(("program finished" if not failed else "program stopped") +
        " after %d operator pause(s)" % pauses)
    code = 0
    if recorder is not None:
        recorder.send_signal(signal.SIGINT)
        try:
            code = recorder.wait(60)
        except subprocess.TimeoutExpired:
            recorder.kill()
            code = 1
        log("recorder exited with code %d" % code)
    if failed:
        log("error: " + str(failed))
        return 1
    cmd.state(linuxcnc.STATE_OFF)
    return code


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception as exc:  # any failure must end LinuxCNC with a non-zero code
        log("error: %s" % exc)
        sys.exit(1)
