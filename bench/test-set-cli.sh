#!/usr/bin/env bash
# Times circana on a test set (issue 25, item 6): three planes (XY, YZ, ZX) x two feeds
# (F500, F1000), CCW and CW, D100, logged at 1 kHz: `circana analyze --json` and
# `circana diagnose --json` on the set's trace, text and binary, best of ROUNDS wall times
# (bash's `time`, 1 ms resolution), the CPU time (user + sys) of the same best round, and the
# peak memory. The target: each under 1 s wall. On a busy machine (the load average is
# printed) the wall time includes waiting for a core; the CPU time does not.
# usage: bench/test-set-cli.sh [BUILD_DIR] [ROUNDS]   (Release build; needs /usr/bin/time)
set -euo pipefail
build=${1:-build}
rounds=${2:-5}
work=${TMPDIR:-/tmp}/circtest-bench
mkdir -p "$work"
# The simulated mill's errors in all three planes, per axis and per plane.
sim=(--set XY,YZ,ZX --feeds 500,1000 --d 100 --period 0.001
     --kv-x 30 --kv-y 31 --kv-z 30 --backlash-x 0.010 --backlash-y 0.006 --backlash-z 0.008
     --scale-x 40e-6 --scale-y -30e-6 --scale-z 25e-6
     --squareness-xy 100e-6 --squareness-yz -60e-6 --squareness-zx 45e-6 --noise 0.0005)
for ext in csv ctb; do
  [ -f "$work/test-set.$ext" ] || "$build/tests/support/circtest-simtrace" -o "$work/test-set.$ext" "${sim[@]}"
done

timed() {
  local TIMEFORMAT='%3R %3U %3S'
  { time "$@" >/dev/null 2>&1; } 2>&1
}
min() { awk -v a="$1" -v b="$2" 'BEGIN { print (a < b ? a : b) }'; }

status=0
for ext in csv ctb; do
  file="$work/test-set.$ext"
  rows=$(grep -c '^[0-9-]' "$work/test-set.csv")
  printf '%s: %s rows, %s MB\n' "$file" "$rows" "$(du -m "$file" | cut -f1)"
  for cmd in analyze diagnose; do
    "$build/analysis/circana" "$cmd" "$file" --json >/dev/null  # refuses now, not in the rounds
    best=999
    cpu=999
    for _ in $(seq "$rounds"); do
      t=$(timed "$build/analysis/circana" "$cmd" "$file" --json)
      best=$(min "$best" "$(cut -d' ' -f1 <<<"$t")")
      cpu=$(min "$cpu" "$(awk '{ print $2 + $3 }' <<<"$t")")
    done
    rss=$( { /usr/bin/time -f '%M' "$build/analysis/circana" "$cmd" "$file" --json >/dev/null; } 2>&1 | tail -1)
    verdict=$(awk -v t="$best" 'BEGIN { print (t < 1.0 ? "under 1 s" : "OVER 1 s") }')
    [ "$verdict" = "under 1 s" ] || status=1
    printf '  circana %-8s --json: %.3f s wall, %.3f s CPU (best of %s), peak RSS %d MiB: %s\n' \
      "$cmd" "$best" "$cpu" "$rounds" $((rss / 1024)) "$verdict"
  done
done
printf 'load average: %s\n' "$(cut -d' ' -f1-3 /proc/loadavg)"
exit $status
