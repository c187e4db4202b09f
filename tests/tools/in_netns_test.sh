#!/usr/bin/env bash
# tests/tools/in_netns.sh: where unshare works, the command sees only a loopback interface with
# multicast on; where the machine refuses a namespace (emulated by an unshare on PATH that fails
# as the kernel does, "Operation not permitted"), it exits 77 with the KESTREL-SKIP reason that
# makes ctest skip the multi-process tests instead of failing them.
# Usage: in_netns_test.sh SOURCE_ROOT
set -uo pipefail
in_netns=$1/tests/tools/in_netns.sh
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# 1. Refused: exit 77, the marker and unshare's own words, and the command never ran.
cat >"$work/unshare" <<'STUB'
#!/bin/sh
echo "unshare: unshare failed: Operation not permitted" >&2
exit 1
STUB
chmod +x "$work/unshare"
PATH="$work:$PATH" "$in_netns" touch "$work/ran" >"$work/out.txt" 2>&1
rc=$?
[[ $rc -eq 77 ]] || fail "refused namespace: exit $rc, expected 77"
grep -q "^KESTREL-SKIP: no private network namespace here: .*Operation not permitted" \
  "$work/out.txt" || fail "refused namespace: no KESTREL-SKIP reason: $(cat "$work/out.txt")"
[[ ! -e $work/ran ]] || fail "refused namespace: the command ran anyway"

# 2. Allowed (where it is): only lo, up, with multicast.
if unshare --net true 2>/dev/null || unshare --map-root-user --net true 2>/dev/null; then
  links=$("$in_netns" ip -o link show) || fail "in_netns.sh ip -o link show failed"
  [[ $(echo "$links" | grep -c .) -eq 1 ]] || fail "more than one interface: $links"
  echo "$links" | grep -q "lo: <LOOPBACK,MULTICAST,UP" || fail "lo not up with multicast: $links"
  route=$("$in_netns" ip route show 224.0.0.0/4)
  [[ $route == *"dev lo"* ]] || fail "multicast not routed to lo: $route"
else
  echo "this machine refuses network namespaces: part 2 not run"
fi
echo "$failures failures"
[[ $failures -eq 0 ]]
