#!/bin/bash
# The circlog soak benchmark (a figure for docs/circlog.md, not a ctest test): 8 siggen
# channels at 1 kHz into circlog at its default depth for DURATION seconds (default 600),
# recorded by circlog-record; reports lost samples, the ring's high-water mark, the HAL
# function time (.time sampled once a second, .tmax) and the ring's memory. Needs root
# (it runs HAL in private namespaces like the hal tests).
#   bench/circlog-soak.sh BUILD_DIR [DURATION_S]
set -euo pipefail
build=$(readlink -f "${1:?usage: $0 BUILD_DIR [DURATION_S]}")
duration=${2:-600}
src=$(cd "$(dirname "$0")/.." && pwd)
dir=$(mktemp -d /tmp/circlog-soak.XXXXXX)
trap 'rm -rf "$dir"' EXIT

cat >"$dir/test.hal" <<HAL
loadrt threads name1=servo period1=1000000
loadrt siggen num_chan=2
loadrt circlog channels=8
addf siggen.0.update servo
addf siggen.1.update servo
addf circlog.0 servo
setp siggen.0.amplitude 50
setp siggen.1.frequency 0.3
net c0 siggen.0.sine circlog.0.in-00
net c1 siggen.0.cosine circlog.0.in-01
net c2 siggen.0.triangle circlog.0.in-02
net c3 siggen.0.sawtooth circlog.0.in-03
net c4 siggen.1.sine circlog.0.in-04
net c5 siggen.1.cosine circlog.0.in-05
net c6 siggen.1.triangle circlog.0.in-06
net c7 siggen.1.sawtooth circlog.0.in-07
net enable circlog.0.enable
sets enable 1
start
HAL

cat >"$dir/test.sh" <<SH
set -euo pipefail
source "\$CIRCLOG_TESTS/lib.sh"
hal_start "\$TEST_DIR/test.hal"
start_recorder -o soak.csv --columns x_cmd,y_cmd,z_cmd,a,x,y,z,b --duration $duration
: >times.txt
while kill -0 \$recorder 2>/dev/null; do
  halcmd getp circlog.0.time >>times.txt
  sleep 1
done
wait_recorder
tmax=\$(halcmd getp circlog.0.tmax)
bytes=\$(ipcs -m | awk 'tolower(\$1) == "0x43434c00" { print \$5 }')
hal_stop
cat recorder.err
echo "recorder exit code: \$recorder_rc"
grep -E '^# (rows|overruns|gaps|lost_samples|ring_high_water|module.depth|sample_period_s|end_period|start_period):' soak.csv
mhz=\$(awk -F: '/^cpu MHz/ { print \$2; exit }' /proc/cpuinfo)
sort -n times.txt | awk -v tmax="\$tmax" -v mhz="\$mhz" '
  { t[NR] = \$1 }
  END {
    printf "circlog.0.time samples: %d, median %d cycles, p99 %d, max %d; tmax %d cycles\n",
           NR, t[int(NR / 2) + 1], t[int(NR * 0.99) + 1], t[NR], tmax
    if (mhz > 0) printf "  at %.0f MHz: median %.3f us, tmax %.3f us\n", mhz,
           t[int(NR / 2) + 1] / mhz, tmax / mhz
  }'
echo "ring shared memory: \$bytes bytes"
SH
"$src/tests/hal-component/run-hal-test.sh" "$dir" "$build/hal-component/circlog.so" \
  "$build/hal-component/circlog-record"
