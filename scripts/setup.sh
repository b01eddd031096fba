#!/usr/bin/env bash
# Installs what circtest needs on Debian 12 (idempotent: apt only runs when a package is
# missing) and builds it in ./build. Run as root, or as a user with sudo.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

mapfile -t packages < <(sed -e 's/#.*//' -e 's/[[:space:]]*$//' -e '/^[[:space:]]*$/d' scripts/debian-packages.txt)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

BUILD_DIR=${CIRCTEST_BUILD_DIR:-build}
# The programs and libraries Release (-O3); the test programs' own sources -O1: they compile
# 40 % faster and the CPU goes to the programs under test (tests/CMakeLists.txt).
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
  -DCIRCTEST_TEST_COMPILE_OPTIONS=-O1
cmake --build "$BUILD_DIR" -j"$(nproc)"
