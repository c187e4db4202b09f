#!/usr/bin/env bash
# Two process-sheet runners ("vehicle" and "host") over real UDP multicast in a private network
# namespace, driven by kestrel-cmd procman as a bot-procman sheriff (PMD_INFO2, PMD_ORDERS2):
# start everything, stop one command on one host, restart one (a new run id), respawn a killed
# auto_respawn command, and on SIGTERM every child is stopped and the runners exit 0.
# Usage: procman_multiprocess_test.sh PROCMAN_BIN CMD_BIN IN_NETNS
set -euo pipefail
exec "$3" bash -c '
  set -euo pipefail
  procman=$1; cmd=$2
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
  dir=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 0.5; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  cat >"$dir/test.procman" <<SHEET
group "vehicle" {
  cmd "a" { exec = "sleep 60"; host = "vehicle"; }
  cmd "b" { exec = "sleep 60"; host = "vehicle"; auto_respawn = "true"; }
}
cmd "c" { exec = "sleep 60"; host = "host"; stop_signal = 15; }
SHEET
  "$procman" "$dir/test.procman" --host vehicle --log-dir "$dir/vlogs" 2>"$dir/vehicle.err" &
  vehicle=$!
  "$procman" "$dir/test.procman" --host host --log-dir "$dir/hlogs" 2>"$dir/host.err" &
  host=$!
  sleep 0.5
  fail() { echo "FAIL: $*"; cat "$dir"/list*.txt 2>/dev/null; exit 1; }
  state() {  # state FILE ID -> the state column of command ID
    awk -v id="$2" "\$1 == id { print \$2 }" "$1"
  }
  pid_of() { awk -v id="$2" "\$1 == id { print \$4 }" "$1"; }

  runid() { awk -v id="$2" "\$1 == id { print \$6 }" "$1"; }

  sleep 1.6  # the bot-procman discovery of both runners
  "$cmd" procman start all >"$dir/start.txt" || fail "start all not confirmed: $(cat "$dir/start.txt")"
  grep -q "^start all on vehicle: done" "$dir/start.txt" || fail "vehicle not ordered"
  grep -q "^start all on host: done" "$dir/start.txt" || fail "host not ordered"
  "$cmd" procman list --seconds 1.5 >"$dir/list1.txt" || fail "no runner status"
  for id in a b c; do
    [[ $(state "$dir/list1.txt" $id) == running ]] || fail "$id not running after start all"
  done

  [[ $(runid "$dir/list1.txt" a) == 1 ]] || fail "a is not in run 1"

  "$cmd" procman stop cmd:a --host vehicle || fail "stop not confirmed"
  "$cmd" procman list --seconds 1.5 >"$dir/list2.txt"
  [[ $(state "$dir/list2.txt" a) == stopped ]] || fail "a not stopped"
  [[ $(state "$dir/list2.txt" c) == running ]] || fail "c on the other host was touched"

  c_first=$(pid_of "$dir/list2.txt" c)
  "$cmd" procman restart cmd:c || fail "restart not confirmed"
  "$cmd" procman list --seconds 1.5 >"$dir/list2b.txt"
  [[ $(state "$dir/list2b.txt" c) == running ]] || fail "c not running after its restart"
  [[ $(pid_of "$dir/list2b.txt" c) != "$c_first" ]] || fail "c was not restarted"
  [[ $(runid "$dir/list2b.txt" c) == 2 ]] || fail "c restarted outside run 2"
  if "$cmd" procman stop cmd:nosuch >"$dir/nosuch.txt" 2>&1; then fail "an unknown command was ordered"; fi

  b_pid=$(pid_of "$dir/list2.txt" b)
  kill -9 "$b_pid"
  sleep 2.0
  "$cmd" procman list --seconds 1.5 >"$dir/list3.txt"
  [[ $(state "$dir/list3.txt" b) == running ]] || fail "b not respawned"
  new_b=$(pid_of "$dir/list3.txt" b)
  [[ "$new_b" != "$b_pid" ]] || fail "b has the same pid"
  [[ $(runid "$dir/list3.txt" b) == 1 ]] || fail "a respawn is not a new run"

  c_pid=$(pid_of "$dir/list3.txt" c)
  kill -TERM $vehicle $host
  wait $vehicle || fail "vehicle runner exit code $?"
  wait $host || fail "host runner exit code $?"
  for p in $new_b $c_pid; do
    if kill -0 "$p" 2>/dev/null; then fail "child $p survived its runner"; fi
  done
  cat "$dir/list3.txt"
  echo PASS
' _ "$1" "$2"
