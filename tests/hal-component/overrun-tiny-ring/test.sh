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
enabled=$(halcmd getp sampler.0.curr-depth)
pin=$(halcmd getp circlog.0.overruns)
hal_stop
cat recorder.err >&2
check overruns trace.csv "$pin" "$recorder_rc" "$enabled"
echo "stderr names the gaps: $(grep -q 'gap: [0-9]* record(s) lost before period' recorder.err && echo yes || echo NO)"
echo "stderr reports the loss: $(grep -q 'error: [0-9]* sample(s) lost' recorder.err && echo yes || echo NO)"
