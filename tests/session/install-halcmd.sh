#!/bin/bash
# circtest install on a configuration, checked by LinuxCNC's own halcmd: the configuration's
# HAL files and the circtest.hal install wrote are loaded as LinuxCNC loads them
# (`halcmd -i INI -f FILE`, in HALFILE order), and circlog's pins must sit on the signals of
# each joint's command and feedback; then uninstall must give back every file byte-identical.
#   install-halcmd.sh CIRCTEST CONFIG_DIR INI_NAME "COLUMN=SIGNAL ..." [INSTALL OPTION]...
# As root it runs itself inside scripts/hal-sandbox (the build's circlog.so beside the system
# modules: CIRCLOG_MODULE, CIRCDRIVE_MODULE).
set -euo pipefail
circtest=$(readlink -f "$1") config=$(readlink -f "$2") ini_name=$3 expected=$4
shift 4
here=$(cd "$(dirname "$0")" && pwd)

if [ "${SESSION_TEST_INSIDE:-}" != 1 ]; then
  [ "$(id -u)" = 0 ] || { echo "SKIP: needs root (hal-sandbox)"; exit 77; }
  work=$(mktemp -d /tmp/circtest-install.XXXXXX)
  chmod 755 "$work"
  modules=()
  for m in ${CIRCLOG_MODULE:-} ${CIRCDRIVE_MODULE:-}; do modules+=(--module "$m"); done
  rc=0
  SESSION_TEST_INSIDE=1 SESSION_WORK=$work "$here/../../scripts/hal-sandbox" --work "$work" \
    "${modules[@]}" --net -- "$0" "$circtest" "$config" "$ini_name" "$expected" "$@" || rc=$?
  [ "$rc" != 0 ] || rm -rf "$work"
  [ "$rc" = 0 ] || echo "(work files kept in $work)" >&2
  exit "$rc"
fi

work=$SESSION_WORK
export HOME=$work/home
mkdir -p "$HOME"
machine=$work/machine pristine=$work/pristine
cp -rL "$config" "$machine"
# A configuration that wires circlog by hand (sim-servo) is tested without that wiring.
sed -i -e '/^HALFILE *= *circlog.hal/d' -e '/^\[CIRCTEST\]/,/^\[/{/^COLUMNS/d}' \
  "$machine/$ini_name"
rm -f "$machine/circlog.hal"
cp -a "$machine" "$pristine"
ini=$machine/$ini_name

"$circtest" install --ini "$ini" --yes "$@" > "$work/install.out"
cat "$work/install.out"
[ -f "$machine/circtest.hal" ] || { echo "FAIL: no circtest.hal"; exit 1; }
grep -q '^HALFILE = circtest.hal' "$ini" || { echo "FAIL: the INI does not load circtest.hal"; exit 1; }

# LinuxCNC's order: every [HAL] HALFILE with the INI's values substituted.
halrun -U >/dev/null 2>&1 || true
halrun -I -f /dev/null </dev/null >/dev/null 2>&1 &
for _ in $(seq 100); do halcmd show comp >/dev/null 2>&1 && break; sleep 0.1; done
cd "$machine"
# As the linuxcnc script: the NML server, the trajectory planner and homing modules, io, then
# the HALFILEs.
linuxcncsvr -ini "$ini" >/dev/null 2>&1 &
sleep 0.5
halcmd loadrt tpmod && halcmd loadrt homemod
halcmd loadusr -Wn iocontrol io -ini "$ini" || { echo "FAIL: io did not start"; halrun -U; exit 1; }
while read -r f; do
  halcmd -i "$ini" -f "$f" || { echo "FAIL: halcmd -f $f"; halrun -U; exit 1; }
done < <(sed -n 's/^HALFILE *= *//p' "$ini")
halcmd show pin circlog > "$work/pins.txt"
halcmd show pin circtest-servo-period > "$work/period-pins.txt" || true
halcmd show pin motion.servo.last-period >> "$work/period-pins.txt" || true
# The threads run a moment: the period conv_u32_float hands circlog is motion's own (stopped,
# both pins hold the last period's values).
halcmd start && sleep 0.5 && halcmd stop
period_u32=$(halcmd getp motion.servo.last-period)
period_float=$(halcmd getp circtest-servo-period.out)
period_in=$(halcmd getp "circlog.0.in-$(printf '%02d' "$(sed -n 's/^COLUMNS *= *//p' "$ini" |
  tr ',' '\n' | grep -n '^servo_period$' | cut -d: -f1 | awk '{print $1-1}')")")
halcmd show funct circlog.0 > "$work/funct.txt"
halcmd show thread > "$work/thread.txt"
halrun -U >/dev/null 2>&1 || true
cat "$work/pins.txt"

fail=0
columns=$(sed -n 's/^COLUMNS *= *//p' "$ini")
IFS=, read -r -a cols <<< "$columns"
for want in $expected; do
  col=${want%%=*} sig=${want#*=}
  idx=-1
  for i in "${!cols[@]}"; do [ "${cols[$i]}" = "$col" ] && idx=$i; done
  [ "$idx" -ge 0 ] || { echo "FAIL: no column $col in COLUMNS = $columns"; fail=1; continue; }
  pin=$(printf 'circlog.0.in-%02d' "$idx")
  line=$(grep -E "[[:space:]]$pin([[:space:]]|$)" "$work/pins.txt" || true)
  echo "$line" | grep -qE "<== $sig\$" ||
    { echo "FAIL: $pin ($col) is not on signal $sig: $line"; fail=1; }
done
grep -qE "circlog.0.enable[[:space:]]+<== circtest-marker" "$work/pins.txt" ||
  { echo "FAIL: circlog.0.enable is not on the marker signal"; fail=1; }
# circlog.0 runs in the servo thread, after motion-controller.
awk '/servo-thread/{s=1} s' "$work/thread.txt" | grep -n "motion-controller\|circlog.0" |
  tr '\n' ' ' | grep -qE "motion-controller.*circlog.0" ||
  { echo "FAIL: circlog.0 is not after motion-controller in the servo thread"; cat "$work/thread.txt"; fail=1; }

# The servo thread's period: motion.servo.last-period through conv_u32_float into circlog, run
# in the servo thread after motion-controller and before circlog.0.
cat "$work/period-pins.txt"
grep -qE "circtest-servo-period.in[[:space:]]+<== " "$work/period-pins.txt" ||
  { echo "FAIL: circtest-servo-period.in is on no signal"; fail=1; }
sig=$(sed -nE 's/.*circtest-servo-period.in[[:space:]]+<== ([^ ]+)$/\1/p' "$work/period-pins.txt")
grep -qE "motion.servo.last-period[[:space:]]+==> $sig\$" "$work/period-pins.txt" ||
  { echo "FAIL: motion.servo.last-period is not on $sig"; fail=1; }
awk '/servo-thread/{s=1} s' "$work/thread.txt" | grep -n "motion-controller\|circtest-servo-period\|circlog.0" |
  tr '\n' ' ' | grep -qE "motion-controller.*circtest-servo-period.*circlog.0" ||
  { echo "FAIL: circtest-servo-period is not between motion-controller and circlog.0"; fail=1; }
echo "servo period: motion.servo.last-period $period_u32, conv out $period_float, circlog in $period_in"
python3 - "$period_u32" "$period_float" "$period_in" <<'PY' || fail=1
import sys
u32, out, logged = int(sys.argv[1], 0), float(sys.argv[2]), float(sys.argv[3])
if not (u32 > 0 and out == u32 and logged == u32):
    sys.exit("FAIL: the period logged (%s, %s) is not motion's (%d)" % (sys.argv[2], sys.argv[3], u32))
PY

"$circtest" uninstall --ini "$ini"
if ! diff -r "$pristine" "$machine"; then
  echo "FAIL: uninstall did not restore the configuration byte-identical"; fail=1
fi
[ $fail = 0 ] && echo "PASS"
exit $fail
