#!/usr/bin/env bash
# A mixed deployment over real UDP multicast in a private network namespace: a Kestrel runner
# (kestrel-procman, host "kestrel") beside a deputy that speaks only bot-procman
# (bot_procman_deputy.py, host "py": libbot2's protocol written independently, no Kestrel message,
# no sheet, no command until a sheriff creates them), docs/protocols.md §5.
#  1. The sheet's script, run by the Kestrel runner, orders the py deputy's commands through
#     PMD_ORDERS2 as a sheriff does: creates them there, starts one, waits for it to run (py's
#     info2_t), starts one of its own, restarts py's (a new run id), stops py's group and waits
#     for it to stop; then the runner exits (--exit-after-script).
#  2. kestrel-cmd procman as the only sheriff: load creates the sheet's commands on a fresh py
#     deputy (and finds the Kestrel runner's own), output follows a command's PMD_PRINTF, start
#     and stop act on both deputies, list shows it.
# Usage: procman_mixed_test.sh PROCMAN_BIN CMD_BIN IN_NETNS LCMTYPES_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exec "$3" bash -c '
  set -euo pipefail
  procman=$1; cmd=$2; types=$3; here=$4
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
  dir=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 0.5; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  fail() { echo "FAIL: $*"; for f in "$dir"/*.txt "$dir"/*.err; do echo "== $f"; tail -n 12 "$f"; done; exit 1; }
  cat >"$dir/mixed.procman" <<SHEET
cmd "k1" { exec = "sh -c '"'"'echo k1-says-hi; exec sleep 60'"'"'"; host = "kestrel"; }
group "py" {
  cmd "p1" { exec = "sh -c '"'"'echo p1-says-\$MIXED_WORD; exec sleep 60'"'"'"; host = "py"; stop_signal = 15; }
  cmd "p2" { exec = "sleep 60"; host = "py"; }
}
script "go" {
  start cmd "p1" wait "running";
  start cmd "k1" wait "running";
  restart cmd "p1" wait "running";
  stop group "py" wait "stopped";
}
SHEET
  # The list columns: name state pid N runid N ...
  column() { awk -v id="$2" -v c="$3" "\$1 == id { print \$c }" "$1"; }
  py_deputy() { MIXED_WORD=hello python3 "$here/bot_procman_deputy.py" "$types" --name py 2>>"$dir/py.err" & }

  # 1. A script across the two.
  py_deputy; py=$!
  start_s=$(date +%s.%N)
  timeout 20 "$procman" "$dir/mixed.procman" --host kestrel --script go --exit-after-script \
    --log-dir "$dir/klogs" 2>"$dir/runner.err" || fail "the script did not finish (exit $?)"
  took=$(awk -v a="$start_s" -v b="$(date +%s.%N)" "BEGIN { printf \"%.1f\", b - a }")
  grep -q "script \"go\" done" "$dir/runner.err" || fail "no script done in the runner log"
  "$cmd" procman list --seconds 1.2 >"$dir/list1.txt" || fail "no deputy listed"
  [[ $(column "$dir/list1.txt" p1 2) == stopped && $(column "$dir/list1.txt" p1 6) == 2 ]] ||
    fail "p1 on py is not stopped in run 2 (started, restarted, stopped by the script)"
  [[ $(column "$dir/list1.txt" p2 2) == stopped && $(column "$dir/list1.txt" p2 6) == 0 ]] ||
    fail "p2 was not created stopped on py"
  [[ $(column "$dir/list1.txt" p1 8) == "signal" && $(column "$dir/list1.txt" p1 9) == 15 ]] ||
    fail "p1 was not stopped with its stop signal 15"
  echo "script across a Kestrel runner and a protocol-only deputy: done in $took s; py: p1 run 2 stopped by signal 15, p2 created"
  kill -TERM $py; wait $py || fail "the py deputy did not exit 0"

  # 2. kestrel-cmd procman: load, output, start, stop, list.
  py_deputy; py=$!
  "$procman" "$dir/mixed.procman" --host kestrel --log-dir "$dir/klogs" 2>"$dir/runner2.err" &
  runner=$!
  sleep 1.6  # both deputies discovery windows
  "$cmd" procman load "$dir/mixed.procman" >"$dir/load.txt" || fail "load not confirmed"
  grep -q "on py: done" "$dir/load.txt" && grep -q "on kestrel: done" "$dir/load.txt" ||
    fail "load did not reach both deputies"
  "$cmd" procman output group:py --seconds 3 >"$dir/output.txt" &
  output=$!
  "$cmd" procman start all >"$dir/start.txt" || fail "start all not confirmed"
  grep -q "start all on py: done" "$dir/start.txt" && grep -q "start all on kestrel: done" "$dir/start.txt" ||
    fail "start all did not reach both deputies"
  wait $output
  grep -qx "\[py p1\] p1-says-hello" "$dir/output.txt" || fail "p1 output not followed"
  if grep -q k1-says "$dir/output.txt"; then fail "output group:py showed k1"; fi
  "$cmd" procman stop group:py >"$dir/stop.txt" || fail "stop not confirmed"
  "$cmd" procman list --seconds 1.2 >"$dir/list3.txt"
  [[ $(column "$dir/list3.txt" p1 2) == stopped && $(column "$dir/list3.txt" p2 2) == stopped &&
     $(column "$dir/list3.txt" p1 6) == 1 && $(column "$dir/list3.txt" p2 6) == 1 &&
     $(column "$dir/list3.txt" k1 2) == running ]] ||
    fail "start all then stop group:py: not p1 and p2 stopped in run 1 and k1 running"
  echo "kestrel-cmd procman against both: load created p1, p2 on py; start all ran k1, p1, p2; output: $(head -1 "$dir/output.txt"); stop group:py"
  kill -TERM $runner $py
  wait $runner || fail "the runner exit code $?"
  wait $py || fail "the py deputy exit code $?"
  echo PASS
' _ "$1" "$2" "$4" "$here"
