#!/usr/bin/env bash
# Fails on any clang-format drift (the root .clang-format) in the tracked C++ files of ROOT.
# Skipped (exit 77) with a message when clang-format or git is missing, or ROOT is not a git
# work tree. Fix drift with: git ls-files '*.cc' '*.h' '*.cpp' | xargs clang-format -i
# Usage: check_format.sh ROOT
set -euo pipefail
root=$1
command -v clang-format >/dev/null ||
  { echo "SKIPPED: clang-format is not installed (scripts/setup installs Debian's clang-format)"; exit 77; }
command -v git >/dev/null || { echo "SKIPPED: git is not installed"; exit 77; }
git -C "$root" rev-parse --is-inside-work-tree >/dev/null 2>&1 ||
  { echo "SKIPPED: $root is not a git work tree"; exit 77; }
cd "$root"
count=$(git ls-files '*.cc' '*.h' '*.cpp' | wc -l)
if ! git ls-files -z '*.cc' '*.h' '*.cpp' | xargs -0 clang-format --dry-run --Werror 2>"${TMPDIR:-/tmp}/kestrel-format.$$"; then
  grep -E "error:" "${TMPDIR:-/tmp}/kestrel-format.$$" | head -50
  echo "FAIL: clang-format drift in: $(grep -oE '^[^:]+:[0-9]+:[0-9]+: error' "${TMPDIR:-/tmp}/kestrel-format.$$" | cut -d: -f1 | sort -u | tr '\n' ' ')"
  rm -f "${TMPDIR:-/tmp}/kestrel-format.$$"
  exit 1
fi
rm -f "${TMPDIR:-/tmp}/kestrel-format.$$"
echo "PASS: $count tracked C++ files formatted ($(clang-format --version | head -1))"
