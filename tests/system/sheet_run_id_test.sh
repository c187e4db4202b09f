#!/usr/bin/env bash
# Run ids through the sheets and the runner (docs/design.md §3.5): the host sheet's mapper,
# started by kestrel-procman, checkpoints, is killed with -9 and respawned by the runner: the
# same run, so it resumes. A new runner is a new run: it sets the previous run's checkpoint aside
# (kept, not overwritten) and starts a fresh map. A runner given that run's id again
# ($KESTREL_RUN_ID, e.g. after the runner itself was restarted) resumes it. LCM over memq://
# (each process alone): the mapper needs no peer to start, load and save its checkpoint.
# Usage: sheet_run_id_test.sh BUILD_DIR ROOT
set -euo pipefail
build=$1; root=$2
cd "$root"
export LCM_DEFAULT_URL="memq://" KESTREL_BIN="$build/bin" KESTREL_RUN
KESTREL_RUN=$(mktemp -d)
unset KESTREL_RUN_ID
runner=""
trap 'if [[ -n $runner ]]; then kill -TERM $runner 2>/dev/null; wait $runner 2>/dev/null; fi; rm -rf "$KESTREL_RUN"' EXIT
ck=$KESTREL_RUN/mapper.kmap
fail() {
  echo "FAIL: $*"
  for f in "$KESTREL_RUN"/*.err "$KESTREL_RUN"/*/mapper.log; do
    if [[ -f $f ]]; then echo "== $f"; tail -15 "$f"; fi
  done
  exit 1
}
wait_for() {  # wait_for SECONDS COMMAND...: until the command succeeds
  local end=$((SECONDS + $1))
  shift
  until "$@"; do
    ((SECONDS < end)) || return 1
    sleep 0.2
  done
}
start_runner() {  # start_runner NAME: a runner of the host sheet that starts only the mapper
  "$build/common/procman/kestrel-procman" scripts/sheets/host.procman --host base \
    --start cmd:mapper --log-dir "$KESTREL_RUN/$1" 2>"$KESTREL_RUN/$1.err" &
  runner=$!
}
stop_runner() {
  kill -TERM $runner
  wait $runner || true
  runner=""
}
run_id_of() {  # run_id_of NAME: the run id the runner NAME announced
  sed -n 's/.* run id \([^ ]*\) .*/\1/p' "$KESTREL_RUN/$1.err" | head -1
}
mapper_pid() { pgrep -f "^$build/bin/kestrel-mapper .*checkpoint_path=$ck" | head -1 || true; }

# Run 1: a fresh map, checkpointed; kill -9; the runner's respawn resumes it.
start_runner run1
wait_for 60 test -s "$ck" || fail "run 1: no checkpoint"
run1=$(run_id_of run1)
[[ -n $run1 ]] || fail "run 1: the runner announced no run id"
pid=$(mapper_pid)
[[ -n $pid ]] || fail "run 1: no mapper process"
kill -9 "$pid"
wait_for 60 grep -qs "resumed from checkpoint $ck of this run '$run1'" "$KESTREL_RUN/run1/mapper.log" ||
  fail "run 1: the respawned mapper did not resume its run's checkpoint"
stop_runner
echo "run 1 ($run1): the mapper killed with -9 was respawned and resumed"

# Run 2: a new runner, a new run: run 1's checkpoint is set aside, the map starts fresh.
start_runner run2
wait_for 60 grep -qs "not resumed, moved to $ck.run-$run1" "$KESTREL_RUN/run2/mapper.log" ||
  fail "run 2: run 1's checkpoint was not set aside"
run2=$(run_id_of run2)
[[ -n $run2 && $run2 != "$run1" ]] || fail "run 2: run id '$run2' is not new"
grep -q "resumed from checkpoint" "$KESTREL_RUN/run2/mapper.log" && fail "run 2 resumed a checkpoint"
grep -qa "$run1" "$ck.run-$run1" || fail "the file set aside is not run 1's checkpoint"
wait_for 60 grep -qsa "$run2" "$ck" || fail "run 2: no checkpoint of its own"
stop_runner
echo "run 2 ($run2): run 1's checkpoint was set aside, the map started fresh"

# Run 3: a runner started with run 2's id continues run 2: the mapper resumes.
export KESTREL_RUN_ID=$run2
start_runner run3
unset KESTREL_RUN_ID
wait_for 60 grep -qs "resumed from checkpoint $ck of this run '$run2'" "$KESTREL_RUN/run3/mapper.log" ||
  fail "run 3: the mapper did not resume run 2's checkpoint"
[[ $(run_id_of run3) == "$run2" ]] || fail "run 3: the runner did not keep \$KESTREL_RUN_ID"
stop_runner
echo "run 3 ($run2 again): resumed"
echo "PASS: a respawn resumes its run's checkpoint, a new run does not"
