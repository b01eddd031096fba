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
scripts/lint.sh "$BUILD_DIR"
phase "lint"
full_run=0
# The full run leaves out the label soak (circlog for 10 minutes: `scripts/test.sh -L soak`).
if [ $# -eq 0 ]; then full_run=1; set -- -LE soak; fi
# The full run (CI) also runs the unit tests once under ASan/UBSan and each fuzz harness for
# CIRCTEST_FUZZ_SECONDS, in a second build dir (scripts/sanitize.sh). CIRCTEST_SANITIZE_PASS=0
# skips it. Its build runs at the lowest priority beside the suite, on the CPU the LinuxCNC
# runs leave idle while they wait on real-time motion; its log is printed if it fails.
sanitize=0
[ $full_run = 1 ] && [ "${CIRCTEST_SANITIZE_PASS:-1}" != 0 ] && sanitize=1
san_log=$BUILD_DIR/sanitize-build.log
if [ $sanitize = 1 ]; then
  nice -n 19 scripts/sanitize.sh build >"$san_log" 2>&1 &
  san_build=$!
fi
# Twice as many tests as cores: the LinuxCNC runs (e2e, one at a time) wait on the machine's
# motion, in real time, most of their minute, and the unit tests use that CPU meanwhile.
ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 2))" "$@"
phase "test suite"
if [ $sanitize = 1 ]; then
  san_rc=0
  wait "$san_build" || san_rc=$?
  if [ $san_rc != 0 ]; then
    tail -n 60 "$san_log"
    echo "test.sh: the sanitizer build failed (exit $san_rc; whole log: $san_log)" >&2
    exit $san_rc
  fi
  phase "sanitizer build"
  scripts/sanitize.sh test
  phase "sanitizer and fuzz pass"
fi
