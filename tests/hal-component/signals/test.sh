# Test 1: 5 s of known signals at 1 kHz into 8 channels: one row per enabled period, period
# counters consecutive, values equal to what LinuxCNC's sampler saw in the same periods.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"

start_recorder -o trace.csv --until-idle 0.3
t0=$(date +%s.%N)
halcmd sets enable 1
t1=$(date +%s.%N)
sleep 5
t2=$(date +%s.%N)
halcmd sets enable 0
t3=$(date +%s.%N)
wait_recorder
echo "recorder exit: $recorder_rc"
dump_sampler >sampler.txt
echo "pins: overruns=$(halcmd getp circlog.0.overruns) reading=$(halcmd getp circlog.0.reading)"
hal_stop
cat recorder.err >&2
check signals trace.csv sampler.txt "$t0" "$t1" "$t2" "$t3"
