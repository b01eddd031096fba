# Helpers for the test.sh scripts, sourced inside the namespaces set up by run-hal-test.sh.
REALTIME=/usr/lib/linuxcnc/realtime

# Starts realtime and runs a HAL file (like halrun -f, but leaves the session running).
hal_start() {
  halrun -U >/dev/null 2>&1 || true
  "$REALTIME" start >&2
  halcmd -f "$1" >&2
}

hal_stop() {
  halcmd stop >&2 || true
  halcmd unload all >&2 || true
  "$REALTIME" stop >&2 || true
}

# Waits until a HAL pin or parameter has a value (up to 10 s).
wait_for_value() {
  local name=$1 want=$2 i
  for i in $(seq 200); do
    [ "$(halcmd getp "$name")" = "$want" ] && return 0
    sleep 0.05
  done
  echo "timeout waiting for $name = $want (is $(halcmd getp "$name"))" >&2
  return 1
}

# Starts circlog-record in the background with ARGS (stderr to recorder.err), sets $recorder to
# its PID and waits until it has attached to the ring (circlog.0.reading).
start_recorder() {
  "$CIRCLOG_RECORDER" "$@" 2>recorder.err &
  recorder=$!
  wait_for_value circlog.0.reading TRUE
}

# Waits for the recorder started by start_recorder; sets $recorder_rc to its exit code.
wait_recorder() {
  recorder_rc=0
  wait "$recorder" || recorder_rc=$?
}

# Number of samples waiting in sampler.0's fifo, then prints them (halsampler).
dump_sampler() {
  local n
  n=$(halcmd getp sampler.0.curr-depth)
  halsampler -n "$n"
}

check() { /usr/bin/python3 "$CIRCLOG_TESTS/check_trace.py" "$@"; }

# The end of an overrun test, once the recorder has stopped: the sampler's count of enabled
# periods and the overrun pin read before HAL stops, then check_trace.py's overrun checks and
# whether stderr names the gaps and the loss.
finish_overrun_test() {
  local enabled pin
  enabled=$(halcmd getp sampler.0.curr-depth)
  pin=$(halcmd getp circlog.0.overruns)
  hal_stop
  cat recorder.err >&2
  check overruns trace.csv "$pin" "$recorder_rc" "$enabled"
  echo "stderr names the gaps: $(grep -q 'gap: [0-9]* record(s) lost before period' recorder.err && echo yes || echo NO)"
  echo "stderr reports the loss: $(grep -q 'error: [0-9]* sample(s) lost' recorder.err && echo yes || echo NO)"
}
