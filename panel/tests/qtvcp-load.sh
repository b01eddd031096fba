#!/bin/bash
# The panel as LinuxCNC's own qtvcp loads it (`qtvcp circtest`, offscreen), in a private HAL
# session (scripts/hal-sandbox): the handler imported, initialized__ run, the window shown and
# drawn into a PNG, no Python traceback.
# usage: qtvcp-load.sh SOURCE_DIR WORK_DIR
set -eu
src=$1
work=$2
rm -rf "$work"
mkdir -p "$work/cfg/qtvcp/panels"
cp -r "$src/panel/circtest" "$work/cfg/qtvcp/panels/circtest"
cat >"$work/run.sh" <<INNER
#!/bin/bash
# No desktop bus in the sandbox: qtvcp's notifications and Qt fail at once instead of waiting.
export CONFIG_DIR=$work/cfg QT_QPA_PLATFORM=offscreen CIRCTEST_PANEL_SCREENSHOT=$work/panel.png
export DBUS_SESSION_BUS_ADDRESS=disabled: PYTHONUNBUFFERED=1
cd $work/cfg
/usr/lib/linuxcnc/realtime start >/dev/null 2>&1
/usr/bin/python3 -X faulthandler /usr/bin/qtvcp -d circtest >$work/qtvcp.log 2>&1 &
pid=\$!
for _ in \$(seq 1 900); do
  [ -s $work/panel.png ] && break
  kill -0 \$pid 2>/dev/null || break
  sleep 0.1
done
# Not drawn in time: Python's stacks into the log (faulthandler, SIGABRT) to say where it waits.
[ -s $work/panel.png ] || kill -ABRT \$pid 2>/dev/null || true
sleep 0.5
# qtvcp leaves HAL on SIGTERM but its window stays: SIGKILL after 2 s
kill \$pid 2>/dev/null || true
for _ in \$(seq 1 20); do kill -0 \$pid 2>/dev/null || break; sleep 0.1; done
kill -9 \$pid 2>/dev/null || true
/usr/lib/linuxcnc/realtime stop >/dev/null 2>&1 || true
INNER
chmod +x "$work/run.sh"
"$src/scripts/hal-sandbox" --work "$work/sandbox" -- "$work/run.sh"
fail() { echo "qtvcp-load: $*"; cat "$work/qtvcp.log"; exit 1; }
grep -q "Module 'circtest_handler' imported" "$work/qtvcp.log" || fail "the handler was not imported"
grep -q "Show window" "$work/qtvcp.log" || fail "qtvcp did not show the panel"
if grep -q "Traceback" "$work/qtvcp.log"; then fail "a Python traceback"; fi
[ -s "$work/panel.png" ] || fail "the panel was not drawn ($work/panel.png)"
python3 - "$work/panel.png" <<'PY' || fail "the picture is not the panel's size"
import struct, sys
data = open(sys.argv[1], "rb").read(24)
width, height = struct.unpack(">II", data[16:24])
assert data[:8] == b"\x89PNG\r\n\x1a\n" and width >= 400 and height >= 400, (width, height)
PY
echo "qtvcp-load: the panel loaded and drawn ($work/panel.png)"
