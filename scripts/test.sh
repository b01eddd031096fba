#!/usr/bin/env bash
# The README's test command: set up, build, lint (clang-format on every C/C++ file, clang-tidy
# on the last commit's C++ files: scripts/lint.sh), run every test (labels unit, hal, e2e, db,
# report (headless Chromium), package, tools, hostile; soak only when asked).
# Extra arguments go to ctest, e.g. `scripts/test.sh -L unit`.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
phase() { echo "test.sh: $1 done after $((SECONDS - start)) s"; }
scripts/setup.sh
phase "install and build"
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
# The LinuxCNC runs of this suite that equal an earlier one (configuration, program, --set
# values: configs/circtest-run) reuse its trace: a new, empty cache each time.
CIRCTEST_RUN_CACHE=$(cd "$BUILD_DIR" && pwd)/run-cache
rm -rf "$CIRCTEST_RUN_CACHE"
export CIRCTEST_RUN_CACHE
scripts/lint.sh "$BUILD_DIR"
phase "lint"
full_run=0
# The full run leaves out the label soak (circlog for 10 minutes: `scripts/test.sh -L soak`).
if [ $# -eq 0 ]; then full_run=1; set -- -LE soak; fi
# The full run (CI) also runs the unit tests once under ASan/UBSan and each fuzz harness for
# CIRCTEST_FUZZ_SECONDS, in a second build dir (scripts/sanitize.sh). CIRCTEST_SANITIZE_PASS=0
# skips it. Build, tests and harnesses run at the lowest priority beside the suite: the
# LinuxCNC runs (e2e, one at a time) wait on real-time motion for most of the suite and leave
# the CPU idle, and at nice 19 the pass takes only what the suite leaves. The stepper runs
# (e2e tests named Stepper*, RUN_SERIAL in tests/e2e/CMakeLists.txt) wait until the pass has
# ended and then run alone: beside the sanitizer tests and harnesses (a core each, flat out)
# the stepper machine's 50 us base thread (non-realtime POSIX) missed enough periods to stop on
# a following error in the fresh-Debian run.
sanitize=0
[ $full_run = 1 ] && [ "${CIRCTEST_SANITIZE_PASS:-1}" != 0 ] && sanitize=1
san_log=$BUILD_DIR/sanitize-build.log san_test_log=$BUILD_DIR/sanitize-test.log
san_mark=$BUILD_DIR/sanitize-build.done san_test_mark=$BUILD_DIR/sanitize-test.done
if [ $sanitize = 1 ]; then
  mkdir -p "$BUILD_DIR"
  rm -f "$san_mark" "$san_test_mark"
  (
    nice -n 19 scripts/sanitize.sh build >"$san_log" 2>&1 || { echo build >"$san_mark"; exit 1; }
    echo "$((SECONDS - start))" >"$san_mark"
    rc=0
    nice -n 19 scripts/sanitize.sh test >"$san_test_log" 2>&1 || rc=$?
    echo "$((SECONDS - start)) $rc" >"$san_test_mark"
  ) &
  san_pass=$!
fi
# Twice as many tests as cores: the LinuxCNC runs (e2e, one at a time) wait on the machine's
# motion, in real time, most of their minute, and the unit tests use that CPU meanwhile.
alone='^e2e_test_[a-z_]+\.[A-Za-z]+\.Stepper'
suite_rc=0
if [ $full_run = 1 ]; then
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 2))" "$@" -E "$alone" ||
    suite_rc=$?
  phase "test suite without the stepper runs"
else
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 2))" "$@" || suite_rc=$?
  phase "test suite"
fi
san_rc=0
if [ $sanitize = 1 ]; then
  wait "$san_pass" || true
  if [ ! -f "$san_mark" ] || [ "$(sed -n 1p "$san_mark")" = build ]; then
    tail -n 60 "$san_log"
    echo "test.sh: the sanitizer build failed (whole log: $san_log)" >&2
    exit 1
  fi
  cat "$san_test_log"
  echo "test.sh: sanitizer build done after $(sed -n 1p "$san_mark") s"
  read -r san_end san_rc <"$san_test_mark" || { san_end="?"; san_rc=1; }
  echo "test.sh: sanitizer and fuzz pass done after $san_end s"
fi
if [ $full_run = 1 ]; then
  ctest --test-dir "$BUILD_DIR" --output-on-failure "$@" -R "$alone" || suite_rc=$?
  phase "stepper runs"
fi
if [ "$san_rc" != 0 ]; then
  echo "test.sh: the sanitizer and fuzz pass failed (exit $san_rc; whole log: $san_test_log)" >&2
  [ $suite_rc != 0 ] || suite_rc=$san_rc
fi
exit $suite_rc
