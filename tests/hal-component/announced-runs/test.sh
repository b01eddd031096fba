# Test: --until-idle waits for every run the program announces (circgen's segments header),
# through a pause between two runs longer than the idle time, and a program that ends without
# an announced run gives exit 8, a line naming the run and a complete trace that says so.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$CIRCLOG_TESTS/runs/test.hal"

run() {  # run SEGMENT: one run of 0.4 s
  halcmd sets segment "$1"
  halcmd sets enable 1
  sleep 0.4
  halcmd sets enable 0
  halcmd sets segment 0
}
metadata() { grep -E '^# (runs|runs_announced|runs_missing|stop_reason):' "$1"; }

start_recorder -o two.csv --columns x_cmd,y_cmd,x,y --program "$TEST_DIR/two-runs.ngc" \
  --until-idle 1.0
run 1
sleep 2.5  # the pause between a ballbar's CCW and CW runs: longer than --until-idle
run 2
wait_recorder
echo "two runs announced, both run: exit $recorder_rc"
metadata two.csv

start_recorder -o three.csv --columns x_cmd,y_cmd,x,y --program "$TEST_DIR/three-runs.ngc" \
  --until-idle 1.0 --run-wait 2
run 1
sleep 0.5
run 2
wait_recorder
echo "three runs announced, two run: exit $recorder_rc"
metadata three.csv
grep 'error:' recorder.err | sed "s#$TEST_DIR/##; s#$PWD/##"
hal_stop
