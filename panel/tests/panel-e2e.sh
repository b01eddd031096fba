#!/bin/bash
# The panel end to end (test_panel_e2e.py): configs/sim-servo with demo.sh's errors, circlog
# installed (`circtest install --yes`), started with `linuxcnc` and configs/idle-display as
# tests/e2e/session-e2e.sh starts it, switched on and homed; then the panel under Xvfb
# (xvfb-run -a), its buttons pressed by the test: set up, preview, run, apply, LinuxCNC
# restarted (the test runs this script with PANEL_E2E_RESTART=1), verify. Screenshots of each
# step into SHOT_DIR (panel/tests/copy-screenshots.sh copies them into docs/).
#   panel-e2e.sh BUILD_DIR [WORK_DIR]     (SHOT_DIR: PANEL_E2E_SHOTS, else BUILD_DIR/panel/e2e)
# Runs as root inside scripts/hal-sandbox (the build's modules beside the system's); exit 77
# (skipped) when not root.
set -euo pipefail
build=$(readlink -f "$1")
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/../.." && pwd)
# shellcheck source=../../tests/e2e/linuxcnc-e2e.sh
. "$top/tests/e2e/linuxcnc-e2e.sh"

if [ "${PANEL_E2E_RESTART:-}" = 1 ]; then
  # The test's restart, as a user's: LinuxCNC quit, started again, switched on and homed.
  work=$E2E_WORK machine=$PANEL_E2E_MACHINE config=sim-servo
  stop_linuxcnc
  start_linuxcnc
  operator home || fail "on and homed after the restart"
  exit 0
fi
if [ "${E2E_INSIDE:-}" != 1 ]; then
  command -v xvfb-run >/dev/null || { echo "SKIP: no xvfb-run (package xvfb)"; exit 77; }
  e2e_sandbox "$0" "$@"
fi
e2e_machine sim-servo
t0=$SECONDS
"$circtest" install --ini "$ini" --yes --instrument x=simx-tab.out --instrument y=simy-tab.out \
  --instrument z=simz-tab.out >"$work/install.out" || fail "install (exit $?)"
# sim-servo is a simulated machine (its motion is computed per servo period): late servo
# periods of this PC under load are said and the session goes on (docs/session.md).
"$ini_tool" set "$ini" CIRCTEST LATE_SERVO_PERIODS note
start_linuxcnc
operator home || fail "on and homed"
echo "panel e2e: LinuxCNC on and homed after $((SECONDS - t0)) s"
shots=${PANEL_E2E_SHOTS:-$build/panel/e2e}
mkdir -p "$shots"
# The programs (conftest.py's CIRCTEST_TEST_<NAME>)
for name in circgen:gcode-gen/circgen circana:analysis/circana circcomp:compensation/circcomp \
  circtest:session/circtest; do
  n=${name%%:*}
  export "CIRCTEST_TEST_${n^^}=$build/${name#*:}"
done
rc=0
# (root: no compiled Python left in the source tree)
export PYTHONDONTWRITEBYTECODE=1
PANEL_E2E_INI=$ini PANEL_E2E_SHOTS=$shots PANEL_E2E_MACHINE=$machine PANEL_E2E_BUILD=$build \
  PANEL_E2E_SCRIPT=$here/panel-e2e.sh QT_QPA_PLATFORM=xcb xvfb-run -a -s "-screen 0 1280x1024x24" \
  "${PANEL_E2E_PYTHON:-/usr/bin/python3}" -m pytest -q -s -p no:cacheprovider \
  "$here/test_panel_e2e.py" || rc=$?
# A failed test leaves LinuxCNC to the sandbox's end (its PID namespace ends every process).
[ $rc != 0 ] || stop_linuxcnc
echo "panel e2e: $((SECONDS - t0)) s (screenshots in $shots)"
exit $rc
