#!/usr/bin/env bash
# Writes `circana analyze --json` and `circana diagnose --json` of the speed work's check set
# into OUT_DIR: the 1e6-row bench trace (CSV and .ctb, as bench/analyze-cli.sh makes them),
# four simulated traces (ZX 220 deg, YZ with a reversal spike, a ball bar's radial column,
# cyclic error) and the 8 TraCIM reference files. Run it with the build before and after a
# change, then compare the two directories with build/bench/compare_results (every string
# identical, every number within the tolerance; it prints the largest difference).
# usage: bench/results-unchanged.sh BUILD_DIR OUT_DIR
set -euo pipefail
build=$1
out=$2
here=$(cd "$(dirname "$0")/.." && pwd)
work=${TMPDIR:-/tmp}/circtest-bench
mkdir -p "$work" "$out"
sim=(--backlash-x 0.02 --squareness 100e-6 --kv-x 30 --kv-y 33 --noise 0.0002 --period 0.0000664)
simtrace=$build/tests/support/circtest-simtrace
[ -f "$work/trace-1e6.csv" ] || "$simtrace" -o "$work/trace-1e6.csv" "${sim[@]}"
[ -f "$work/trace-1e6.ctb" ] || "$simtrace" -o "$work/trace-1e6.ctb" "${sim[@]}"
[ -f "$work/zx-220.csv" ] || "$simtrace" -o "$work/zx-220.csv" --plane ZX --arc 220 --backlash-x 0.01 --noise 0.0003
[ -f "$work/yz-spike.csv" ] || "$simtrace" -o "$work/yz-spike.csv" --plane YZ --spike-x 0.006 --spike-ms-x 25 --kv-y 28 --noise 0.0002
[ -f "$work/radial.csv" ] || "$simtrace" -o "$work/radial.csv" --radial --bar-length 150 --backlash-y 0.008 --noise 0.0002
[ -f "$work/cyclic.csv" ] || "$simtrace" -o "$work/cyclic.csv" --cyclic-x 0.003 --pitch-x 10 --scale-y 50e-6 --noise 0.0001
files=("$work/trace-1e6.csv" "$work/trace-1e6.ctb" "$work/zx-220.csv" "$work/yz-spike.csv"
       "$work/radial.csv" "$work/cyclic.csv")
for f in "$here"/../shared/reference/tracim-circle-2d/C*.csv /work/shared/reference/tracim-circle-2d/C*.csv; do
  [ -f "$f" ] && files+=("$f")
done
for f in "${files[@]}"; do
  name=$(basename "$f")
  for cmd in analyze diagnose; do
    # A refusal is a result too: its message and exit code are compared.
    rc=0
    "$build/analysis/circana" "$cmd" "$f" --json >"$out/$name.$cmd.json" 2>"$out/$name.$cmd.err" || rc=$?
    echo "$rc" >"$out/$name.$cmd.rc"
  done
done
echo "wrote $(ls "$out" | wc -l) files to $out"
