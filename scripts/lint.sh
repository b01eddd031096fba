#!/usr/bin/env bash
# Style and static checks, run by scripts/test.sh:
#  - clang-format (the repository's .clang-format) on every tracked C/C++ file: fails with the
#    list of files that are not formatted (fix: clang-format -i FILE);
#  - clang-tidy (.clang-tidy, tests/.clang-tidy) on the C++ sources changed since
#    $CIRCTEST_LINT_BASE (a commit; default HEAD~1, the last commit), or on all of them when
#    there is no such commit, with the build's compile_commands.json. A landing of several
#    commits sets it to where it started (e.g. CIRCTEST_LINT_BASE=main), so every commit is
#    checked; all files take about 16 min on 2 cores, too long for every run.
#   scripts/lint.sh [BUILD_DIR]     (default: build, or $CIRCTEST_BUILD_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${1:-${CIRCTEST_BUILD_DIR:-build}}
format=clang-format-14 tidy=clang-tidy-14

# A source tree without git (a release tarball, `git archive`): every C/C++ file outside the
# build folders is checked for format; clang-tidy needs the last commit, so it is skipped.
in_git=1
git rev-parse --is-inside-work-tree >/dev/null 2>&1 || in_git=0
if [ $in_git = 1 ]; then
  mapfile -t sources < <(git ls-files '*.c' '*.h' '*.cpp' '*.hpp' '*.cc' '*.hh')
else
  mapfile -t sources < <(find . \( -path './build*' -o -path './out' -o -path './.git' \) -prune -o \
    -type f \( -name '*.c' -o -name '*.h' -o -name '*.cpp' -o -name '*.hpp' -o -name '*.cc' \
    -o -name '*.hh' \) -print | sed 's|^\./||' | sort)
fi
# One clang-format run for all files; its diagnostics name the files that differ.
rc=0
report=$("$format" --dry-run --Werror "${sources[@]}" 2>&1) || rc=$?
mapfile -t unformatted < <(sed -n \
  's/^\(.*\):[0-9]*:[0-9]*: error: code should be clang-formatted.*/\1/p' <<<"$report" | sort -u)
if [ ${#unformatted[@]} -gt 0 ]; then
  echo "lint: not formatted with $format (run '$format -i' on them):" >&2
  printf '  %s\n' "${unformatted[@]}" >&2
  exit 1
fi
[ "$rc" = 0 ] || { echo "$report" >&2; echo "lint: $format failed (exit $rc)" >&2; exit 1; }
echo "lint: clang-format: ${#sources[@]} files ok"
if [ $in_git = 0 ]; then
  echo "lint: clang-tidy skipped: $root is not a git checkout (no last commit to check)"
  exit 0
fi

[ -f "$build/compile_commands.json" ] ||
  { echo "lint: $build/compile_commands.json missing (configure with CMAKE_EXPORT_COMPILE_COMMANDS=ON)" >&2; exit 1; }
base=${CIRCTEST_LINT_BASE:-HEAD~1}
if [ -n "${CIRCTEST_LINT_BASE:-}" ] && ! git rev-parse -q --verify "$base^{commit}" >/dev/null; then
  echo "lint: CIRCTEST_LINT_BASE=$base is not a commit" >&2
  exit 2
fi
if git rev-parse -q --verify "$base^{commit}" >/dev/null; then
  # Changed since the merge base, so commits that landed on the base meanwhile are not counted.
  mapfile -t changed < <(git diff --name-only --diff-filter=d "$base"...HEAD -- '*.cpp' '*.cc')
  what="changed since $base"
else
  mapfile -t changed < <(git ls-files '*.cpp' '*.cc')
  what="all (no parent commit)"
fi
# The libraries compile a batch of sources at a time (CIRCTEST_UNITY_BUILD): their compile
# commands name the batch file (.../Unity/unity_N_cxx.cxx, a list of #include "source.cpp").
# clang-tidy gets one command per source, the batch's command with the source in its place.
# The test programs' precompiled header (tests/CMakeLists.txt) is left out of their commands:
# clang-tidy need not read the compiler's, and each test file includes what it uses.
db_dir=$(mktemp -d)
trap 'rm -rf "$db_dir"' EXIT
python3 - "$build/compile_commands.json" "$db_dir/compile_commands.json" <<'PY'
import json, re, sys
entries = []
pch = re.compile(r" -include \S*cmake_pch\.hxx| -Winvalid-pch"
                 r"| -Xclang -include-pch -Xclang \S*cmake_pch\.hxx\.pch"
                 r"| -Xclang -include -Xclang \S*cmake_pch\.hxx")
for e in json.load(open(sys.argv[1])):
    e["command"] = pch.sub("", e["command"])
    if re.search(r"/Unity/unity_[0-9]+_cxx\.cxx$", e["file"]):
        for source in re.findall(r'^#include "(.+)"$', open(e["file"]).read(), re.M):
            entries.append(dict(e, file=source, command=e["command"].replace(e["file"], source)))
    else:
        entries.append(e)
json.dump(entries, open(sys.argv[2], "w"), indent=1)
PY
# Only files the build compiles (a source of a part switched off has no compile command).
files=()
for f in "${changed[@]}"; do
  grep -qF "\"file\": \"$root/$f\"" "$db_dir/compile_commands.json" && files+=("$f")
done
if [ ${#files[@]} = 0 ]; then
  echo "lint: clang-tidy: no C++ source $what"
  exit 0
fi
echo "lint: clang-tidy on ${#files[@]} file(s) $what"
headers="^$root/(core|analysis|gcode-gen|hal-component|compensation|configs|tests|bench)/"
printf '%s\n' "${files[@]}" |
  xargs -P "$(nproc)" -n 1 "$tidy" -p "$db_dir" --quiet --header-filter="$headers" 2>/dev/null ||
  { echo "lint: clang-tidy found problems (above)" >&2; exit 1; }
echo "lint: clang-tidy ok"
