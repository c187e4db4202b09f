#!/usr/bin/env bash
# Shows that check_docs.sh fails when it should: in a scratch tree (not a git work tree) it must
# pass on good citations and fail on each kind of bad one, naming the file and line.
# Usage: check_docs_selftest.sh CHECK_DOCS_SH
set -euo pipefail
export LC_ALL=C
check=${1:?usage: check_docs_selftest.sh CHECK_DOCS_SH}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/docs" "$tmp/src"
cat >"$tmp/docs/algorithms.md" <<'MD'
# Algorithms
## §1 Grid
### §1.1 Cells
See §1.1 above and [design.md §2](design.md).
## §2 Rays
MD
cat >"$tmp/docs/design.md" <<'MD'
# Design
## §2 Processes
MD
good='// docs/algorithms.md §1.1, §2 and docs/design.md §2; ranges: docs/algorithms.md §1-§2'

expect() {  # expect PASS|FAIL PATTERN: run the check on the scratch tree
  local want=$1 pattern=$2 out rc=0
  out=$(bash "$check" "$tmp" 2>&1) || rc=$?
  if [[ $want == PASS && $rc -ne 0 ]] || [[ $want == FAIL && $rc -eq 0 ]]; then
    echo "expected $want, got rc=$rc for: $(cat "$tmp/src/a.h")"
    echo "$out"
    exit 1
  fi
  if [[ -n $pattern ]] && ! grep -qE -- "$pattern" <<<"$out"; then
    echo "expected a finding matching '$pattern', got:"
    echo "$out"
    exit 1
  fi
}

echo "$good" >"$tmp/src/a.h"
expect PASS ""
cases=(
  "// docs/algorithms.md §1.2|src/a.h:2: docs/algorithms.md has no section §1.2"
  "// docs/algorithms.md §1.1, §3|no section §3"
  "// docs/algorithms.md §1-§4|no section §4"
  "// docs/geometry.md §1|cites geometry.md, which is not in docs/"
  "// see §1.1|a section number without the page"
  "// ALGO""RITHMS.md section 4|out-of-tree design page"
  "// ../sha""red/notes.md|out-of-tree design page"
  "// see is""sue 12|work item cited by number"
  "// Is""sue #3: fixed|work item cited by number"
)
for c in "${cases[@]}"; do
  printf '%s\n%s\n' "$good" "${c%%|*}" >"$tmp/src/a.h"
  expect FAIL "${c#*|}"
done
# A page whose own reference does not resolve, and a page numbering two headings alike.
echo "$good" >"$tmp/src/a.h"
echo 'As §9 says.' >>"$tmp/docs/algorithms.md"
expect FAIL "docs/algorithms.md:6: no section §9 in this page"
sed -i '$d' "$tmp/docs/algorithms.md"
echo '## §2 Again' >>"$tmp/docs/algorithms.md"
expect FAIL "two headings numbered §2"
echo "check_docs_selftest: ${#cases[@]} + 2 bad cases caught, good citations pass"
