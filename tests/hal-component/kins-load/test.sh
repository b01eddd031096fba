# circtest_kins in a real halrun: loads like trivkins (coordinates=, kinstype= accepted, a
# gantry letter twice), exports its squareness pins, takes setp, refuses a bad coordinates=.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
halrun -U >/dev/null 2>&1 || true
"$REALTIME" start >&2
halcmd loadrt circtest_kins coordinates=XYYZ kinstype=1 >&2
echo "loaded: $(halcmd list comp | tr ' ' '\n' | grep -c '^circtest_kins$')"
halcmd show pin circtest-kins | awk 'NR > 2 && NF >= 5 { print $2, $3, $5 }'
halcmd setp circtest-kins.squareness-xy 1.25e-4
halcmd setp circtest-kins.squareness-zx -3e-5
echo "xy: $(halcmd getp circtest-kins.squareness-xy)"
echo "zx: $(halcmd getp circtest-kins.squareness-zx)"
halcmd unload circtest_kins >&2
rc=0
halcmd loadrt circtest_kins coordinates=XYQ >&2 2>&1 || rc=$?
echo "coordinates=XYQ refused: $([ $rc != 0 ] && echo yes || echo no)"
echo "left loaded: $(halcmd list comp | tr ' ' '\n' | grep -c '^circtest_kins$' || true)"
hal_stop
