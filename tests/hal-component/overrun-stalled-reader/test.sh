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
enabled=$(halcmd getp sampler.0.curr-depth)
pin=$(halcmd getp circlog.0.overruns)
hal_stop
cat recorder.err >&2
check overruns trace.csv "$pin" "$recorder_rc" "$enabled"
echo "stderr names the gaps: $(grep -q 'gap: [0-9]* record(s) lost before period' recorder.err && echo yes || echo NO)"
echo "stderr reports the loss: $(grep -q 'error: [0-9]* sample(s) lost' recorder.err && echo yes || echo NO)"
