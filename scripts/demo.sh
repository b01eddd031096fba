#!/usr/bin/env bash
# The README's main command: set up, build, then evaluate the bundled example trace (a
# simulated D150 F1000 test with backlash, squareness and a gain mismatch) and print the
# clause 6 report. Outputs go to ./out/ (or $1).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
out=${1:-out}
mkdir -p "$out"
trace=examples/sim-d150-f1000.csv
cp "$trace" "$out/trace.csv"
"$BUILD_DIR/analysis/circana" analyze "$out/trace.csv" --json >"$out/result.json"
"$BUILD_DIR/analysis/circana" analyze "$out/trace.csv" | tee "$out/report.txt"
echo
echo "circtest: the trace, its JSON result and the report are in $(cd "$out" && pwd)/"
echo "  trace.csv   the example trace (CCW then CW, D150 F1000, simulated errors)"
echo "  result.json H, G and F per direction (mm), as circana analyze --json prints them"
echo "  report.txt  the ISO 230-4 clause 6 report shown above"
