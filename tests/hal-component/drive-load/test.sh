# circdrive refuses nonsense at load time (loadrt fails, says why on stderr, nothing stays
# loaded), loads with count=, and in a running thread holds the motor against stiction until
# the command beats the breakaway.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
halrun -U >/dev/null 2>&1 || true
"$REALTIME" start >&2

loaded() { halcmd list comp | tr ' ' '\n' | grep -c '^circdrive$' || true; }

# Prints whether loadrt with ARGS failed, said WORDS and left nothing loaded.
refuse() {
  local words=$1 rc=0
  shift
  halcmd loadrt circdrive "$@" >err.txt 2>&1 || rc=$?
  cat err.txt >&2
  echo "loadrt circdrive $*: refused: $([ "$rc" != 0 ] && echo yes || echo NO)," \
    "says '$words': $(grep -qF -- "$words" err.txt && echo yes || echo NO), loaded after: $(loaded)"
  halcmd unload circdrive >/dev/null 2>&1 || true
}

refuse "count=0: give count=N with N in 1..8 (one drive per joint)"
refuse "count=9: give count=N with N in 1..8" count=9
refuse "count=-1: give count=N with N in 1..8" count=-1
refuse "invalid for parameter" count=two

halcmd loadrt threads name1=servo-thread period1=1000000 >&2
halcmd loadrt circdrive count=3 >&2
echo "count=3: functions $(halcmd show funct | awk '$NF ~ /^circdrive\./ { print $NF }' | tr '\n' ' ')"
echo "pins of circdrive.0:"
halcmd show pin circdrive.0 | awk 'NR > 2 && NF >= 5 && $5 != "circdrive.0.time" { print "  " $2, $3, $5 }'
halcmd addf circdrive.0 servo-thread >&2
halcmd setp circdrive.0.enable 1
halcmd setp circdrive.0.coulomb 0.5
halcmd setp circdrive.0.breakaway 0.8
halcmd setp circdrive.0.vel-cmd 0.79
halcmd start
sleep 0.3
echo "command 0.79 below breakaway 0.8: pos $(halcmd getp circdrive.0.pos), stuck $(halcmd getp circdrive.0.stuck), breakaways $(halcmd getp circdrive.0.breakaways)"
halcmd setp circdrive.0.vel-cmd 2.0
wait_for_value circdrive.0.breakaways 1
sleep 0.3
/usr/bin/python3 - "$(halcmd getp circdrive.0.vel)" <<'PY'
import sys
v = float(sys.argv[1])
print(f"command 2.0: broke free, slides at 2.0 - coulomb 0.5: {'yes' if abs(v - 1.5) < 1e-6 else 'NO'}")
PY
halcmd setp circdrive.0.tau nan
sleep 0.05
echo "tau nan: rejected $(halcmd getp circdrive.0.rejected)"
halcmd stop
halcmd unload all >&2
echo "left loaded: $(loaded)"
hal_stop
