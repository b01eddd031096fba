# Test 2b: a reader that stalls (SIGSTOP for 0.8 s) longer than the ring lasts (0.256 s).
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"
start_recorder -o trace.csv --until-idle 0.3
halcmd sets enable 1
sleep 0.2
kill -STOP "$recorder"
sleep 0.8
kill -CONT "$recorder"
sleep 0.3
halcmd sets enable 0
wait_recorder
finish_overrun_test
