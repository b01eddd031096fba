#!/usr/bin/env bash
# Installs what circtest needs on Debian 12 (idempotent: apt only runs when a package is
# missing) and builds it in ./build. Run as root, or as a user with sudo.
#   scripts/setup.sh [install|build]    (default: both; scripts/test.sh runs them apart)
# install takes the packages of scripts/debian-packages.txt (the build's) and
# scripts/debian-packages-test.txt (the tests'); CIRCTEST_PACKAGES=build or tests only one list,
# sanitize the build's without those the sanitizer build does without (below).
# CIRCTEST_UNIT_TESTS=OFF builds no unit-test programs; CIRCTEST_UNIT_TESTS_ELSEWHERE=LIST
# leaves out those another build lists (scripts/test.sh: the sanitizer build's).
set -euo pipefail
cd "$(dirname "$0")/.."
step=all
case "${1:-}" in
  install | build) step=$1 ;;
  "") ;;
  *) echo "setup.sh: expected install or build, got '$1'" >&2; exit 2 ;;
esac

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

# The build's packages that the sanitizer build (scripts/sanitize.sh: no realtime modules, no
# benchmarks) does without: LinuxCNC (300 of the build's 457 packages with what it pulls in,
# 155 of its 357 MB) and the panel's. CIRCTEST_PACKAGES=sanitize leaves them out, so that
# scripts/test.sh starts the sanitizer build while they install.
not_for_sanitizer=(linuxcnc-uspace linuxcnc-uspace-dev libbenchmark-dev python3-pyqt5
                   python3-pyqt5.qtsvg python3-dbus)
install_packages() {
  local lists
  case "${CIRCTEST_PACKAGES:-all}" in
    all) lists=(scripts/debian-packages.txt scripts/debian-packages-test.txt) ;;
    build | sanitize) lists=(scripts/debian-packages.txt) ;;
    tests) lists=(scripts/debian-packages-test.txt) ;;
    *) echo "setup.sh: CIRCTEST_PACKAGES: expected all, build, sanitize or tests, got '$CIRCTEST_PACKAGES'" >&2
       exit 2 ;;
  esac
  mapfile -t packages < <(sed -e 's/#.*//' -e 's/[[:space:]]*$//' -e '/^[[:space:]]*$/d' "${lists[@]}")
  missing=()
  for p in "${packages[@]}"; do
    if [ "${CIRCTEST_PACKAGES:-all}" = sanitize ] && [[ " ${not_for_sanitizer[*]} " == *" $p "* ]]; then
      continue
    fi
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "setup: installing ${missing[*]}"
    # CIRCTEST_APT_STAMP: a file made after the update, whose presence skips it (scripts/test.sh
    # installs in two steps, one update).
    if [ -z "${CIRCTEST_APT_STAMP:-}" ] || [ ! -e "$CIRCTEST_APT_STAMP" ]; then
      $SUDO apt-get update -qq
      [ -z "${CIRCTEST_APT_STAMP:-}" ] || touch "$CIRCTEST_APT_STAMP"
    fi
    # On a CI machine (CI set, as CI services and ../shared/tools/fresh-debian-check do) dpkg
    # unpacks without an fsync per file, as Debian's container images do: a machine that is
    # thrown away after the run loses nothing by it.
    local dpkg_io=()
    [ -z "${CI:-}" ] || dpkg_io=(-o Dpkg::Options::=--force-unsafe-io)
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
      "${dpkg_io[@]}" "${missing[@]}"
  fi
}
[ $step = build ] || install_packages
[ $step != install ] || exit 0

BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
# clang, the programs and libraries at -O2 (Release), the test programs' own sources at -O0:
# the build takes about half the CPU time of gcc -O3's, the programs run as fast
# (docs/development.md), and the CPU goes to the programs under test (tests/CMakeLists.txt).
# A build folder keeps the compiler it was configured with (CMake cannot change it).
compiler=()
[ -f "$BUILD_DIR/CMakeCache.txt" ] || compiler=(-DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++)
cmake -S . -B "$BUILD_DIR" "${compiler[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_FLAGS_RELEASE="-O2 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" \
  -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
  -DCIRCTEST_TEST_COMPILE_OPTIONS=-O0 -DCIRCTEST_UNIT_TESTS="${CIRCTEST_UNIT_TESTS:-ON}" \
  -DCIRCTEST_UNIT_TESTS_ELSEWHERE="${CIRCTEST_UNIT_TESTS_ELSEWHERE:-}"
# CIRCTEST_BUILD_TARGET: one target and what it needs (scripts/test.sh: circtest_e2e_programs).
cmake --build "$BUILD_DIR" -j"$(nproc)" ${CIRCTEST_BUILD_TARGET:+--target "$CIRCTEST_BUILD_TARGET"}
