#!/usr/bin/env bash
# kestrel-vicon and kestrel-vicon-emitter as separate processes in a private network namespace:
# the emitter streams the synthetic circle over UDP on 127.0.0.1, kestrel-vicon publishes pose_t
# over LCM UDP multicast, a listener counts them. Then the emitter stops: kestrel-vicon must
# publish valid = false (never its last pose) and degrade its heartbeat; SIGTERM exits 0.
# Usage: vicon_processes_test.sh KESTREL_VICON KESTREL_VICON_EMITTER LISTENER IN_NETNS
set -euo pipefail
exec "$4" bash -c '
  set -euo pipefail
  vicon=$1; emitter=$2; listener=$3
  url="udpm://239.255.76.67:7667?ttl=0"
  out=$(mktemp)
  "$listener" "$url" 4 >"$out" &
  listener_pid=$!
  for i in $(seq 100); do grep -q ready "$out" && break; sleep 0.05; done
  "$vicon" --lcm-url "$url" --set bind_address=127.0.0.1 --set port=51001 &
  vicon_pid=$!
  "$emitter" --lcm-url "$url" --set port=51001 --set source=synthetic --set rate_hz=100 &
  emitter_pid=$!
  sleep 2.2
  kill -TERM $emitter_pid
  wait $emitter_pid
  wait $listener_pid
  kill -TERM $vicon_pid
  vicon_status=0
  wait $vicon_pid || vicon_status=$?
  cat "$out"
  read -r _ valid _ invalid _ last_valid _ heartbeats _ last_state _ malformed _ error \
    < <(grep "^valid" "$out")
  rm -f "$out"
  fail=0
  check() { if ! eval "$1"; then echo "FAILED: $1" >&2; fail=1; fi; }
  check "[[ $valid -ge 100 ]]"          # ~200 frames at 100 Hz in ~2 s (slack for load)
  check "[[ $invalid -ge 5 ]]"          # repeated at 10 Hz after the 0.1 s time-out
  check "[[ $last_valid -eq 0 ]]"       # the stream ends invalid, not with a stale pose
  check "[[ $heartbeats -ge 3 ]]"
  check "[[ $last_state -eq 2 ]]"       # STATE_DEGRADED once the object is lost
  check "[[ $malformed -eq 0 ]]"
  check "[[ $vicon_status -eq 0 ]]"
  check "awk \"BEGIN { exit !($error < 1e-9) }\""
  exit $fail
' _ "$1" "$2" "$3"
