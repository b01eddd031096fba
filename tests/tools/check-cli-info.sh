#!/bin/bash
# Every circtest command answers --help (exit 0, usage on stdout, nothing on stderr) and
# --version ("<program> <version>", the version CMake's project() declares).
#   check-cli-info.sh VERSION CIRCGEN CIRCANA CIRCLOG_RECORD CIRCTEST_RUN CIRCTEST_INI [CIRCCOMP]
# circana's commands are taken from its own usage text, so a new one is checked too.
set -uo pipefail
version=$1
declare -A exe=([circgen]=$2 [circana]=$3 [circlog-record]=$4 [circtest-run]=$5 [circtest-ini]=$6 [circcomp]=${7:-})
failures=0
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# check NAME ARGS...: NAME is the program name --version must print.
check() {
  local name=$1 rc
  shift
  local cmd=("${exe[$name]}" "$@")
  rc=0
  "${cmd[@]}" --version >"$tmp/out" 2>"$tmp/err" || rc=$?
  [ "$rc" = 0 ] || fail "${name} $* --version: exit $rc"
  [ -s "$tmp/err" ] && fail "${name} $* --version: wrote to stderr: $(head -1 "$tmp/err")"
  [ "$(cat "$tmp/out")" = "$name $version" ] ||
    fail "${name} $* --version: printed '$(head -1 "$tmp/out")', expected '$name $version'"
  rc=0
  "${cmd[@]}" --help >"$tmp/out" 2>"$tmp/err" || rc=$?
  [ "$rc" = 0 ] || fail "${name} $* --help: exit $rc"
  [ -s "$tmp/err" ] && fail "${name} $* --help: wrote to stderr: $(head -1 "$tmp/err")"
  grep -qi usage "$tmp/out" || fail "${name} $* --help: no usage on stdout"
  echo "ok: ${name}${*:+ $*}"
}

check circgen
check circlog-record
check circtest-run
check circtest-ini
[ -z "${exe[circcomp]}" ] || check circcomp
check circana
commands=$("${exe[circana]}" --help | sed -n 's/^.*circana \([a-z][a-z-]*\).*/\1/p' | sort -u)
[ -n "$commands" ] || fail "circana --help names no command"
for c in $commands; do check circana "$c"; done

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
