#!/usr/bin/env bash
# Two processes over real LCM UDP multicast inside a private network namespace: one publishes
# COUNT samples of every Kestrel type, the other must receive every one intact (counts, never
# rates). Usage: multiprocess_test.sh LCM_PEER IN_NETNS
set -euo pipefail
peer=$1
in_netns=$2
exec "$in_netns" bash -c '
  set -euo pipefail
  peer=$1
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
  out=$(mktemp)
  "$peer" receive "$url" 50 30 >"$out" &
  receiver=$!
  for i in $(seq 100); do grep -q ready "$out" && break; sleep 0.05; done
  "$peer" publish "$url" 50 5
  status=0
  wait $receiver || status=$?
  cat "$out"
  rm -f "$out"
  exit $status
' _ "$peer"
