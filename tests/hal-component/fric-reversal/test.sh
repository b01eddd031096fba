# circfric alone in a real halrun: a sine velocity command through reversals; the pulses'
# timing, shape, sign, bound and the enable pin checked period by period on what LinuxCNC's
# sampler recorded, and runtime nonsense (setp) rejected without output.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
hal_start "$TEST_DIR/test.hal"

sleep 0.3
halcmd sets fric-want 1
halcmd sets sampling 1
sleep 2.4
# Switched off in the first pulse after this (test.hal: fric-arm), so that a pulse is running.
count=$(halcmd getp circfric.0.reversals)
halcmd sets fric-arm 1
wait_for_value circfric.0.reversals $((count + 2))
sleep 1.2
halcmd sets sampling 0
dump_sampler >samples.txt
echo "sampler overruns: $(halcmd getp sampler.0.overruns)"
/usr/bin/python3 "$TEST_DIR/check.py" samples.txt

# Runtime nonsense: flagged in .rejected (bits), the output 0, nothing propagated.
nonsense() {
  local pin=$1 value=$2 want=$3 good
  good=$(halcmd getp "circfric.1.$pin")
  halcmd setp "circfric.1.$pin" "$value"
  wait_for_value circfric.1.rejected "$want"
  echo "setp $pin $value: rejected $(halcmd getp circfric.1.rejected)," \
    "offset $(halcmd getp circfric.1.offset), active $(halcmd getp circfric.1.active)"
  halcmd setp "circfric.1.$pin" "$good"
  wait_for_value circfric.1.rejected 0
}
nonsense amplitude nan 1
nonsense amplitude -0.1 1
nonsense amplitude-max inf 2
nonsense decay-ms 0 4
nonsense decay-ms -20 4
nonsense vel-threshold -1 8
nonsense min-travel nan 16
nonsense rise-ms -1 128
nonsense rise-ms 48 128
halcmd unlinkp circfric.1.vel-cmd
halcmd setp circfric.1.vel-cmd nan
wait_for_value circfric.1.rejected 32 || true
echo "vel-cmd nan: rejected $(halcmd getp circfric.1.rejected), offset $(halcmd getp circfric.1.offset)"
hal_stop
