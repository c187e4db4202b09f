#!/usr/bin/env bash
# Replay: a mission records every message as an LCM log; lcm-logplayer replays it over
# UDP multicast (private network namespace) into a fresh kestrel-mapper process, whose map must
# equal the live mapper's bit for bit (the live mapper applied every message).
# Usage: replay_test.sh MISSION MAPPER IN_NETNS ROOT
set -euo pipefail
mission=$1; mapper=$2; in_netns=$3; root=$4
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$mission" --root "$root" --world config/worlds/lasr.yaml --sim config/sim/sim_ci.yaml \
  --max-time 40 --no-quality --log "$dir/run.lcmlog" --map "$dir/live.kmap" >"$dir/summary.txt"
grep -q "every message applied: yes" "$dir/summary.txt" || { cat "$dir/summary.txt"; exit 1; }
"$in_netns" bash -c '
  set -euo pipefail
  mapper=$1; root=$2; dir=$3
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  "$mapper" --config "$root/config/mapper.yaml" --lcm-url "$url" \
    --set "map.min_m=[0.5,-8.3,-0.15]" --set "map.max_m=[10.3,3.5,1.5]" \
    --save "$dir/replay.kmap" 2>"$dir/mapper.log" &
  m=$!
  sleep 0.5
  lcm-logplayer --lcm-url="$url" --speed=4 "$dir/run.lcmlog" >/dev/null
  sleep 1
  kill -TERM $m
  wait $m
' _ "$mapper" "$root" "$dir"
if ! cmp "$dir/live.kmap" "$dir/replay.kmap"; then
  echo "FAIL: the replayed map differs from the live map"
  tail -5 "$dir/mapper.log"
  exit 1
fi
echo "PASS: replayed map equals the live map ($(stat -c %s "$dir/live.kmap") bytes, $(stat -c %s "$dir/run.lcmlog") bytes of log)"
