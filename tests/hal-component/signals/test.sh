# Test 1: 5 s of known signals at 1 kHz into 8 channels: one row per enabled period, period
# counters consecutive, values equal to what LinuxCNC's sampler saw in the same periods.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"

start_recorder -o trace.csv --until-idle 0.3
halcmd sets enable 1
sleep 5
halcmd sets enable 0
wait_recorder
echo "recorder exit: $recorder_rc"
dump_sampler >sampler.txt
echo "pins: overruns=$(halcmd getp circlog.0.overruns) reading=$(halcmd getp circlog.0.reading)"
hal_stop
cat recorder.err >&2
check signals trace.csv sampler.txt
