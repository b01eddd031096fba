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
# Twice as many tests as cores: the LinuxCNC runs (e2e) wait on the machine's motion, in real
# time, most of their minute, and each has its own sandbox.
ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 2))" "$@"
phase "test suite"
# The full run (CI) also runs the unit tests once under ASan/UBSan and each fuzz harness for
# CIRCTEST_FUZZ_SECONDS, in a second build dir (scripts/sanitize.sh). CIRCTEST_SANITIZE_PASS=0
# skips it.
if [ $full_run = 1 ] && [ "${CIRCTEST_SANITIZE_PASS:-1}" != 0 ]; then
  scripts/sanitize.sh
  phase "sanitizer and fuzz pass"
fi
