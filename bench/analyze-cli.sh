#!/usr/bin/env bash
# Times `circana analyze --json` on a 1e6-sample CCW+CW trace, text and binary, against the
# floors measured in the same rounds by bench/parse_baseline (parsing every number with
# std::from_chars; reading the .ctb's bytes), prints the ratios and circana's peak memory;
# then `circana diagnose --json` on the same files against analyze (target: at most 2x).
# Rounds interleave circana and the floors, so a busy machine slows both alike; the best
# round of each counts.
# Wall and CPU times come from bash's `time` at 1 ms resolution (/usr/bin/time's 10 ms was too
# coarse for the last few per cent); /usr/bin/time only gives the peak memory.
# usage: bench/analyze-cli.sh [BUILD_DIR] [ROUNDS]   (Release build; needs /usr/bin/time)
set -euo pipefail
build=${1:-build}
rounds=${2:-7}
work=${TMPDIR:-/tmp}/circtest-bench
mkdir -p "$work"
sim=(--backlash-x 0.02 --squareness 100e-6 --kv-x 30 --kv-y 33 --noise 0.0002 --period 0.0000664)
# D150 F1000, 2 x (360 + 2 x 30 deg lead) and dwells: a period of 66.4 us gives ~1e6 rows.
[ -f "$work/trace-1e6.csv" ] || "$build/tests/support/circtest-simtrace" -o "$work/trace-1e6.csv" "${sim[@]}"
[ -f "$work/trace-1e6.ctb" ] || "$build/tests/support/circtest-simtrace" -o "$work/trace-1e6.ctb" "${sim[@]}"

# timed CMD...: "wall user sys" in seconds, ms resolution; the command's output is dropped.
timed() {
  local TIMEFORMAT='%3R %3U %3S'
  { time "$@" >/dev/null 2>&1; } 2>&1
}
min() { awk -v a="$1" -v b="$2" 'BEGIN { print (a < b ? a : b) }'; }

# bench FILE MODE: best circana wall time and best floor/reader times over the rounds.
bench() {
  local file=$1 mode=$2 best=999 cpu=999 floor=999 floorc=999 reader=999 reader1=999 readerc=999
  local fresh=999
  local line t
  for _ in $(seq "$rounds"); do
    t=$(timed "$build/analysis/circana" analyze "$file" --json)
    best=$(min "$best" "$(cut -d' ' -f1 <<<"$t")")
    cpu=$(min "$cpu" "$(awk '{ print $2 + $3 }' <<<"$t")")
    line=$("$build/bench/parse_baseline" "$file" 1 "$mode" | grep '^floor_wall_s=')
    floor=$(min "$floor" "$(sed 's/.*floor_wall_s=\([0-9.]*\).*/\1/' <<<"$line")")
    reader=$(min "$reader" "$(sed 's/.*reader_wall_s=\([0-9.]*\).*/\1/' <<<"$line")")
    reader1=$(min "$reader1" "$(sed 's/.*reader1_wall_s=\([0-9.]*\).*/\1/' <<<"$line")")
    floorc=$(min "$floorc" "$(sed 's/.*floor_cpu_s=\([0-9.]*\).*/\1/' <<<"$line")")
    readerc=$(min "$readerc" "$(sed 's/.*reader1_cpu_s=\([0-9.]*\).*/\1/' <<<"$line")")
    fresh=$(min "$fresh" "$(sed 's/.*fresh_wall_s=\([0-9.]*\).*/\1/' <<<"$line")")
  done
  local rss
  rss=$( { /usr/bin/time -f '%M' "$build/analysis/circana" analyze "$file" --json >/dev/null; } 2>&1 | tail -1)
  local rows
  rows=$("$build/bench/parse_baseline" "$file" 1 "$mode" | sed -n 's/^read_trace, 1 thread.*(\([0-9]*\) rows).*/\1/p')
  printf '%s: %s rows, %s MB\n' "$file" "$rows" "$(du -m "$file" | cut -f1)"
  awk -v c="$best" -v f="$floor" -v r="$reader" -v r1="$reader1" -v m="$mode" -v rss="$rss" \
      -v n="$rows" -v cc="$cpu" -v fc="$floorc" -v rc="$readerc" -v fr="$fresh" 'BEGIN {
    fl = (m == "binary") ? "reading its bytes" : "from_chars of every number";
    printf "  floor (%s):            %.3f s\n", fl, f
    printf "  read_trace (all cores / 1 thread): %.3f / %.3f s = %.2fx / %.2fx the floor\n", r, r1, r / f, r1 / f
    printf "  circana analyze --json:                %.3f s = %.2fx the floor\n", c, c / f
    printf "  CPU time (user+sys): floor %.3f s, read_trace 1 thread %.3f s = %.2fx, circana %.2f s = %.2fx\n", fc, rc, rc / fc, cc, cc / fc
    if (m == "binary") printf "  reading its bytes into fresh memory (what keeping them costs): %.3f s; read_trace %.2fx, analyze %.2fx that\n", fr, r / fr, c / fr
    printf "  circana peak RSS: %d MiB, %.0f MiB per 1e6 rows\n", rss / 1024, rss / 1024 / n * 1e6
  }'
}

echo "machine: $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), best of $rounds rounds"
bench "$work/trace-1e6.csv" csv
bench "$work/trace-1e6.ctb" binary

# diagnose FILE: best wall and CPU of `circana diagnose --json` and of `analyze --json`,
# interleaved, and their ratio; diagnose's peak memory.
diagnose_bench() {
  local file=$1 dw=999 dc=999 aw=999 ac=999 t
  for _ in $(seq "$rounds"); do
    t=$(timed "$build/analysis/circana" diagnose "$file" --json)
    dw=$(min "$dw" "$(cut -d' ' -f1 <<<"$t")")
    dc=$(min "$dc" "$(awk '{ print $2 + $3 }' <<<"$t")")
    t=$(timed "$build/analysis/circana" analyze "$file" --json)
    aw=$(min "$aw" "$(cut -d' ' -f1 <<<"$t")")
    ac=$(min "$ac" "$(awk '{ print $2 + $3 }' <<<"$t")")
  done
  local rss
  rss=$( { /usr/bin/time -f '%M' "$build/analysis/circana" diagnose "$file" --json >/dev/null; } 2>&1 | tail -1)
  awk -v f="$file" -v dw="$dw" -v dc="$dc" -v aw="$aw" -v ac="$ac" -v rss="$rss" 'BEGIN {
    printf "%s: circana diagnose --json %.3f s wall, %.2f s CPU; analyze --json %.3f s wall, %.2f s CPU\n", f, dw, dc, aw, ac
    printf "  diagnose / analyze: %.2fx wall, %.2fx CPU (target 2x); diagnose peak RSS %d MiB\n", dw / aw, dc / ac, rss / 1024
  }'
}
diagnose_bench "$work/trace-1e6.csv"
diagnose_bench "$work/trace-1e6.ctb"
