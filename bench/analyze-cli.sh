#!/usr/bin/env bash
# Times `circana analyze --json` on a 1e6-sample CCW+CW trace against merely parsing every
# number of the same file with std::from_chars, and measures circana's peak memory.
# usage: bench/analyze-cli.sh [BUILD_DIR]      (Release build; needs /usr/bin/time)
set -euo pipefail
build=${1:-build}
work=${TMPDIR:-/tmp}/circtest-bench
mkdir -p "$work"
trace=$work/trace-1e6.csv
if [ ! -f "$trace" ]; then
  # D150 F1000, 2 x (360 + 2 x 30 deg lead) and dwells: a period of 66.4 us gives ~1e6 rows.
  "$build/tests/support/circtest-simtrace" -o "$trace" --backlash-x 0.02 --squareness 100e-6 \
    --kv-x 30 --kv-y 33 --noise 0.0002 --period 0.0000664
fi
rows=$(($(grep -vc '^#' "$trace") - 1))
size=$(du -m "$trace" | cut -f1)
echo "trace: $trace, $rows rows, $size MB"
"$build/bench/parse_baseline" "$trace" 5
# Best of 5 wall times of circana on a file, then one run under /usr/bin/time for peak RSS.
time_circana() {
  local file=$1 label=$2 best=999 s e
  for i in 1 2 3 4 5; do
    s=$(date +%s.%N)
    "$build/analysis/circana" analyze "$file" --json >/dev/null
    e=$(date +%s.%N)
    best=$(awk -v s="$s" -v e="$e" -v b="$best" 'BEGIN { t = e - s; print (t < b ? t : b) }')
  done
  printf 'circana analyze --json%s: best of 5: %.3f s\n' "$label" "$best"
  /usr/bin/time -f "circana analyze --json$label: peak RSS %M KiB, %e s" \
    "$build/analysis/circana" analyze "$file" --json >/dev/null
}
time_circana "$trace" ""

# The same trace in the binary form (docs/trace-format.md).
binary=$work/trace-1e6.ctb
if [ ! -f "$binary" ]; then
  "$build/tests/support/circtest-simtrace" -o "$binary" --backlash-x 0.02 --squareness 100e-6 \
    --kv-x 30 --kv-y 33 --noise 0.0002 --period 0.0000664
fi
echo "binary: $binary, $(du -m "$binary" | cut -f1) MB"
time_circana "$binary" " (binary)"
