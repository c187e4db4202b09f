#!/usr/bin/env bash
# Two vehicles as separate processes over UDP multicast in a private network namespace
# (docs/design.md §7.10): one kestrel-sim flying V1_ and V2_, one kestrel-controller per vehicle
# on its prefixed channels, and kestrel-cmd commanding all of them, then one.
# Usage: two_vehicle_processes_test.sh BIN_DIR SOURCE_DIR IN_NETNS
set -euo pipefail
exec "$3" bash -c '
  set -euo pipefail
  bin=$1; cd "$2"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
  dir=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 0.5; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  fail() { echo "FAIL: $*"; for f in "$dir"/*; do echo "== $f"; tail -5 "$f"; done; exit 1; }
  "$bin/kestrel-sim" --config config/sim/sim_ci.yaml --set world_file=config/worlds/lasr.yaml \
    --set speed_factor=1 --set depth.enabled=false --set lidar.enabled=false \
    --set "vehicles=[{prefix: V1_, start_offset_m: [0, 0, 0]}, {prefix: V2_, start_offset_m: [1.5, 0, 0]}]" \
    >"$dir/sim.log" 2>&1 &
  for p in V1_ V2_; do
    sets=()
    for c in pose:POSE_VICON imu:IMU trajectory:TRAJECTORY command:COMMAND motor:MOTOR_COMMAND \
             status:CONTROLLER_STATUS heartbeat:HEARTBEAT_CONTROLLER; do
      sets+=(--set "channels.${c%%:*}=$p${c##*:}")
    done
    "$bin/kestrel-controller" --vehicle config/vehicle/paper.yaml --sim-clock "${p}SIM_TRUTH" \
      --set "safety.geofence_min_m=[0.3,-8.5,-0.35]" --set "safety.geofence_max_m=[10.5,3.7,2.5]" \
      "${sets[@]}" >"$dir/controller-$p.log" 2>&1 &
  done
  sleep 2
  "$bin/kestrel-cmd" takeoff --vehicle all --height 0.8 --wait 10 >"$dir/takeoff.txt" ||
    fail "take-off not confirmed by both"
  for p in V1_ V2_; do
    grep -qx "sent takeoff on ${p}COMMAND" "$dir/takeoff.txt" || fail "no take-off sent to $p"
    grep -qx "controller confirmed (${p}CONTROLLER_STATUS)" "$dir/takeoff.txt" || fail "$p did not take off"
  done
  sleep 6
  "$bin/kestrel-cmd" land --vehicle V2_ --wait 5 >"$dir/land.txt" || fail "V2_ did not land"
  grep -qx "sent land on V2_COMMAND" "$dir/land.txt" || fail "land went elsewhere"
  # The other vehicle still holds: a hold order is confirmed at once, and it is not landing.
  "$bin/kestrel-cmd" hold --vehicle V1_ --wait 2 >"$dir/hold.txt" || fail "V1_ is not holding"
  if "$bin/kestrel-cmd" takeoff --vehicle all --channel COMMAND >/dev/null 2>&1; then
    fail "--vehicle and --channel together were accepted"
  fi
  cat "$dir/takeoff.txt" "$dir/land.txt" "$dir/hold.txt"
  echo PASS
' _ "$1" "$2"
