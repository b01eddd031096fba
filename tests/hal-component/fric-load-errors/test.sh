# circfric refuses nonsense at load time (loadrt fails, says why on stderr, nothing stays
# loaded), and loads with count= or names= as LinuxCNC's pid does.
set -euo pipefail
source "$CIRCLOG_TESTS/lib.sh"
halrun -U >/dev/null 2>&1 || true
"$REALTIME" start >&2

loaded() { halcmd list comp | tr ' ' '\n' | grep -c '^circfric$' || true; }

# Prints whether loadrt with ARGS failed, said WORDS and left nothing loaded.
refuse() {
  local words=$1 rc=0
  shift
  halcmd loadrt circfric "$@" >err.txt 2>&1 || rc=$?
  cat err.txt >&2
  echo "loadrt circfric $*: refused: $([ "$rc" != 0 ] && echo yes || echo NO)," \
    "says '$words': $(grep -qF -- "$words" err.txt && echo yes || echo NO), loaded after: $(loaded)"
  halcmd unload circfric >/dev/null 2>&1 || true
}

refuse "count=0: give count=N with N in 1..8 (one instance per joint) or names=a,b,..."
refuse "count=0: give count=N with N in 1..8" count=0
refuse "count=9: give count=N with N in 1..8" count=9
refuse "count=-1: give count=N with N in 1..8" count=-1
refuse "give count= or names=, not both" count=2 names=x
refuse "'fric-x' is given twice" names=fric-x,fric-y,fric-x
refuse "'x/y' (name 1): a name is 1..33 characters of A-Z a-z 0-9 _ - ." names=x/y
refuse "'' (name 2): a name is 1..33 characters" names=a,,b
refuse "(name 1): a name is 1..33 characters" names=abcdefghijabcdefghijabcdefghijabcd
refuse "can only take 8 arguments" names=a,b,c,d,e,f,g,h,i
refuse "invalid for parameter" count=two

halcmd loadrt circfric count=8 >&2
echo "count=8: functions $(halcmd show funct | awk '$NF ~ /^circfric\./ { print $NF }' | tr '\n' ' ')"
halcmd unload circfric >&2
halcmd loadrt circfric names=fric-x,fric-y,abcdefghijabcdefghijabcdefghijabc >&2
echo "names=: functions $(halcmd show funct | awk 'NR > 2 && NF >= 6 { print $NF }' | tr '\n' ' ')"
echo "names=: pins of fric-x:"
halcmd show pin fric-x | awk 'NR > 2 && NF >= 5 { print "  " $2, $3, $4, $5 }'
echo "33-character name's longest pin: $(halcmd list pin | tr ' ' '\n' | grep -c '^abcdefghijabcdefghijabcdefghijabc\.amplitude-max$')"
halcmd unload circfric >&2
echo "left loaded: $(loaded)"
hal_stop
