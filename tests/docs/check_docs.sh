#!/usr/bin/env bash
# Checks that the repository documents itself:
#  1. no tracked file cites a design page that is not in the repository (the former out-of-tree
#     pages, in any path form, or their folder) or a work item by number ("issue 7"): a reader
#     following such a reference finds nothing;
#  2. every citation of a page by section, "docs/<name>.md §N" or "§N.M" (also "<name>.md §N" in
#     docs/, lists such as "§3.5, §4.2" and ranges such as "§6-§9"), names a file docs/<name>.md
#     that has a heading with exactly that section number ("## §N ..." or "### §N.M ...");
#  3. no page of docs/ numbers two headings alike;
#  4. a bare "§N" names its page outside docs/, and resolves in its own page inside docs/.
# Usage: check_docs.sh SOURCE_DIR. Files are those git tracks (the working tree's content), or
# every file under SOURCE_DIR but build*/ and .git/ when SOURCE_DIR is not a git work tree;
# tests/docs/ (this check and its self-test) is left out.
# Exit status 0 when everything holds, 1 with one line per finding otherwise.
set -euo pipefail
export LC_ALL=C  # byte-wise matching; "§" is the two bytes C2 A7 in UTF-8
src=${1:?usage: check_docs.sh SOURCE_DIR}
cd "$src"

files=()
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  while IFS= read -r -d '' f; do
    [[ -f $f ]] && files+=("$f")
  done < <(git ls-files -z)
else
  while IFS= read -r -d '' f; do
    files+=("${f#./}")
  done < <(find . -path ./.git -prune -o -path './build*' -prune -o -type f -print0)
fi
# This check and its self-test quote bad references on purpose.
kept=()
for f in "${files[@]}"; do
  [[ $f == tests/docs/* ]] || kept+=("$f")
done
files=("${kept[@]}")
if [[ ${#files[@]} -eq 0 ]]; then
  echo "check_docs: no files found under $src" >&2
  exit 1
fi

failures=0
fail() {
  echo "$1"
  failures=$((failures + 1))
}

# 1. References that lead nowhere. The names are split here so that this file does not match.
gone_pages='(ALGO''RITHMS|DE''SIGN|PROTO''COLS|STY''LE)\.md'
gone_folder='\.\./sha''red([/ ]|$)'
work_item='[Ii]ssues? #?[0-9]+'
while IFS= read -r hit; do
  fail "out-of-tree design page: $hit"
done < <(grep -InHE "$gone_pages|$gone_folder" -- "${files[@]}" || true)
while IFS= read -r hit; do
  fail "work item cited by number (state the fact instead): $hit"
done < <(grep -InHE "$work_item" -- "${files[@]}" || true)

# 3. Section numbers of each page: unique.
for page in docs/*.md; do
  [[ -f $page ]] || continue
  while IFS= read -r dup; do
    fail "$page: two headings numbered $dup"
  done < <({ grep -oE '^#+ §[0-9]+(\.[0-9]+)? ' "$page" || true; } | awk '{print $2}' | sort | uniq -d)
done

# 2 and 4. Citations by section, in one pass (awk) over every line holding a "§".
headings=$(mktemp)
trap 'rm -f "$headings"' EXIT
for page in docs/*.md; do
  [[ -f $page ]] || continue
  { grep -oE '^#+ §[0-9.]+( |$)' "$page" || true; } |
    awk -v page="$page" '{sub(/^§/, "", $2); print page, $2}'
done >"$headings"
report=$(grep -IHnE -- "§" "${files[@]}" | awk -v headings="$headings" '
  BEGIN {
    while ((getline h < headings) > 0) { split(h, f, " "); has[f[1] " " f[2]] = 1; pages[f[1]] = 1 }
    sec = "§[0-9]+(\\.[0-9]+)?"
    cite = "([A-Za-z0-9_./-]*/)?[a-z_]+\\.md\\]? ?,? " sec "((, | and |-|, and )" sec ")*"
  }
  function numbers(text, out,   n, t) {  # the section numbers in text, into out[1..n]
    n = 0
    while (match(text, sec)) {
      t = substr(text, RSTART, RLENGTH); sub(/^§/, "", t); out[++n] = t
      text = substr(text, RSTART + RLENGTH)
    }
    return n
  }
  {
    where = $0; sub(/:.*/, "", where)
    rest = substr($0, length(where) + 2); line = rest; sub(/:.*/, "", line)
    text = substr(rest, length(line) + 2)
    remaining = ""
    while (match(text, cite)) {
      c = substr(text, RSTART, RLENGTH)
      remaining = remaining substr(text, 1, RSTART - 1) " "
      text = substr(text, RSTART + RLENGTH)
      target = c; sub(/\.md.*/, "", target); sub(/^\[/, "", target)
      name = target; sub(/.*\//, "", name)
      page = "docs/" name ".md"
      if (index(target, "/") > 0) {
        if (target !~ /^docs\// && target !~ /\/docs\//) continue
      } else if (where !~ /^docs\// && !(page in pages)) continue
      if (!(page in pages)) { print where ":" line ": cites " name ".md, which is not in docs/: " c; continue }
      n = numbers(c, nums)
      for (i = 1; i <= n; i++) {
        seen[page " " nums[i]] = 1
        if (!((page " " nums[i]) in has)) print where ":" line ": " page " has no section §" nums[i] ": " c
      }
    }
    remaining = remaining text
    n = numbers(remaining, nums)
    if (n == 0) next
    if (where !~ /^docs\/[^\/]*\.md$/) { print where ":" line ": a section number without the page it belongs to: " $0; next }
    for (i = 1; i <= n; i++)
      if (!((where " " nums[i]) in has)) print where ":" line ": no section §" nums[i] " in this page"
  }
  END { for (k in seen) distinct++; print "CITED " distinct + 0 }
' || true)
count=0
while IFS= read -r finding; do
  [[ -n $finding ]] || continue
  if [[ $finding == "CITED "* ]]; then
    count=${finding#CITED }
  else
    fail "$finding"
  fi
done <<<"$report"

if [[ $failures -gt 0 ]]; then
  echo "check_docs: $failures finding(s)"
  exit 1
fi
echo "check_docs: ${#files[@]} files, $count distinct section citations resolve, no dangling references"
