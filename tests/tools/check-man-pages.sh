#!/bin/bash
# The man pages (docs/man) and the markdown docs describe the programs as they are: every
# option a program's --help lists is in its man page and in its markdown doc, every option a
# man page or an option table describes is one --help lists, every circana command is in
# circana(1) and docs/circana.md, every pin the
# circlog HAL adapter creates is in circlog(9) and docs/circlog.md, every pin and loadrt
# parameter of circtest_kins is in circtest_kins(9) (its pins also in docs/kinematics.md), every
# pin and loadrt parameter of circfric is in circfric(9) and docs/circfric.md, and each page
# renders without a groff warning.
#   check-man-pages.sh SOURCE_DIR CIRCGEN CIRCANA CIRCLOG_RECORD CIRCCOMP
set -u  # no pipefail: grep -q may close a pipe early
src=$1 circgen=$2 circana=$3 recorder=$4 circcomp=$5 circtest=$6
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# A man page's text with groff's escaped hyphens made plain.
plain() { sed -e 's/\\-/-/g' -e 's/\\f[BIRP]//g' "$1"; }

# Options of a --help text (boost::program_options layout: "  --name arg  text" or
# "  -o [ --name ] arg  text"), one "name short" line each (short may be empty).
options_of() { sed -n 's/^  \(-\([a-z]\) \[ \)\{0,1\}--\([a-z][a-z0-9-]*\).*/\3 \2/p'; }

# The tag lines of a man page's entries (the line after .TP or .TQ), hyphens plain; the first
# cells of the markdown option tables' rows.
documented_in_page() { awk '/^\.T[PQ]/ { getline; print }' "$1" | sed 's/\\-/-/g'; }
documented_in_tables() { sed -n 's/^| \(`-[^|]*\)|.*/\1/p' "$@"; }

# check_options WHAT HELP_TEXT MAN_PAGE DOC...: each option has an entry in the man page by its
# long name, and is in one of the markdown docs by its long name or its short one (in the
# option table when the one doc has one).
check_options() {
  local what=$1 help=$2 page=$3 opt short n=0
  shift 3
  while read -r opt short; do
    n=$((n + 1))
    documented_in_page "$src/docs/man/$page" | grep -qe "--$opt\b" ||
      fail "$what: --$opt has no entry (.TP) in docs/man/$page"
    case $opt in help | version | trace | points | input) continue ;; esac  # positional or generic
    local pattern="--$opt\b"
    [ -z "$short" ] || pattern="$pattern|(^|[ \`])-$short\b"
    cat "$@" | grep -qEe "$pattern" || fail "$what: --$opt is not in ${*#"$src"/}"
    # A program's own page with an option table (circgen.md, circlog.md): a row of its own.
    if [ $# = 1 ] && [ -n "$(documented_in_tables "$1")" ]; then
      documented_in_tables "$1" | grep -qEe "$pattern" ||
        fail "$what: --$opt has no row in the option table of ${1#"$src"/}"
    fi
  done < <(options_of <<<"$help")
  [ $n -gt 2 ] || fail "$what: --help lists no options"
  echo "ok: $what: $n options in docs/man/$page and the docs"
}

# The reverse: every option a man page describes (the tag line after .TP or .TQ) and every
# option a markdown option table names (first cell of a row) is one the program's --help lists,
# so a removed or renamed option cannot stay documented.
#   check_documented_options WHAT KNOWN MAN_PAGE [DOC...]   (KNOWN: the options, one a line)
check_documented_options() {
  local what=$1 known=$2 page=$3 opt n=0
  shift 3
  for opt in $(documented_in_page "$src/docs/man/$page" | grep -oE -- '--[a-z][a-z0-9-]*' | sort -u); do
    n=$((n + 1))
    grep -qxF -- "$opt" <<<"$known" || fail "$what: docs/man/$page describes $opt, which --help does not list"
  done
  [ $n -gt 2 ] || fail "$what: docs/man/$page describes no options"
  [ $# = 0 ] && return
  for opt in $(documented_in_tables "$@" | grep -oE -- '--[a-z][a-z0-9-]*' | sort -u); do
    grep -qxF -- "$opt" <<<"$known" || fail "$what: ${*#"$src"/} lists $opt, which --help does not list"
  done
}
long_options() { options_of | sed 's/^\([^ ]*\).*/--\1/'; }

check_options circgen "$("$circgen" --help)" circgen.1 "$src/docs/circgen.md"
check_documented_options circgen "$("$circgen" --help | long_options)" circgen.1 "$src/docs/circgen.md"
check_options circlog-record "$("$recorder" --help)" circlog-record.1 "$src/docs/circlog.md"
check_documented_options circlog-record "$("$recorder" --help | long_options)" circlog-record.1 \
  "$src/docs/circlog.md"
commands=$("$circana" --help | sed -n 's/^.*circana \([a-z][a-z-]*\).*/\1/p' | sort -u)
[ "$(wc -w <<<"$commands")" -gt 5 ] || fail "circana --help lists too few commands: $commands"
circana_known=$'--help\n--version'  # generic: tools.cli_info runs both
for c in $commands; do
  check_options "circana $c" "$("$circana" "$c" --help)" circana.1 "$src/README.md" "$src"/docs/*.md
  circana_known=$circana_known$'\n'$("$circana" "$c" --help | long_options)
  plain "$src/docs/man/circana.1" | grep -qE "circana $c\b" || fail "circana: command $c is not in docs/man/circana.1"
  grep -qE "circana $c\b" "$src/docs/circana.md" || fail "circana: command $c is not in docs/circana.md"
done
check_documented_options circana "$circana_known" circana.1
# Each command circana.1 names (.B circana COMMAND in the synopsis) is one circana has.
for c in $(plain "$src/docs/man/circana.1" | sed -n 's/^\.B circana \([a-z][a-z-]*\).*/\1/p' | sort -u); do
  grep -qxF "$c" <<<"$commands" || fail "circana: docs/man/circana.1 names command $c, which circana --help does not list"
done

# circcomp's --help is a usage text: every --option in it.
n=0
for opt in $("$circcomp" --help | grep -o -- '--[a-z][a-z-]*' | sort -u) --version; do
  n=$((n + 1))
  documented_in_page "$src/docs/man/circcomp.1" | grep -qe "$opt\b" ||
    fail "circcomp: $opt has no entry (.TP) in docs/man/circcomp.1"
  [ "$opt" = --version ] || grep -qe "$opt\b" "$src/docs/compensation.md" ||
    fail "circcomp: $opt is not in docs/compensation.md"
done
check_documented_options circcomp "$("$circcomp" --help | grep -o -- '--[a-z][a-z-]*' | sort -u; echo --help; echo --version)" \
  circcomp.1
echo "ok: circcomp: $n options in docs/man/circcomp.1 and docs/compensation.md"
circtest_known=$("$circtest" --help 2>&1 | grep -o -- '--[a-z][a-z-]*' | sort -u; echo --help; echo --version)
check_documented_options circtest "$circtest_known" circtest.1
for opt in $(grep -vxF -e --help -e --version <<<"$circtest_known"); do
  plain "$src/docs/man/circtest.1" | grep -qF -- "$opt" || fail "circtest(1) does not describe $opt"
done
echo "ok: circtest: its options in docs/man/circtest.1"

pins=$(grep -o '"circlog\.0\.[a-z-]*' "$src/hal-component/circlog/circlog_hal.cpp" | tr -d '"' | sort -u)
[ -n "$pins" ] || fail "no pin names found in hal-component/circlog/circlog_hal.cpp"
for pin in $pins; do
  name=${pin%-}  # "circlog.0.in-%02d" -> circlog.0.in
  plain "$src/docs/man/circlog.9" | grep -qF "$name" || fail "circlog(9) does not name $name"
  grep -qF "${name#circlog.0.}" "$src/docs/circlog.md" || fail "docs/circlog.md does not name $name"
done
echo "ok: circlog: $(wc -w <<<"$pins") pins and parameters in circlog(9) and docs/circlog.md"

# check_documented PAGE DOC NAME...: each NAME is in docs/man/PAGE and, unless DOC is -, in
# the markdown doc DOC, as a whole name (a pin not only as the start of a longer one).
check_documented() {
  local page=$1 doc=$2 name pattern
  shift 2
  for name in "$@"; do
    pattern=${name//./\\.}
    [ "${name: -1}" = "=" ] || pattern="$pattern([^a-z-]|\$)"
    plain "$src/docs/man/$page" | grep -qE -- "$pattern" || fail "${page%.*}(${page##*.}) does not name $name"
    [ "$doc" = - ] || grep -qE -- "$pattern" "$src/$doc" || fail "$doc does not name $name"
  done
}
# The loadrt parameters (RTAPI_MP_*) of a module's adapter, as NAME=.
loadrt_params() { grep -o 'RTAPI_MP_[A-Z_]*([a-z_]*' "$1" | sed -e 's/.*(//' -e 's/$/=/'; }

kins_src=$src/hal-component/circtest_kins/circtest_kins_hal.cpp
kins_pins=$(grep -o '"circtest-kins\.[a-z-]*"' "$kins_src" | tr -d '"' | sort -u)
[ -n "$kins_pins" ] || fail "no pin names found in $kins_src"
check_documented circtest_kins.9 docs/kinematics.md $kins_pins
check_documented circtest_kins.9 - $(loadrt_params "$kins_src")
echo "ok: circtest_kins: $(wc -w <<<"$kins_pins") pins in circtest_kins(9) and docs/kinematics.md"

# circfric's pins are "%s.SUFFIX" (the instance name first): each as circfric.N.SUFFIX.
fric_src=$src/hal-component/circfric/circfric_hal.cpp
fric_pins=$( (grep -o '"%s\.[a-z-]*"' "$fric_src"; grep -o 'name, "[a-z-]*"' "$fric_src") |
  sed -e 's/.*"%s\./circfric.N./' -e 's/name, "/circfric.N./' -e 's/"$//' | sort -u)
[ "$(wc -w <<<"$fric_pins")" -ge 10 ] || fail "too few pin names found in $fric_src: $fric_pins"
check_documented circfric.9 docs/circfric.md $fric_pins $(loadrt_params "$fric_src")
echo "ok: circfric: $(wc -w <<<"$fric_pins") pins in circfric(9) and docs/circfric.md"

# Every option the README names is one of a program's (the README shows a few, the man pages
# all of them).
all_known=$(
  "$circgen" --help | long_options
  "$recorder" --help | long_options
  echo "$circana_known"
  "$circcomp" --help | grep -o -- '--[a-z][a-z-]*'
  echo "$circtest_known"
)
n=0
for opt in $(grep -oE -- '--[a-z][a-z0-9-]*' "$src/README.md" | sort -u); do
  n=$((n + 1))
  grep -qxF -- "$opt" <<<"$all_known" || fail "README.md names $opt, which no program's --help lists"
done
[ $n -gt 5 ] || fail "README.md names too few options ($n)"

for page in "$src"/docs/man/*.[19]; do
  warnings=$(groff -man -Tutf8 -ww -z "$page" 2>&1)
  [ -z "$warnings" ] || fail "$(basename "$page"): groff warns: $warnings"
done

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
