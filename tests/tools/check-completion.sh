#!/bin/bash
# The bash completion (packaging/bash-completion/circtest.bash) completes options from the
# programs' own --help, circana's commands and the values of the enumerated options.
#   check-completion.sh COMPLETION_FILE BIN_DIR...   (BIN_DIRs hold circgen, circana, circlog-record)
set -u
file=$1
shift
for d in "$@"; do PATH=$d:$PATH; done
# shellcheck disable=SC1091
source /usr/share/bash-completion/bash_completion
# shellcheck disable=SC1090
source "$file"
failures=0

# expect "WORDS..." WANTED: completing the last word of WORDS offers WANTED (and maybe more).
expect() {
  local line=$1 want=$2
  read -ra COMP_WORDS <<<"$line"
  [[ $line == *" " ]] && COMP_WORDS+=("")
  COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
  COMP_LINE=$line COMP_POINT=${#line}
  COMPREPLY=()
  _circtest
  if printf '%s\n' "${COMPREPLY[@]}" | grep -qxF -- "$want"; then
    echo "ok: '$line' -> $want"
  else
    echo "FAIL: '$line' offers '${COMPREPLY[*]}', not $want"
    failures=$((failures + 1))
  fi
}

expect "circgen --ins" --instrument
expect "circgen --instrument b" ballbar
expect "circgen --plane " ZX
expect "circana a" analyze
expect "circana analyze --g-" --g-method
expect "circana analyze --f-centre n" nominal
expect "circana fit --js" --json
expect "circlog-record --until" --until-idle
[ "$failures" = 0 ] || exit 1
