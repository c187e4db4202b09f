#!/usr/bin/env bash
# kill -9 the mapper process mid-stream, restart it and feed it the stream again from the start:
# it skips what its checkpoint holds (publisher epoch and sequence numbers; the feeder replays one
# recording, so its epoch repeats) and ends bit-identical to an uninterrupted run. Real processes
# over UDP multicast in a private network namespace.
# Usage: mapper_kill_test.sh MAPPER FEEDER IN_NETNS
set -euo pipefail
exec "$3" bash -c '
  set -euo pipefail
  mapper=$1; feeder=$2
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  dir=$(mktemp -d)
  trap "kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  common=(--lcm-url "$url" --set "map.min_m=[-3.2,-4.2,-0.15]" --set "map.max_m=[3.2,4.2,2.7]"
          --set map.resolution_m=0.1 --set snapshot_period_s=0 --set delta_period_s=0)
  # Uninterrupted run.
  "$mapper" "${common[@]}" --save "$dir/a.map" 2>"$dir/a.log" &
  m=$!
  sleep 0.5
  "$feeder" "$url" 8 4
  sleep 0.5
  kill -TERM $m
  wait $m
  # Interrupted run: checkpoint every 0.2 s, kill -9 after about half the stream.
  # One run id for both lives of the mapper (the runner gives a respawn the same one).
  ck=(--set "checkpoint_path=$dir/ck.map" --set checkpoint_period_s=0.2 --set run_id=kill-test)
  "$mapper" "${common[@]}" "${ck[@]}" 2>"$dir/b1.log" &
  m=$!
  sleep 0.5
  "$feeder" "$url" 8 4 &
  f=$!
  sleep 1.0
  kill -9 $m
  wait $f
  test -s "$dir/ck.map" || { echo "FAIL: no checkpoint was written"; exit 1; }
  "$mapper" "${common[@]}" "${ck[@]}" --save "$dir/b.map" 2>"$dir/b2.log" &
  m=$!
  sleep 0.5
  "$feeder" "$url" 8 4
  sleep 0.5
  kill -TERM $m
  wait $m
  grep -q "resumed from checkpoint" "$dir/b2.log" || { echo "FAIL: did not resume"; cat "$dir/b2.log"; exit 1; }
  grep -q "already_applied" "$dir/b2.log" || { echo "FAIL: skipped nothing"; cat "$dir/b2.log"; exit 1; }
  if ! cmp "$dir/a.map" "$dir/b.map"; then
    echo "FAIL: maps differ"; cat "$dir/a.log" "$dir/b2.log"; exit 1
  fi
  grep "resumed" "$dir/b2.log"
  echo "PASS: resumed map is bit-identical to the uninterrupted run ($(stat -c %s "$dir/a.map") bytes)"
' _ "$1" "$2"
