#!/usr/bin/env bash
# The second build of scripts/test.sh: clang with CIRCTEST_SANITIZE (ASan + UBSan with
# float-cast-overflow) and CIRCTEST_FUZZ, in its own build dir; runs the unit tests once
# under the sanitizers and each fuzz harness for CIRCTEST_FUZZ_SECONDS (default 4: the gate
# replays its fixed seed from the corpus; exploration is the longer hand run of docs/fuzzing.md).
# Only the unit-test programs (CIRCTEST_UNIT_TESTS=ONLY, their own sources at -O0 and without
# ASan's instrumentation: cmake/Sanitize.cmake), the HAL kernels without the realtime modules
# (a sanitized module cannot go into rtapi_app), no benchmarks (docs/fuzzing.md).
# CIRCTEST_SANITIZE_SCOPE: all (default) every part; inputs only the parts that read what
# users and other programs hand over and write the configuration (core: traces, INI, JSON,
# input files; compensation and session: HAL files, comp tables, the manifest, the diagnosis
# JSON, the configuration writer; the HAL kernels and the recorder), without analysis and
# circgen: scripts/test.sh's full run, whose main build runs every unit test.
#   scripts/sanitize.sh [all|configure|build|test] [CTEST ARGS...]   (default all: build, then
#   test; configure: only cmake's configure step, which lists the unit-test programs in
#   $SAN_DIR/unit-test-programs.txt)
set -euo pipefail
cd "$(dirname "$0")/.."
phase=all
case "${1:-}" in all|configure|build|test) phase=$1; shift ;; esac
SAN_DIR=${CIRCTEST_SANITIZE_DIR:-build-sanitize}
scope=()
case "${CIRCTEST_SANITIZE_SCOPE:-all}" in
  all) scope=(-DCIRCTEST_BUILD_ANALYSIS=ON -DCIRCTEST_BUILD_GCODE=ON) ;;
  inputs) scope=(-DCIRCTEST_BUILD_ANALYSIS=OFF -DCIRCTEST_BUILD_GCODE=OFF) ;;
  *) echo "sanitize.sh: CIRCTEST_SANITIZE_SCOPE: expected all or inputs, got '$CIRCTEST_SANITIZE_SCOPE'" >&2
     exit 2 ;;
esac
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
# No debug information by default: the sanitizers' reports name each frame's function (the
# symbol table) but not its file and line, and the build takes 13 % less (html_report.cpp
# 31.1 -> 27.1 s); CIRCTEST_SANITIZE_DEBUG=-gline-tables-only gives file:line back (a CI
# finding reproduces with the fixed seeds and the same build), -g a build to step through.
debug=${CIRCTEST_SANITIZE_DEBUG:-}
if [ "$phase" != test ]; then
  cmake -S . -B "$SAN_DIR" -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCIRCTEST_SANITIZE=ON -DCIRCTEST_FUZZ=ON \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 $debug -DNDEBUG" \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 $debug -DNDEBUG" \
    -DCIRCTEST_HAL_MODULES=OFF -DCIRCTEST_BUILD_BENCHMARKS=OFF -DCIRCTEST_BUILD_DOCS=OFF \
    -DCIRCTEST_FUZZ_SECONDS="${CIRCTEST_FUZZ_SECONDS:-4}" -DCIRCTEST_TEST_COMPILE_OPTIONS=-O0 -DCIRCTEST_UNIT_TESTS=ONLY \
    "${scope[@]}" "${launcher[@]}"
  [ "$phase" != configure ] || exit 0
  cmake --build "$SAN_DIR" -j"$(nproc)"
fi
[ "$phase" != build ] || exit 0
# halt_on_error: the first report fails the test; detect_leaks: a leak is a finding too.
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
# Twice as many tests as cores: several wait on the programs they start.
ctest --test-dir "$SAN_DIR" --output-on-failure -j"$(($(nproc) * 2))" -L 'unit|fuzz' "$@"
