#!/bin/bash
# circtest as the user who runs LinuxCNC, on a configuration it was not built on: configs/
# pncconf-mill (pncconf's files and signal names, a simulated drive and motor in place of the
# Mesa card), in ~/linuxcnc/configs/mill of an unprivileged user, started as pncconf's users
# start it (`linuxcnc ~/linuxcnc/configs/mill/mill.ini`, no -r), every command with stdin from
# /dev/null, and circtest as its package installs it: the parts' own install rules (the .deb's)
# into a staging root, its realtime modules where LinuxCNC's loadrt looks
# (/usr/lib/linuxcnc/modules; scripts/hal-sandbox mounts the staged ones there for this test
# only, the system's folder is not written). Then, as that user:
#   circtest install                  without --yes and without a terminal: nothing written
#   circtest install --yes            the channels found through pncconf's signals (x-pos-cmd,
#                                     x-pos-fb); the marker output beside custom.hal's relay
#   restart LinuxCNC, the operator homes and touches off (G10 L2 P1: the table's middle)
#   circtest run, X jammed mid-run    a following error: said, incomplete, exit 5
#   circtest run, X jammed at start   a following error before the first run: said, exit 5
#   circtest run --start --yes        measured, diagnosed (each axis lags 1 / P), FF1 applied
#   restart LinuxCNC
#   circtest verify --start           the same program again: G well below G before
# and nothing in the user's home or configuration folder belongs to another user.
#   session-user-e2e.sh BUILD_DIR [WORK_DIR]
set -euo pipefail
build=$(readlink -f "$1")
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/../.." && pwd)
# shellcheck source=linuxcnc-e2e.sh
. "$here/linuxcnc-e2e.sh"

if [ "${E2E_INSIDE:-}" != 1 ]; then
  [ "$(id -u)" = 0 ] || { echo "SKIP: needs root (to make the user and the sandbox)"; exit 77; }
  work=${2:-$(mktemp -d /tmp/circtest-user-e2e.XXXXXX)}
  mkdir -p "$work"
  chmod 755 "$work"
  stage=$work/stage
  rm -rf "$stage"
  # What the .deb holds, by the same install rules: programs in /usr/bin, the LinuxCNC link in
  # /usr/libexec/circtest, the realtime modules in /usr/lib/linuxcnc/modules.
  for part in gcode-gen analysis compensation hal-component session; do
    DESTDIR=$stage cmake --install "$build/$part" --prefix /usr >/dev/null
  done
  modules=()
  for m in "$stage"/usr/lib/linuxcnc/modules/*.so; do modules+=(--module "$m"); done
  [ -x "$stage/usr/bin/circtest" ] && [ ${#modules[@]} -gt 0 ] ||
    { echo "FAIL: the install put no circtest or no module into $stage"; exit 1; }
  rc=0
  E2E_INSIDE=1 E2E_WORK=$work E2E_STAGE=$stage "$top/scripts/hal-sandbox" --work "$work" --net \
    "${modules[@]}" -- "$0" "$@" || rc=$?
  [ "$rc" != 0 ] || [ -n "${2:-}" ] || rm -rf "$work"
  [ "$rc" = 0 ] || echo "(work files kept in $work)" >&2
  exit "$rc"
fi

work=$E2E_WORK stage=$E2E_STAGE
"$top/scripts/rt-boost" &
boost_pid=$!
trap 'kill "$boost_pid" 2>/dev/null || true' EXIT

# The machine's user: an ordinary account, no groups, its home in the work folder.
user=circtest-operator
id -u "$user" >/dev/null 2>&1 ||
  useradd --system --no-create-home --home-dir /nonexistent --shell /usr/sbin/nologin "$user"
uid=$(id -u "$user") gid=$(id -g "$user")
home=$work/home
rm -rf "$home"
mkdir -p "$home/linuxcnc/configs" "$home/linuxcnc/nc_files"
machine=$home/linuxcnc/configs/mill ini=$home/linuxcnc/configs/mill/mill.ini
cp -r "$top/configs/pncconf-mill" "$machine"
# The screen: configs/idle-display (headless) in place of gmoccapy; pncconf writes the
# user's own nc_files folder; a simulated machine notes late servo periods (docs/session.md).
ini_tool=$build/core/circtest-ini
"$ini_tool" set "$ini" DISPLAY DISPLAY "$top/configs/idle-display"
"$ini_tool" set "$ini" DISPLAY PROGRAM_PREFIX "$home/linuxcnc/nc_files"
"$ini_tool" set "$ini" CIRCTEST LATE_SERVO_PERIODS note
chown -R "$uid:$gid" "$home"
# The linuxcnc script's lock file (scripts/hal-sandbox: this folder's) is the user's to make.
chown "$uid:$gid" "$work"
export CIRCTEST_DISPLAY_PID=$work/display.pid

# COMMAND as the user, in a login-like environment: no root, no RTAPI_UID, no build paths.
as_user() {
  setpriv --reuid="$uid" --regid="$gid" --clear-groups -- env -i HOME="$home" USER="$user" \
    LOGNAME="$user" LANG=C.UTF-8 PATH="$stage/usr/bin:/usr/local/bin:/usr/bin:/bin" \
    CIRCTEST_DISPLAY_PID="$CIRCTEST_DISPLAY_PID" CIRCTEST_MARKER="${CIRCTEST_MARKER:-}" "$@"
}
# shellcheck disable=SC2034 # the operator (linuxcnc-e2e.sh) runs as the user
e2e_as=(as_user)
link=$stage/usr/libexec/circtest/circtest-linuxcnc

fail() {
  echo "FAIL: $*"
  tail -n 20 "$work/linuxcnc.log" "$home/linuxcnc_print.txt" "$home/linuxcnc_debug.txt" \
    2>/dev/null || true
  exit 1
}

start_mill() {
  rm -f "$CIRCTEST_DISPLAY_PID"
  (cd "$home" && as_user linuxcnc "$ini") >>"$work/linuxcnc.log" 2>&1 </dev/null &
  lcnc_pid=$!
  for _ in $(seq 300); do
    [ -f "$CIRCTEST_DISPLAY_PID" ] && as_user "$link" status >/dev/null 2>&1 && return 0
    kill -0 $lcnc_pid 2>/dev/null || fail "LinuxCNC did not start"
    sleep 0.2
  done
  fail "LinuxCNC did not come up in 60 s"
}

# circtest ARGS... as the user, stdin /dev/null, into OUT; its exit code into rc.
as_circtest() {
  local out=$1
  shift
  rc=0
  as_user circtest "$@" </dev/null >"$out" 2>&1 || rc=$?
}

t0=$SECONDS
as_circtest "$work/install-asked.out" install --ini "$ini"
cat "$work/install-asked.out"
[ ! -e "$machine/circtest.hal" ] || fail "install without --yes and without a terminal wrote"
as_circtest "$work/install.out" install --ini "$ini" --yes
cat "$work/install.out"
[ $rc = 0 ] || fail "install (exit $rc)"
# The channels through pncconf's signals, and the marker beside custom.hal's relay (output 00).
for net in "net x-pos-cmd => circlog.0.in-00" "net y-pos-cmd => circlog.0.in-01" \
  "net x-pos-fb => circlog.0.in-03" "net y-pos-fb => circlog.0.in-04" \
  "net circtest-marker motion.digital-out-01 => circlog.0.enable"; do
  grep -qxF "$net" "$machine/circtest.hal" || fail "circtest.hal has no '$net'"
done
start_mill
# LinuxCNC's own programs run as the user (rtapi_app, setuid root as LinuxCNC installs it,
# keeps root for its threads and writes files as the user).
for p in milltask halui io; do
  [ "$(ps -o uid= -C "$p" | tr -d ' ' | sort -u)" = "$uid" ] || fail "$p does not run as $user"
done
operator home
operator "mdi=G10 L2 P1 X200 Y150 Z-50"
CIRCTEST_MARKER=$(sed -n 's/^MARKER_OUTPUT *= *//p' "$ini")
# X jammed as the program starts: its move to the start trips the following error before the
# first run's marker, nothing is recorded; named from LinuxCNC's following error high mark of
# joint 0 (first: a later following error must go beyond an earlier one to raise it), exit 5.
operator jam-at-start=pid.x.Pgain=0 &
op=$!
as_circtest "$work/ferror-early.out" run --ini "$ini" --start --yes --d 20 --f 1000
cat "$work/ferror-early.out"
wait $op || fail "X was not jammed at the start"
[ $rc = 5 ] || fail "a following error before the first run: exit $rc, expected 5"
grep -qF "circtest: the test is incomplete (joint 0 (X): a following error " "$work/ferror-early.out" &&
  grep -qF "before its first run was recorded: its error reached" "$work/ferror-early.out" ||
  fail "the following error before the first run is not said"
rm -rf "$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)"
as_user halcmd setp pid.x.Pgain 40
operator home
# A following error mid-run (X jammed: its pid's gain 0 once the run records, so the motor
# stops while the command goes on): said in one line, the trace kept, nothing analysed or
# applied, exit 5.
operator jam=pid.x.Pgain=0 &
op=$!
as_circtest "$work/ferror.out" run --ini "$ini" --start --yes --d 20 --f 1000
cat "$work/ferror.out"
wait $op || fail "X was not jammed"
[ $rc = 5 ] || fail "a following error: exit $rc, expected 5"
grep -qF "circtest: the test is incomplete (joint 0 (X): a following error" "$work/ferror.out" ||
  fail "the following error is not said"
s=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
[ -s "$s/trace.csv" ] || fail "following error: the trace is not kept"
[ ! -e "$s/diagnosis.json" ] && [ ! -e "$s/apply.txt" ] || fail "following error: analysed or applied"
rm -rf "$s"
as_user halcmd setp pid.x.Pgain 40
operator home
as_circtest "$work/run.out" run --ini "$ini" --start --yes
cat "$work/run.out"
[ $rc = 0 ] || fail "circtest run (exit $rc)"
session=$(ls -d "$machine"/circtest-sessions/*/ | tail -n 1)
for f in program.ngc trace.csv results.json diagnosis.json plan.diff apply.txt report.html; do
  [ -s "$session/$f" ] || fail "the session folder has no $f"
done
grep -q "^Stored as test 1 of machine" "$session/history.txt" || fail "not stored in the history"
stop_linuxcnc
start_mill
operator home
# The same touch-off again: LinuxCNC keeps it in linuxcnc.var only when milltask exits within
# the linuxcnc script's 2 s, which a loaded machine (CI, beside a build) does not always give.
operator "mdi=G10 L2 P1 X200 Y150 Z-50"
as_circtest "$work/verify.out" verify --ini "$ini" --start
cat "$work/verify.out"
[ $rc = 0 ] || fail "circtest verify (exit $rc)"
stop_linuxcnc
grep -h "POSIX\|realtime" "$home/linuxcnc_print.txt" "$home/linuxcnc_debug.txt" 2>/dev/null | head -n 3 || true
others=$(find "$home" "$work/display.pid" ! -user "$user")
[ -z "$others" ] || fail "not the user's: $others"
echo "session as $user on pncconf-mill: $((SECONDS - t0)) s"

# Each axis lags by 1 / P plus one servo period (P 40 and 50 1/s, FF1 0: a type-1 loop follows
# a ramp with exactly 1 / P of error; the drive's lag adds nothing to it; the pid compares the
# previous period's command with the feedback read before motion, as pncconf's
# error-previous-target asks for a card read at the period's start, so against this period's
# command the axis is one period later); circcomp's FF1 takes the lags out.
/usr/bin/python3 - "$session" "$ini" "$work/run.out" <<'PY'
import json, re, sys
session, ini, run_out = sys.argv[1], sys.argv[2], sys.argv[3]
def ini_value(sec, key):
    cur = None
    for line in open(ini):
        line = line.strip()
        if line.startswith("["): cur = line.strip("[]")
        elif cur == sec and "=" in line and line.split("=")[0].strip() == key:
            return float(line.split("=", 1)[1])
d = json.load(open(session + "/diagnosis.json"))
lag = d["axis_lag_ms"]
before = json.load(open(session + "/results.json"))
after = json.load(open(session + "/verify-results.json"))
g = lambda r: max(run["G"] for run in r["runs"])
print("lag X %.2f ms (1/P + 1 ms: 26.00), Y %.2f ms (21.00); FF1 now X %s, Y %s; G %.1f -> %.1f um"
      % (lag["X"], lag["Y"], ini_value("JOINT_0", "FF1"), ini_value("JOINT_1", "FF1"),
         g(before) * 1e3, g(after) * 1e3))
errors = []
if abs(lag["X"] - 26.0) > 0.02 * 26.0: errors.append("the lag of X")
if abs(lag["Y"] - 21.0) > 0.02 * 21.0: errors.append("the lag of Y")
if not ini_value("JOINT_0", "FF1") > 0: errors.append("FF1 of X not written")
if not g(after) < 0.5 * g(before): errors.append("G did not halve after the corrections")
# Each run's G said as it ended (the live copy through that run) is the G of the whole trace's
# evaluation after the program.
said = {int(m.group(1)): float(m.group(2)) for m in
        re.finditer(r"run (\d+) of \d+ \([^)]*\): G ([0-9.]+) um", open(run_out).read())}
print("G said at each run's end: %s" % said)
if sorted(said) != list(range(1, len(before["runs"]) + 1)): errors.append("not every run's G said")
for k, value in said.items():
    if abs(value - before["runs"][k - 1]["G"] * 1e3) > 0.051:
        errors.append("run %d's G said %.1f, evaluated %.2f" % (k, value, before["runs"][k - 1]["G"] * 1e3))
if errors: sys.exit("FAIL: " + ", ".join(errors))
print("PASS")
PY
