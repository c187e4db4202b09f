#!/usr/bin/env bash
# lcm-logger records every Kestrel type published by one process; lcm-logplayer replays the
# log into a receiver that checks every sample byte for byte and the count of each type.
# Runs inside a private network namespace. Usage: logger_test.sh LCM_PEER IN_NETNS
# (Debian's LCM 1.3.1 lcm-logger: the short -l option is broken, use --lcm-url=.)
set -euo pipefail
peer=$1
in_netns=$2
exec "$in_netns" bash -c '
  set -euo pipefail
  peer=$1
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
  dir=$(mktemp -d)
  trap "kill \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  lcm-logger --quiet --force --lcm-url="$url" "$dir/run.lcmlog" &
  logger=$!
  sleep 0.5
  "$peer" publish "$url" 30 10
  sleep 0.5
  kill -INT $logger
  wait $logger || true
  test -s "$dir/run.lcmlog"
  "$peer" receive "$url" 30 30 >"$dir/out" &
  receiver=$!
  for i in $(seq 100); do grep -q ready "$dir/out" && break; sleep 0.05; done
  lcm-logplayer --lcm-url="$url" --speed=1 "$dir/run.lcmlog"
  status=0
  wait $receiver || status=$?
  cat "$dir/out"
  exit $status
' _ "$peer"
