# Test 3: toggling enable and segment gives separate runs, with named columns and the
# program's header in the metadata.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"
start_recorder -o trace.csv --columns x_cmd,y_cmd,x,y --describe "x=table X (grid encoder)" \
  --program "$TEST_DIR/program.ngc" --until-idle 1.0
halcmd sets segment 1
halcmd sets enable 1   # run 1, segment 1
sleep 0.4
halcmd sets enable 0
sleep 0.3
halcmd sets enable 1   # run 2, same segment: kept apart by the marker-0 row
sleep 0.4
halcmd sets segment 2  # run 3: segment changes while enabled
sleep 0.4
halcmd sets enable 0
wait_recorder
echo "recorder exit: $recorder_rc"
hal_stop
cat recorder.err >&2
check runs trace.csv
