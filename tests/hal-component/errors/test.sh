# Clear errors (exit code 7, hal) when there is nothing to record, 2 for bad options; and a
# logger without a reader neither writes nor counts overruns.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"

# Prints the exit code and whether stderr contains the expected words.
try() {
  local label=$1 words=$2 rc=0
  shift 2
  "$@" 2>err.txt || rc=$?
  cat err.txt >&2
  echo "$label: exit $rc, says '$words': $(grep -qF -- "$words" err.txt && echo yes || echo NO)"
}

try "no realtime session" "circlog is not loaded (is LinuxCNC or halrun running?)" "$CIRCLOG_RECORDER" -o a.csv --duration 1

hal_start "$TEST_DIR/no-circlog.hal"
try "circlog not loaded" "circlog is not loaded" "$CIRCLOG_RECORDER" -o a.csv --duration 1
for args in "" "channels=0" "channels=17" "channels=2 depth=1"; do
  rc=0
  halcmd loadrt circlog $args 2>/dev/null || rc=$?
  echo "loadrt circlog $args: refused: $([ "$rc" != 0 ] && echo yes || echo NO)"
done
hal_stop

hal_start "$TEST_DIR/no-function.hal"
try "function not in a thread" "does not run" "$CIRCLOG_RECORDER" -o a.csv --duration 1
hal_stop

hal_start "$TEST_DIR/loaded.hal"
halcmd sets enable 1
sleep 0.3
echo "no reader: written=$(halcmd getp circlog.0.written) overruns=$(halcmd getp circlog.0.overruns)"
try "wrong column count" "names 3 channel(s) but circlog.0 has 2" \
  "$CIRCLOG_RECORDER" -o a.csv --columns x,y,z --duration 1
try "bad option" "--duration must be a number of seconds in (0, 604800]" "$CIRCLOG_RECORDER" -o a.csv --duration -1
"$CIRCLOG_RECORDER" -o first.csv 2>first.err &
first=$!
wait_for_value circlog.0.reading TRUE
try "second reader" "already being recorded by process $first" \
  "$CIRCLOG_RECORDER" -o second.csv --duration 1 | sed "s/process $first/process PID/"
echo "no partial file left by the refused reader: $([ -e second.csv ] || [ -e second.csv.part ] && echo NO || echo yes)"
kill -TERM "$first"
rc=0
wait "$first" || rc=$?
echo "SIGTERM: exit $rc, file complete: $(grep -q '^# stop_reason: signal' first.csv && echo yes || echo NO)"
echo "reading after the recorder left: $(halcmd getp circlog.0.reading)"
hal_stop
