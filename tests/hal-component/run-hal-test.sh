#!/bin/bash
# Runs one circlog HAL test (a directory with test.sh and expected) against the module in the
# build tree, without installing anything (without `expected`, prints test.sh's output):
#   run-hal-test.sh TEST_DIR MODULE.so RECORDER [MORE_MODULE.so]...
# As root it re-runs itself through scripts/hal-sandbox (private mount, IPC, PID and network
# namespaces; the build's circlog.so beside the system modules; realtime as `nobody`; every
# process killed when the test ends), so a LinuxCNC running elsewhere on the machine is
# neither seen nor disturbed and no rtapi_app or recorder can outlive a failing test.
set -euo pipefail

test_dir=$(cd "$1" && pwd)
module=$(readlink -f "$2")
recorder=$(readlink -f "$3")
more=()
for m in "${@:4}"; do more+=(--module "$(readlink -f "$m")"); done
here=$(cd "$(dirname "$0")" && pwd)
system_modules=/usr/lib/linuxcnc/modules

if [ "${CIRCLOG_TEST_INSIDE:-}" != 1 ]; then
  if [ "$(id -u)" != 0 ]; then
    echo "SKIP: the HAL tests need root (for a private mount namespace over $system_modules)"
    exit 77
  fi
  work=$(mktemp -d /tmp/circlog-test.XXXXXX)
  chmod 755 "$work"
  rc=0
  CIRCLOG_TEST_INSIDE=1 CIRCLOG_WORK=$work \
    "$here/../../scripts/hal-sandbox" --work "$work" --module "$module" "${more[@]}" --net -- "$0" "$@" || rc=$?
  if [ "$rc" = 0 ] && [ -z "${CIRCLOG_KEEP_WORK:-}" ]; then
    rm -rf "$work"
  else
    echo "(work files kept in $work)" >&2
  fi
  exit "$rc"
fi

work=$CIRCLOG_WORK
mkdir -p "$work/home"
export HOME=$work/home
export CIRCLOG_RECORDER=$recorder CIRCLOG_TESTS=$here TEST_DIR=$test_dir
export PYTHONDONTWRITEBYTECODE=1
cd "$work"

# The realtime threads SCHED_FIFO, as configs/circtest-run makes them (scripts/rt-boost: at
# normal priority, the suite's builds and LinuxCNC runs beside this one delay its threads; as
# root only, inside the sandbox's own PID namespace).
boost=
if [ "$(id -u)" = 0 ]; then
  "$here/../../scripts/rt-boost" &
  boost=$!
fi
cleanup() {
  halrun -U >/dev/null 2>&1 || true
  [ -z "$boost" ] || kill "$boost" 2>/dev/null || true
}
trap cleanup EXIT

rc=0
bash "$test_dir/test.sh" >"$work/result" 2>"$work/stderr" || rc=$?
if [ "$rc" != 0 ]; then
  echo "test.sh failed with exit code $rc; its stderr:" >&2
  cat "$work/stderr" >&2
  exit 1
fi
if [ ! -e "$test_dir/expected" ]; then
  cat "$work/result"  # a benchmark: figures, not a golden comparison
  exit 0
fi
if ! diff -u "$test_dir/expected" "$work/result"; then
  echo "result differs from $test_dir/expected; stderr of test.sh:" >&2
  cat "$work/stderr" >&2
  exit 1
fi
echo "ok: $(basename "$test_dir")"
