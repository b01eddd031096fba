#!/bin/bash
# The .deb installed into a fresh root: builds the package with CPack, installs it with
# `dpkg -i` into an overlay of the running system (in the private namespaces of
# scripts/hal-sandbox; the writes land in a scratch folder and vanish with the test, the real
# system is not touched),
# then checks there that the files are where LinuxCNC and man look, that halrun loads circlog
# from /usr/lib/linuxcnc/modules, that `man circana`, `man 9 circlog` and `man 9 circtest_kins`
# render, that the programs run, and that dpkg --verify finds the installed files unchanged.
#   test-deb.sh BUILD_DIR VERSION
set -euo pipefail

if [ "${CIRCTEST_DEB_INSIDE:-}" != 1 ]; then
  build=$(readlink -f "$1")
  version=$2
  if [ "$(id -u)" != 0 ]; then
    echo "SKIP: the package test needs root (overlay mount, chroot, dpkg)"
    exit 77
  fi
  work=$(mktemp -d /var/tmp/circtest-deb.XXXXXX)
  trap 'rm -rf "$work"' EXIT
  cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/pkg" >"$work/cpack.log" 2>&1 ||
    { cat "$work/cpack.log"; exit 1; }
  deb=$(ls "$work"/pkg/circtest_"$version"_*.deb)
  echo "built $(basename "$deb") ($(stat -c %s "$deb") bytes)"
  rc=0
  CIRCTEST_DEB_INSIDE=1 "$(dirname "$0")/../../scripts/hal-sandbox" --work "$work" -- \
    "$0" "$work" "$deb" "$version" || rc=$?
  exit $rc
fi

work=$1 deb=$2 version=$3
root=$work/root
mkdir -p "$work/upper" "$work/ovl" "$root"
mount -t overlay overlay -o "lowerdir=/,upperdir=$work/upper,workdir=$work/ovl" "$root"
mount --rbind /dev "$root/dev"
mount -t proc proc "$root/proc"
mount -t tmpfs tmpfs "$root/tmp"
fail() { echo "FAIL: $*" >&2; exit 1; }
in_root() { chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 "$@"; }

# Fresh as far as circtest goes: no earlier install may answer for the package.
for f in /usr/bin/circgen /usr/bin/circana /usr/bin/circlog-record /usr/bin/circcomp \
  /usr/bin/circtest /usr/libexec/circtest/circtest-linuxcnc \
  /usr/lib/linuxcnc/modules/circlog.so /usr/lib/linuxcnc/modules/circtest_kins.so \
  /usr/lib/linuxcnc/modules/circfric.so \
  /usr/share/man/man1/circana.1 /usr/share/man/man1/circana.1.gz /usr/share/man/man9/circlog.9 \
  /usr/share/man/man9/circtest_kins.9 /usr/share/man/man9/circfric.9; do
  rm -f "$root$f"
done
in_root dpkg -s circtest >/dev/null 2>&1 && in_root dpkg --purge circtest >/dev/null
rm -f "$root/var/lib/man-db/auto-update"  # skip the man-db trigger's rebuild of its index

cp "$deb" "$root/tmp/circtest.deb"
in_root dpkg -i /tmp/circtest.deb >"$work/dpkg.log" 2>&1 || { cat "$work/dpkg.log"; fail "dpkg -i"; }
in_root dpkg --verify circtest || fail "dpkg --verify: installed files differ from the package"
for f in /usr/bin/circgen /usr/bin/circana /usr/bin/circlog-record \
  /usr/lib/linuxcnc/modules/circlog.so /usr/lib/linuxcnc/modules/circtest_kins.so \
  /usr/lib/linuxcnc/modules/circfric.so \
  /usr/share/man/man1/circgen.1 \
  /usr/share/man/man1/circana.1 /usr/share/man/man1/circlog-record.1 \
  /usr/share/man/man9/circlog.9 /usr/share/man/man9/circtest_kins.9 \
  /usr/share/man/man9/circfric.9 \
  /usr/share/bash-completion/completions/circana \
  /usr/bin/circcomp /usr/share/man/man1/circcomp.1 \
  /usr/bin/circtest /usr/libexec/circtest/circtest-linuxcnc /usr/share/man/man1/circtest.1; do
  in_root dpkg -S "$f" | grep -q '^circtest: ' || fail "$f is not installed by the package"
done
echo "ok: dpkg -i; files in /usr/bin, /usr/lib/linuxcnc/modules, /usr/share/man, bash-completion"

for p in circgen circana circlog-record circcomp circtest; do
  [ "$(in_root "$p" --version)" = "$p $version" ] || fail "$p --version"
done
in_root circgen --d 150 --f 1000 --safe-z 5 -o /tmp/test.ngc || fail "circgen"
grep -q '^(circtest: generator: circgen '"$version"')' "$root/tmp/test.ngc" || fail "circgen output"
echo "ok: programs run from /usr/bin"

man_text=$(in_root env MANWIDTH=80 man -P cat circana 2>"$work/man.err") || fail "man circana"
[ ! -s "$work/man.err" ] || fail "man circana warns: $(cat "$work/man.err")"
grep -q 'circana analyze' <<<"$man_text" || fail "man circana: no synopsis"
grep -q "circtest $version" <<<"$man_text" || fail "man circana: no version $version in the footer"
in_root env MANWIDTH=80 man -P cat 9 circlog | grep -q 'circlog.0.overruns' || fail "man 9 circlog"
in_root env MANWIDTH=80 man -P cat 9 circtest_kins | grep -q 'circtest-kins.squareness-xy' ||
  fail "man 9 circtest_kins"
echo "ok: man circana, man 9 circlog, man 9 circtest_kins render"

# halrun in the installed root, realtime as nobody (rtapi_app refuses root) with its FIFO in
# a folder nobody owns; circlog comes from /usr/lib/linuxcnc/modules, where the package put it.
mkdir -p "$root/tmp/rtapi"
chown nobody "$root/tmp/rtapi"
cat >"$root/tmp/load.hal" <<'HAL'
loadrt threads name1=servo period1=1000000
loadrt circlog channels=2
addf circlog.0 servo
start
show comp circlog
show pin circlog.0.in-01
getp circlog.0.depth
HAL
rt_uid=$(id -u nobody)
hal_out=$(chroot "$root" env -i PATH=/usr/bin:/bin HOME=/tmp RTAPI_UID="$rt_uid" \
  RTAPI_FIFO_PATH=/tmp/rtapi/.rtapi_fifo halrun -f /tmp/load.hal 2>&1) ||
  { echo "$hal_out"; fail "halrun -f load.hal"; }
chroot "$root" env -i PATH=/usr/bin:/bin RTAPI_UID="$rt_uid" \
  RTAPI_FIFO_PATH=/tmp/rtapi/.rtapi_fifo halrun -U >/dev/null 2>&1 || true
grep -q 'circlog.0.in-01' <<<"$hal_out" || { echo "$hal_out"; fail "circlog's pins are missing"; }
grep -qx '16384' <<<"$hal_out" || { echo "$hal_out"; fail "circlog.0.depth is not the default"; }
echo "ok: halrun loads circlog from /usr/lib/linuxcnc/modules"
