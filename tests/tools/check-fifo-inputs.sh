#!/usr/bin/env bash
# Every program refuses a FIFO named as an input, unopened: exit code 3 (io) and
# "FILE: is a FIFO, not a regular file" (circgen: "is a FIFO, expected a regular INI file"
# or "... parameter file"; circtest-ini: "not a regular file"), within 20 s even
# though no writer ever opens the FIFO (opening it for reading would wait for one).
# usage: check-fifo-inputs.sh SOURCE_DIR CIRCGEN CIRCANA CIRCCOMP CIRCLOG_RECORD CIRCTEST_INI
set -u
src=$1 circgen=$2 circana=$3 circcomp=$4 recorder=$5 ini_tool=$6
dir=$(mktemp -d "${TMPDIR:-/tmp}/circtest-fifo.XXXXXX")
trap 'rm -rf "$dir"' EXIT
failures=0

# CASE: NAME, the text stderr must hold, then the command.
check() {
  local name=$1 expected=$2
  shift 2
  timeout 20 "$@" </dev/null >"$dir/out" 2>"$dir/err"
  local code=$?
  if [ "$code" -eq 124 ]; then
    echo "FAIL $name: still waiting after 20 s (the FIFO was opened)"
    failures=$((failures + 1))
  elif [ "$code" -ne 3 ] || ! grep -qF -- "$expected" "$dir/err"; then
    echo "FAIL $name: exit $code (expected 3), stderr:"
    sed 's/^/  /' "$dir/err"
    failures=$((failures + 1))
  else
    echo "ok $name: $(head -n1 "$dir/err")"
  fi
}

mkfifo "$dir/fifo"
# A machine configuration whose parameter file is a FIFO.
mkdir "$dir/mill"
cp "$src"/configs/sim-mill/* "$dir/mill/"
mkfifo "$dir/mill/sim-mill.var"

check "circgen --ini FIFO" "$dir/fifo: is a FIFO, expected a regular INI file" \
  "$circgen" --d 100 --f 500 --ini "$dir/fifo" -o "$dir/t.ngc"
check "circgen, the INI's PARAMETER_FILE a FIFO" \
  "$dir/mill/sim-mill.var: is a FIFO, expected a regular parameter file" \
  "$circgen" --d 100 --f 500 --ini "$dir/mill/sim-mill.ini" -o "$dir/t.ngc"
check "circana analyze FIFO" "$dir/fifo: is a FIFO, not a regular file" \
  "$circana" analyze "$dir/fifo"
check "circcomp plan --ini INI FIFO" "$dir/fifo: is a FIFO, not a regular file" \
  "$circcomp" plan --ini "$dir/mill/sim-mill.ini" "$dir/fifo"
check "circlog-record --program FIFO" "$dir/fifo: is a FIFO, not a regular file" \
  "$recorder" -o "$dir/t.csv" --program "$dir/fifo"
check "circtest-ini get FIFO" "$dir/fifo: not a regular file" \
  "$ini_tool" get "$dir/fifo" EMC MACHINE

[ "$failures" -eq 0 ] || { echo "$failures case(s) failed"; exit 1; }
