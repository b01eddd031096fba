# The wiring docs/circfric.md gives for a second HAL file: addf's position puts circfric
# between the position command's source and the pid, unlinkp + net splice it into the
# command without editing the main file, and the pid follows pos-out.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
halrun -U >/dev/null 2>&1 || true
"$REALTIME" start >&2
halcmd -f "$TEST_DIR/main.hal" >&2
halcmd -f "$TEST_DIR/fric.hal" >&2
echo "thread order: $(halcmd show thread servo-thread | awk 'NF == 2 && $1 ~ /^[0-9]+$/ { print $2 }' | tr '\n' ' ')"
echo "pid.x.command is on: $(halcmd show pin pid.x.command | awk 'NR > 2 && NF >= 6 { print $NF }')"
echo "fric-x.pos-in is on: $(halcmd show pin fric-x.pos-in | awk 'NR > 2 && NF >= 6 { print $NF }')"
halcmd start
count=$(halcmd getp fric-x.reversals)
wait_for_value fric-x.reversals $((count + 1))
halcmd stop
cmd=$(halcmd getp pid.x.command)
pos_in=$(halcmd getp fric-x.pos-in)
offset=$(halcmd getp fric-x.offset)
/usr/bin/python3 - "$cmd" "$pos_in" "$offset" <<'PY'
import sys
cmd, pos_in, offset = map(float, sys.argv[1:])
print(f"pid.x.command = pos-in + offset while a pulse runs: "
      f"{'yes' if abs(offset) > 0.1 and abs(cmd - (pos_in + offset)) < 2e-6 else 'NO'}")
PY
hal_stop
