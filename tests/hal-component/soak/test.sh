# The soak (label soak; not in the default run): circlog at 10 kHz with 16 channels for
# CIRCLOG_SOAK_S seconds (default 600), recorded into a .ctb by circlog-record. Fails unless
# every sample is there: period counters consecutive from the first row to the last, rows =
# the servo periods of the recording, overruns, gaps and lost samples 0 in the trailer and on
# the circlog.0.overruns pin, recorder exit 0. Prints the figures for docs/performance.md.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
duration=${CIRCLOG_SOAK_S:-600}
hal_start "$TEST_DIR/test.hal"
cols=$(seq -f 'c%02g' 0 15 | paste -sd,)
start_recorder -o soak.ctb --columns "$cols" --duration "$duration"
rtapi=$(pgrep -x rtapi_app | head -1)
ticks() { awk '{ print $14 + $15 }' "/proc/$1/stat" 2>/dev/null || true; }
rtapi0=$(ticks "$rtapi")
: >times.txt
recorder_ticks=0
start_s=$(date +%s.%N)
while kill -0 "$recorder" 2>/dev/null; do
  halcmd getp circlog.0.time >>times.txt
  t=$(ticks "$recorder")
  [ -z "$t" ] || recorder_ticks=$t
  sleep 1
done
end_s=$(date +%s.%N)
wait_recorder
rtapi1=$(ticks "$rtapi")
pin_overruns=$(halcmd getp circlog.0.overruns)
tmax=$(halcmd getp circlog.0.tmax)
hal_stop
cat recorder.err
hz=$(getconf CLK_TCK)
echo "recorder exit code: $recorder_rc"
echo "circlog.0.overruns pin: $pin_overruns"
awk -v a="$start_s" -v b="$end_s" -v r="$recorder_ticks" -v x0="$rtapi0" -v x1="$rtapi1" \
  -v hz="$hz" 'BEGIN {
    wall = b - a
    printf "wall %.1f s; CPU: circlog-record %.1f s (%.1f %% of one core), rtapi_app (the 10 kHz thread) %.1f s (%.1f %%)\n",
           wall, r / hz, 100 * r / hz / wall, (x1 - x0) / hz, 100 * (x1 - x0) / hz / wall }'
mhz=$(awk -F: '/^cpu MHz/ { print $2; exit }' /proc/cpuinfo)
sort -n times.txt | awk -v tmax="$tmax" -v mhz="$mhz" '
  { t[NR] = $1 }
  END {
    printf "circlog.0.time: %d samples, median %d cycles, p99 %d, max %d; tmax %d cycles", NR,
           t[int(NR / 2) + 1], t[int(NR * 0.99) + 1], t[NR], tmax
    if (mhz > 0) printf " (median %.3f us, tmax %.3f us at %.0f MHz)", t[int(NR / 2) + 1] / mhz,
                        tmax / mhz, mhz
    printf "\n" }'
check soak soak.ctb "$pin_overruns" "$recorder_rc" "$duration"
