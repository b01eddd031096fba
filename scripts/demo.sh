#!/usr/bin/env bash
# The README's main command: install, build, then the closed loop on the simulated LinuxCNC
# mill (configs/sim-mill, copied to ./out/machine so the repository's copy never changes):
#   measure  circgen writes the D150 F1000 program, circtest-run runs it headless while
#            circlog logs the servo thread, circana evaluates the instrument (table) channels;
#   diagnose circana diagnose splits H and G into backlash, scale, squareness, servo ...;
#   plan     circcomp plan shows the diff of what it would write;
#   apply    circcomp apply writes it (BACKLASH / COMP_FILE, circtest_kins for squareness);
#   measure  the same program again on the compensated machine, diagnose again;
# then prints H, G, F and the diagnosis before and after side by side. Everything lands in
# ./out/ (or $1). Run as root.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
bin=$(cd "$BUILD_DIR" && pwd)
out=${1:-out}
mkdir -p "$out"
out=$(cd "$out" && pwd)
circana=$bin/analysis/circana circcomp=$bin/compensation/circcomp ini_tool=$bin/core/circtest-ini
# circcomp apply checks that the realtime modules a plan loads are where the run loads them:
# circtest-run takes them from this build tree, not from an installed package.
export CIRCTEST_KINS_MODULE=$bin/hal-component/circtest_kins.so
export CIRCTEST_FRIC_MODULE=$bin/hal-component/circfric.so

# The machine: sim-mill's own errors (backlash on X, X out of square to Y, unequal
# position-loop gains) plus a scale error on X, in a copy that circcomp may change.
rm -rf "$out/machine"
cp -r configs/sim-mill "$out/machine"
ini=$out/machine/sim-mill.ini
"$ini_tool" set "$ini" SIM SCALE_X 50e-6
sim() { "$ini_tool" get "$ini" SIM "$1"; }

"$bin/gcode-gen/circgen" --d 150 --f 1000 --ini "$ini" -o "$out/test.ngc"

measure() {  # NAME: run the program, evaluate and diagnose
  local name=$1
  echo "circtest: running $out/test.ngc on the simulated mill ($name, about a minute)..."
  CIRCTEST_BIN=$bin configs/circtest-run --ini "$ini" --program "$out/test.ngc" \
    --out "$out/$name-run"
  cp "$out/$name-run/trace.csv" "$out/$name.csv"
  "$circana" analyze "$out/$name.csv" --json >"$out/$name.json"
  "$circana" analyze "$out/$name.csv" --svg "$out/$name.svg" --scale-um-per-div 5 \
    >"$out/$name-report.txt"
}

measure before
"$circana" diagnose "$out/before.csv" --json >"$out/diagnosis.json"
"$circana" diagnose "$out/before.csv" >"$out/diagnosis.txt"
"$circcomp" plan --ini "$ini" "$out/diagnosis.json" >"$out/plan.diff"
"$circcomp" apply --ini "$ini" "$out/diagnosis.json" >"$out/apply.txt"
measure after
"$circana" diagnose "$out/after.csv" --json >"$out/after-diagnosis.json"
"$circana" diagnose "$out/after.csv" >"$out/after-diagnosis.txt"
"$circana" analyze "$out/after.csv" --compare "$out/before.csv" --svg "$out/before-after.svg" \
  --scale-um-per-div 5 >/dev/null
# The report a service engineer hands over: after against before, with the remaining diagnosis.
"$circana" report "$out/after.csv" "$out/before.csv" -o "$out/report.html" --scale-um-per-div 5 \
  --diagnosis "$out/after-diagnosis.json" >/dev/null

cat "$out/before-report.txt"
echo
echo "circcomp plan (the whole diff is in $out/plan.diff):"
grep '^# ' "$out/plan.diff" || true
echo
python3 - "$out" <<'EOF'
import json, sys
out = sys.argv[1]
before, after = (json.load(open(f"{out}/{n}.json")) for n in ("before", "after"))
d0, d1 = (json.load(open(f"{out}/{n}.json")) for n in ("diagnosis", "after-diagnosis"))
def um(v): return "-" if v is None else f"{v * 1e3:8.2f}"
def num(v, f="{:8.2f}"): return "-" if v is None else f.format(v)
def geometric_g(d):  # the modelled G less the servo terms' shares
    g = d["model_G_mm"]
    for c in d["contributions"]:
        if c["source"] in ("servo mismatch", "radius change"):
            g -= c["share_mm"]
    return g
rows = [("H (um)", um(before["H"]), um(after["H"]))]
for i, (r0, r1) in enumerate(zip(before["runs"], after["runs"])):
    lab = r0["label"]
    rows += [(f"G {lab} (um)", um(r0["G"]), um(r1["G"])),
             (f"F {lab} max/min (um)", f"{um(r0['F_max']).strip()}/{um(r0['F_min']).strip()}",
              f"{um(r1['F_max']).strip()}/{um(r1['F_min']).strip()}")]
ax = d0["axes"]
for a in ax:
    rows.append((f"backlash {a} (um)", um(d0["backlash_mm"][a]), um(d1["backlash_mm"][a])))
for a in ax:
    rows.append((f"scale {a} (ppm)", num(d0["scale_ppm"][a]), num(d1["scale_ppm"][a])))
rows += [("scale mismatch (ppm)", num(d0["scale_mismatch_ppm"]), num(d1["scale_mismatch_ppm"])),
         ("squareness (urad)", num(d0["squareness_urad"]), num(d1["squareness_urad"])),
         ("servo mismatch (ms)", num(d0["servo_mismatch_ms"], "{:8.3f}"),
          num(d1["servo_mismatch_ms"], "{:8.3f}")),
         ("modelled G (um)", um(d0["model_G_mm"]), um(d1["model_G_mm"])),
         ("  without servo terms (um)", um(geometric_g(d0)), um(geometric_g(d1)))]
print(f"{'':28} {'before':>14} {'after':>14}")
for name, b, a in rows:
    print(f"{name:28} {b:>14} {a:>14}")
EOF

echo
echo "circtest: done. Files in $out/:"
echo "  test.ngc                   the ISO 230-4 test program (circgen --d 150 --f 1000)"
echo "  before.csv, after.csv      what circlog logged every servo period (commanded x_cmd,"
echo "                             motor x_fb and table x, the instrument), before and after"
echo "  before.json, after.json    H, G, F per direction in mm (circana analyze --json)"
echo "  before-report.txt, after-report.txt   the clause 6 reports"
echo "  before-after.svg           both tests in one plot at 5 um/div: before solid, after dashed"
echo "  before.svg, after.svg      each test alone, at the same scale"
echo "  report.html                the report to hand over (circana report): clause 6 header, H/G/F"
echo "                             before and after, both paths, the remaining diagnosis; prints A4"
echo "  diagnosis.json/.txt        circana diagnose of the first run (what circcomp reads)"
echo "  plan.diff                  circcomp plan: every file it changes or creates, and advice"
echo "  after-diagnosis.json/.txt  circana diagnose of the compensated machine"
echo "  machine/                   the compensated configuration (circcomp revert --ini"
echo "                             $ini undoes it)"
echo "The simulated machine has backlash $(sim BACKLASH_X) mm and scale $(sim SCALE_X) on X,"
echo "squareness $(sim SQUARENESS_XY) rad of X to Y, position-loop gains $(sim KV_X)/$(sim KV_Y) 1/s."
echo "circcomp writes backlash, scale and squareness; the gain mismatch stays (advice in plan.diff)."
