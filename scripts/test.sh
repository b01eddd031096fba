#!/usr/bin/env bash
# The README's test command: set up, build, lint (clang-format on every C/C++ file, clang-tidy
# on the last commit's C++ files: scripts/lint.sh), run every test (labels unit, hal, e2e, db,
# report (headless Chromium), package, tools, hostile; soak only when asked).
# Extra arguments go to ctest, e.g. `scripts/test.sh -L unit`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
scripts/lint.sh "$BUILD_DIR"
full_run=0
# The full run leaves out the label soak (circlog for 10 minutes: `scripts/test.sh -L soak`).
if [ $# -eq 0 ]; then full_run=1; set -- -LE soak; fi
ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(nproc)" "$@"
# The full run (CI) also runs the unit tests once under ASan/UBSan and each fuzz harness for
# 30 s, in a second build dir (scripts/sanitize.sh). CIRCTEST_SANITIZE_PASS=0 skips it.
if [ $full_run = 1 ] && [ "${CIRCTEST_SANITIZE_PASS:-1}" != 0 ]; then
  scripts/sanitize.sh
fi
