#!/usr/bin/env bash
# The README's main command: install, build, then run the whole circular test on the
# simulated LinuxCNC mill (configs/sim-mill, default [SIM] errors: backlash on X, squareness
# of X to Y, a position-loop gain mismatch): circgen writes the D150 F1000 program,
# circtest-run runs it headless while circlog logs the servo thread, circana evaluates the
# instrument (table) channels. Everything lands in ./out/ (or $1). Run as root.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
out=${1:-out}
mkdir -p "$out"
out=$(cd "$out" && pwd)
ini=configs/sim-mill/sim-mill.ini

"$BUILD_DIR/gcode-gen/circgen" --d 150 --f 1000 --ini "$ini" -o "$out/test.ngc"
echo "circtest: running $out/test.ngc on the simulated mill (about a minute)..."
CIRCTEST_BIN=$(cd "$BUILD_DIR" && pwd) configs/circtest-run --ini "$ini" --program "$out/test.ngc" \
  --out "$out/run"
cp "$out/run/trace.csv" "$out/trace.csv"
"$BUILD_DIR/analysis/circana" analyze "$out/trace.csv" --json >"$out/result.json"
"$BUILD_DIR/analysis/circana" analyze "$out/trace.csv" --svg "$out/plot.svg" >"$out/report.txt"
"$BUILD_DIR/analysis/circana" analyze "$out/trace.csv" --columns x_fb,y_fb >"$out/report-motor.txt"
cat "$out/report.txt"

sim() { "$BUILD_DIR/core/circtest-ini" get "$ini" SIM "$1"; }
echo
echo "circtest: done. Files in $out/:"
echo "  test.ngc          the ISO 230-4 test program (circgen --d 150 --f 1000)"
echo "  trace.csv         what circlog logged every servo period: commanded (x_cmd), motor"
echo "                    encoder (x_fb) and table (x, the instrument) positions"
echo "  result.json       H, G, F per direction in mm (circana analyze --json)"
echo "  report.txt        the clause 6 report above, from the instrument (table) channels"
echo "  plot.svg          the actual paths of both runs, deviations magnified (open in a browser)"
echo "  report-motor.txt  the same from the motor encoders, which cannot see play or squareness"
echo "  run/              the LinuxCNC configuration as run and its log"
echo "The simulated machine has backlash $(sim BACKLASH_X) mm on X, squareness $(sim SQUARENESS_XY) rad"
echo "of X to Y and position-loop gains $(sim KV_X)/$(sim KV_Y) 1/s: H shows the play, G the"
echo "ellipse of squareness and gain mismatch (tilted the other way in each direction)."
