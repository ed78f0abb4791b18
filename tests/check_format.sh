#!/usr/bin/env bash
# check_format.sh SOURCE_DIR: every C++ file of the tree is as clang-format (.clang-format at the
# root) writes it; the files that are not are named, with `clang-format -i FILE` to fix them.
set -u
cd "$1" || exit 1
command -v clang-format >/dev/null || { echo "clang-format is not installed (scripts/run.sh test installs it)"; exit 1; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.hpp')
else
  mapfile -t files < <(find core parallel io apps tests benchmarks -name '*.cpp' -o -name '*.hpp')
fi
bad=()
for f in "${files[@]}"; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "not formatted (clang-format -i FILE): ${bad[*]}"
  exit 1
fi
echo "${#files[@]} files formatted as .clang-format says"
