# Every way halcmd sets a gain, read by circcomp as a real halcmd reads it: the servo-mill
# fixture with X's FF1 set by a later "PIN = [SECTION]KEY" (custom.hal, after the
# [JOINT_0]FF1 setp), Y's FF1 by "sets" of the signal its pin is on and Y's P by "PIN =
# VALUE". halcmd loads the files as LinuxCNC does; the values it ends with are compared with
# what circcomp plans from ("FF1 BEFORE -> AFTER"), then again after circcomp apply.
# Run by run-hal-test.sh.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
fixture=servo-mill
rm -rf "$fixture"
cp -r "$FRIC_FIXTURES/$fixture" "$fixture"
cd "$fixture"
sed -i 's/^setp   pid.y.FF1       \[JOINT_1\]FF1$/net y-ff1 pid.y.FF1/' servo-mill.hal
grep -q '^net y-ff1 pid.y.FF1$' servo-mill.hal
cat >>custom.hal <<'HAL'
pid.x.FF1 = [PID_X]FF1
sets y-ff1 0.25
pid.y.Pgain = 45
HAL
printf '\n[PID_X]\nFF1 = 0.4\n' >>servo-mill.ini
rm -rf ../edited && cp -r . ../edited
sha=$(sha256sum servo-mill.ini | cut -d' ' -f1)
cat >../d.json <<JSON
{"schema": "circtest.diagnosis/1", "plane": "XY", "axes": ["X", "Y"],
 "axis_lag_ms": {"X": 12.0, "Y": 18.0},
 "standard_error": {"axis_lag_ms": {"X": 0.01, "Y": 0.01}},
 "ini_sha256": "$sha"}
JSON

# The gains a real halcmd ends with after loading the configuration's HAL files in order.
halcmd_gains() {
  halrun -U >/dev/null 2>&1 || true
  "$REALTIME" start >&2
  halcmd loadrt tpmod >&2
  halcmd loadrt homemod >&2
  for f in $(grep '^HALFILE' servo-mill.ini | sed 's/.*= //'); do
    halcmd -i servo-mill.ini -f "$f" >&2
  done
  for pin in pid.x.FF1 pid.y.FF1 pid.x.Pgain pid.y.Pgain; do
    printf '%s=%.6g ' "$pin" "$(halcmd getp $pin)"
  done
  echo
  hal_stop
}
# "X FF1 before after" from circcomp's summary line of axis AXIS.
circcomp_ff1() {
  sed -n "s/^# change: $1 servo (joint [0-9], pid\.[a-z]): FF1 \([-0-9.]*\) -> \([-0-9.]*\) .*/\1 \2/p"
}
same() { awk -v a="$1" -v b="$2" 'BEGIN { exit !((a - b) ^ 2 < 1e-12) }' && echo agree || echo "DIFFER ($1, $2)"; }

before=$(halcmd_gains)
"$CIRCCOMP" plan --ini servo-mill.ini ../d.json >../plan.txt
read -r x_before x_after <<<"$(circcomp_ff1 X <../plan.txt)"
read -r y_before y_after <<<"$(circcomp_ff1 Y <../plan.txt)"
hx=$(grep -o 'pid.x.FF1=[^ ]*' <<<"$before" | cut -d= -f2)
hy=$(grep -o 'pid.y.FF1=[^ ]*' <<<"$before" | cut -d= -f2)
echo "halcmd before: $before"
echo "X FF1 before: halcmd and circcomp $(same "$hx" "$x_before")"
echo "Y FF1 before: halcmd and circcomp $(same "$hy" "$y_before")"
grep -q 'P 45.0 kept' ../plan.txt && echo "Y P read as 45 (pid.y.Pgain = 45)"
"$CIRCCOMP" apply --ini servo-mill.ini ../d.json >&2
after=$(halcmd_gains)
hx=$(grep -o 'pid.x.FF1=[^ ]*' <<<"$after" | cut -d= -f2)
hy=$(grep -o 'pid.y.FF1=[^ ]*' <<<"$after" | cut -d= -f2)
echo "X FF1 after apply: halcmd and circcomp's planned value $(same "$hx" "$x_after")"
echo "Y FF1 after apply: halcmd and circcomp's planned value $(same "$hy" "$y_after")"
echo "X FF1 changed by the apply: $(awk -v a="$x_before" -v b="$hx" 'BEGIN { print (a != b) ? "yes" : "NO" }')"
"$CIRCCOMP" revert --ini servo-mill.ini >&2
cd ..
echo "reverted byte-identical: $(diff -r -x .circcomp edited "$fixture" >&2 && echo yes || echo NO)"
