#!/usr/bin/env bash
# The README's test command: set up, build, lint (clang-format on every C/C++ file, clang-tidy
# on the last commit's C++ files: scripts/lint.sh), run every test (labels unit, hal, e2e, db,
# report (headless Chromium), package, tools, hostile, panel (pytest-qt offscreen), fuzz; soak
# only when asked).
# Extra arguments go to ctest, e.g. `scripts/test.sh -L unit`: then only the main build and
# those tests.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
phase() { echo "test.sh: $1 done after $((SECONDS - start)) s"; }
BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
full_run=0
# The full run leaves out the label soak (circlog for 10 minutes: `scripts/test.sh -L soak`).
if [ $# -eq 0 ]; then full_run=1; set -- -LE soak; fi
# The full run (CI) builds twice: the main build (Release, clang -O2: the programs, the realtime
# modules and the tests) and the sanitizer build (scripts/sanitize.sh: clang, ASan/UBSan,
# libFuzzer) of the parts that read users' files and write the configuration
# (CIRCTEST_SANITIZE_SCOPE=inputs: core, compensation, session, the HAL kernels and the
# recorder). The unit tests of those parts run there only, under the sanitizers (the main build
# leaves out the programs the sanitizer build lists), with each fuzz harness for
# CIRCTEST_FUZZ_SECONDS. CIRCTEST_SANITIZE_SCOPE=all sanitizes every part (analysis and circgen
# too: about 10 minutes more on 2 cores); CIRCTEST_SANITIZE_PASS=0 leaves the sanitizer build
# out (every unit test then runs in the main build). The sanitizer build starts once its own
# packages are in, at nice 10, while the others install and beside the main build and the
# suite.
sanitize=0
[ $full_run = 1 ] && [ "${CIRCTEST_SANITIZE_PASS:-1}" != 0 ] && sanitize=1
san_log=$BUILD_DIR/sanitize-build.log san_test_log=$BUILD_DIR/sanitize-test.log
san_mark=$BUILD_DIR/sanitize-build.done san_test_mark=$BUILD_DIR/sanitize-test.done
test_packages_mark=$BUILD_DIR/test-packages.done
if [ $sanitize = 1 ]; then
  # The sanitizer build's packages first (the build's but LinuxCNC and the panel's:
  # scripts/setup.sh); the rest of the build's (LinuxCNC) and the tests' (Chromium,
  # PostgreSQL...) install while the sanitizer build compiles, before the main build's
  # configure step looks for them.
  mkdir -p "$BUILD_DIR"
  export CIRCTEST_APT_STAMP=$BUILD_DIR/apt-updated
  rm -f "$CIRCTEST_APT_STAMP" "$test_packages_mark"
  CIRCTEST_PACKAGES=sanitize scripts/setup.sh install
  phase "install of the sanitizer build's packages"
  # The unit-test programs the sanitizer build makes (its configure step lists them) run there,
  # under ASan and UBSan, and are left out of the main build.
  CIRCTEST_SANITIZE_SCOPE=${CIRCTEST_SANITIZE_SCOPE:-inputs} scripts/sanitize.sh configure \
    >"$BUILD_DIR/sanitize-configure.log" 2>&1 ||
    { cat "$BUILD_DIR/sanitize-configure.log"; exit 1; }
  export CIRCTEST_UNIT_TESTS_ELSEWHERE
  CIRCTEST_UNIT_TESTS_ELSEWHERE=$(cd "${CIRCTEST_SANITIZE_DIR:-build-sanitize}" && pwd)/unit-test-programs.txt
  rm -f "$san_mark" "$san_test_mark"
  set -m  # the pass in a process group of its own: stopped whole if this script ends first
  (
    export CIRCTEST_SANITIZE_SCOPE=${CIRCTEST_SANITIZE_SCOPE:-inputs}
    nice -n 10 scripts/sanitize.sh build >"$san_log" 2>&1 || { echo build >"$san_mark"; exit 1; }
    echo "$((SECONDS - start))" >"$san_mark"
    # Its tests run once the tests' packages are in.
    while [ ! -e "$test_packages_mark" ]; do sleep 1; done
    rc=0
    nice -n 10 scripts/sanitize.sh test >"$san_test_log" 2>&1 || rc=$?
    echo "$((SECONDS - start)) $rc" >"$san_test_mark"
  ) &
  san_pass=$!
  set +m
  trap 'kill -- -"$san_pass" 2>/dev/null || true' EXIT
  CIRCTEST_PACKAGES=build scripts/setup.sh install
  phase "install of the build's packages"
  # The tests' packages install while the main build's configure step and its first targets
  # run (the configure step needs none of them: tests/analysis/CMakeLists.txt).
  tests_log=$BUILD_DIR/test-packages.log
  (CIRCTEST_PACKAGES=tests scripts/setup.sh install >"$tests_log" 2>&1 &&
    touch "$test_packages_mark") &
  test_packages=$!
else
  scripts/setup.sh install
  phase "install"
fi
# Waits for the tests' packages (installed in the background in the full run).
wait_for_test_packages() {
  [ -n "${test_packages:-}" ] || return 0
  wait "$test_packages" ||
    { cat "$tests_log"; echo "test.sh: the tests' packages did not install" >&2; exit 1; }
  test_packages=""
  phase "install of the tests' packages"
}
# The full run builds the e2e tests' programs first (tests/e2e: circtest_e2e_programs) and
# starts those tests (label e2e) while the rest builds at nice 10: they wait on LinuxCNC's
# real-time motion for most of their time, the build takes the CPU they leave.
e2e_bg=0
[ $full_run = 1 ] && [ "${CIRCTEST_E2E_EARLY:-1}" != 0 ] && e2e_bg=1
if [ $e2e_bg = 1 ]; then
  CIRCTEST_BUILD_TARGET=circtest_e2e_programs scripts/setup.sh build
  phase "e2e programs build"
  wait_for_test_packages
else
  scripts/setup.sh build
  phase "main build"
  wait_for_test_packages
fi
# The LinuxCNC runs of this suite that equal an earlier one (configuration, program, --set
# values: configs/circtest-run) reuse its trace: a new, empty cache each time.
CIRCTEST_RUN_CACHE=$(cd "$BUILD_DIR" && pwd)/run-cache
rm -rf "$CIRCTEST_RUN_CACHE"
export CIRCTEST_RUN_CACHE
# Four LinuxCNC side by side (tests/e2e/CMakeLists.txt: each e2e test takes one slot of the
# resource linuxcnc for its whole time; configs/circtest-run then takes one of its own
# CIRCTEST_RUN_SLOTS, each run in its own sandbox with its realtime threads SCHED_FIFO): the
# e2e tests (1,236 s one after the other, the demo 210 s of it) are the run's longest path.
# Four times as many tests as cores: the LinuxCNC runs wait on the machine's motion, in real
# time, most of their minute, and the other tests (the unit tests among them) use that CPU.
export CIRCTEST_RUN_SLOTS=${CIRCTEST_RUN_SLOTS:-4}
slots_file=$(cd "$BUILD_DIR" && pwd)/linuxcnc-slots.json
printf '{"version": {"major": 1, "minor": 0},\n "local": [{"linuxcnc": [{"id": "0", "slots": %d}]}]}\n' \
  "$CIRCTEST_RUN_SLOTS" >"$slots_file"
suite_rc=0
if [ $e2e_bg = 1 ]; then
  e2e_log=$BUILD_DIR/e2e-suite.log
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$CIRCTEST_RUN_SLOTS" \
    --resource-spec-file "$slots_file" -L e2e >"$e2e_log" 2>&1 &
  e2e_pid=$!
  nice -n 10 scripts/setup.sh build
  phase "main build"
  scripts/lint.sh "$BUILD_DIR"
  phase "lint"
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 4))" \
    --resource-spec-file "$slots_file" -LE 'e2e|soak' || suite_rc=$?
  phase "test suite but e2e"
  e2e_rc=0
  wait "$e2e_pid" || e2e_rc=$?
  cat "$e2e_log"
  [ $e2e_rc = 0 ] || [ $suite_rc != 0 ] || suite_rc=$e2e_rc
  phase "e2e tests"
else
  scripts/lint.sh "$BUILD_DIR"
  phase "lint"
  ctest --test-dir "$BUILD_DIR" --output-on-failure -j"$(($(nproc) * 4))" \
    --resource-spec-file "$slots_file" "$@" || suite_rc=$?
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
  echo "test.sh: sanitizer pass (unit tests, fuzz harnesses) done after $san_end s"
fi
if [ "$san_rc" != 0 ]; then
  echo "test.sh: the sanitizer pass failed (exit $san_rc; whole log: $san_test_log)" >&2
  [ $suite_rc != 0 ] || suite_rc=$san_rc
fi
exit $suite_rc
