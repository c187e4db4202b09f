#!/usr/bin/env bash
# scripts/sheet-env, which prepares libbot2's own deputy for the sheets: every default of
# scripts/sheets/kestrel.env that the environment leaves unset, a run id, nothing overridden,
# and a malformed line refused with its file and line.
# Usage: sheet_env_test.sh SOURCE_DIR
set -euo pipefail
cd "$1"
fail() { echo "FAIL: $*"; exit 1; }
out=$(env -u KESTREL_BIN -u KESTREL_RUN_ID KESTREL_SPEED=3 scripts/sheet-env env)
grep -qx "KESTREL_SPEED=3" <<<"$out" || fail "a variable already set was overridden"
while IFS= read -r line; do
  [[ $line =~ ^[A-Z_]+= ]] || continue
  name=${line%%=*}
  [[ $name == KESTREL_SPEED ]] && continue
  grep -qxF "$line" <<<"$out" || fail "default $line not applied"
done <scripts/sheets/kestrel.env
grep -Eq "^KESTREL_RUN_ID=[0-9]{8}T[0-9]{6}Z-[0-9a-f]{8}$" <<<"$out" || fail "no run id"
[[ $(KESTREL_RUN_ID=kept scripts/sheet-env printenv KESTREL_RUN_ID) == kept ]] || fail "run id replaced"
bad=$(mktemp)
printf "A=1\nnot an assignment\n" >"$bad"
if msg=$(KESTREL_ENV_FILE=$bad scripts/sheet-env true 2>&1); then fail "a malformed file was accepted"; fi
grep -q "$bad:2: expected NAME=value" <<<"$msg" || fail "no file:line in '$msg'"
rm -f "$bad"
echo PASS
