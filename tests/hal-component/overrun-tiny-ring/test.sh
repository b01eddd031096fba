# Test 2a: overruns from a tiny ring show on the pin, in the metadata, as gaps in the period
# counter, on stderr and in the exit code (8).
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"
start_recorder -o trace.csv --until-idle 0.3 --poll 0.05
halcmd sets enable 1
sleep 1
halcmd sets enable 0
wait_recorder
finish_overrun_test
