#!/usr/bin/env bash
# Ctrl-C and SIGTERM end every long-running Kestrel program within a second (timeout, a runner's
# stop and a user's Ctrl-C rely on it), in a private network namespace. Each program is started in
# a mode that runs until stopped (a process over UDP LCM, a driver retrying a missing device, a
# tool listening, a batch tool reading a FIFO that never fills) and, once running, sent SIGINT;
# a second instance is sent SIGTERM. It must exit within 1 s: a process that handles the signal
# with 0 (its shutdown hooks ran), a tool cut short with 128 + the signal, a batch tool killed by
# the signal. kestrel-mission, interrupted mid-flight, must also write its summary ("end:
# interrupted by SIGINT ...") and every file asked for (the map loads, the CSV has rows).
# Usage: signals_test.sh BUILD_DIR ROOT IN_NETNS
set -euo pipefail
build=$1; root=$2; in_netns=$3
exec "$in_netns" bash -c '
  set -uo pipefail
  build=$1; root=$2
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
  dir=$(mktemp -d)
  trap "kill -9 \$(jobs -p) 2>/dev/null; rm -rf \$dir" EXIT
  failures=0
  fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
  world=tests/system/worlds/small_room.yaml
  cat >"$dir/sleep.procman" <<SHEET
cmd "nap" { exec = "sleep 60"; host = "h"; }
SHEET
  mkfifo "$dir/fifo.lcmlog" "$dir/fifo.kmap" "$dir/fifo.yaml"
  # name | expected exit ("0": a clean exit; "sig": 128 + signal or killed by it) | command line
  # (@N@ is replaced by the instance number, so that two instances do not share a port or a file).
  programs=(
    "kestrel-mapper|0|$build/bin/kestrel-mapper --config config/mapper.yaml"
    "kestrel-controller|0|$build/bin/kestrel-controller"
    "kestrel-explorer|0|$build/bin/kestrel-explorer --config config/exploration/explorer.yaml"
    "kestrel-sim|0|$build/bin/kestrel-sim --config config/sim/sim_ci.yaml --set world_file=$world"
    "kestrel-sim-standin|0|$build/bin/kestrel-sim-standin --config config/sim/standin.yaml --set sensor=depth"
    "kestrel-procman|0|$build/bin/kestrel-procman $dir/sleep.procman --host h@N@ --start all --log-dir $dir/logs@N@"
    "kestrel-vicon|0|$build/bin/kestrel-vicon --config config/drivers/vicon.yaml --set port=5100@N@"
    "kestrel-vicon-emitter|0|$build/bin/kestrel-vicon-emitter --set source=synthetic --set port=5100@N@"
    "kestrel-hokuyo|0|$build/bin/kestrel-hokuyo --config config/drivers/hokuyo.yaml --set port=$dir/no-lidar"
    "kestrel-hokuyo-emulator|0|$build/bin/kestrel-hokuyo-emulator --set link_path=$dir/lidar@N@"
    "kestrel-xtion|0|$build/bin/kestrel-xtion --config config/drivers/xtion.yaml"
    "kestrel-imu|0|$build/bin/kestrel-imu --config config/drivers/imu.yaml --set port=$dir/no-imu"
    "kestrel-imu-emulator|0|$build/bin/kestrel-imu-emulator --set source=synthetic --set link_path=$dir/imu@N@"
    "kestrel-motors|0|$build/bin/kestrel-motors --config config/drivers/motors.yaml --set bus=unix:$dir/no-esc"
    "kestrel-esc-emulator|0|$build/bin/kestrel-esc-emulator --set bus=unix:$dir/esc@N@.sock"
    "kestrel-viewer|0|$build/bin/kestrel-viewer --set port=0 --set foxglove.port=0"
    "kestrel-devices|0|$build/bin/kestrel-devices --watch 60"
    "kestrel-flight-check|sig|$build/bin/kestrel-flight-check $LCM_DEFAULT_URL 60"
    "kestrel-fault|sig|$build/bin/kestrel-fault malformed --seconds-listen 60"
    "kestrel-cmd status|sig|$build/bin/kestrel-cmd status --seconds 60"
    "kestrel-cmd procman output|sig|$build/bin/kestrel-cmd procman output all"
    "kestrel-mapper --replay|sig|$build/bin/kestrel-mapper --replay $dir/fifo.lcmlog"
    "kestrel-map-score|sig|$build/bin/kestrel-map-score --world $world --map $dir/fifo.kmap"
    "kestrel-fidelity|sig|$build/bin/kestrel-fidelity --log $dir/fifo.lcmlog --world $world"
    "kestrel-calibrate|sig|$build/bin/kestrel-calibrate --log $dir/fifo.lcmlog --world $world"
  )
  # kestrel-mcap-export and kestrel-report-export refuse a FIFO (they size the log first) and
  # take a fraction of a second on a test-sized log: not measured here; they end on a signal as
  # the batch tools above do (NodeLoop::RestoreDefaultSignalActions).
  declare -A pids
  start_all() {  # start_all N: every program, instance N
    for entry in "${programs[@]}"; do
      IFS="|" read -r name expected line <<<"$entry"
      # shellcheck disable=SC2086  # the words of the command line
      ${line//@N@/$1} >"$dir/out-$1-${name// /_}.txt" 2>&1 </dev/null &
      pids[$name]=$!
    done
  }
  # stop_each N SIGNAL: signals each program in turn and measures how long it takes to exit.
  stop_each() {
    local n=$1 sig=$2 code=$3 name expected line pid t0 ms status
    for entry in "${programs[@]}"; do
      IFS="|" read -r name expected line <<<"$entry"
      pid=${pids[$name]}
      if ! kill -0 "$pid" 2>/dev/null; then
        wait "$pid"; status=$?
        fail "$name exited (status $status) before the signal: $(tail -c 300 "$dir/out-$n-${name// /_}.txt")"
        continue
      fi
      t0=$(date +%s%N)
      kill -s "$sig" "$pid"
      for i in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.01; done
      ms=$(( ($(date +%s%N) - t0) / 1000000 ))
      if kill -0 "$pid" 2>/dev/null; then
        fail "$name still runs 1 s after $sig"; kill -9 "$pid"; wait "$pid" 2>/dev/null
        continue
      fi
      wait "$pid"; status=$?
      if [[ $expected == 0 && $status -ne 0 ]] || [[ $expected == sig && $status -ne $code ]]; then
        fail "$name: exit status $status after $sig (expected $([[ $expected == 0 ]] && echo 0 || echo $code)): $(tail -c 300 "$dir/out-$n-${name// /_}.txt")"
        continue
      fi
      printf "%-26s %s: exit %3d after %4d ms\n" "$name" "$sig" "$status" "$ms"
    done
  }
  # kestrel-mission mid-flight (started beside the others): the summary of the flight so far
  # and every file asked for.
  start_mission() {
    "$build/bin/kestrel-mission" --world $world --sim config/sim/sim_ci.yaml --seed 3 --progress 0 \
      --max-time 300 --map "$dir/m-$1.kmap" --csv "$dir/m-$1.csv" >"$dir/mission-$1.txt" 2>&1 &
    mission=$!
  }
  stop_mission() {
    local sig=$1 code=$2 t0 ms status
    t0=$(date +%s%N)
    kill -s $sig $mission
    for i in $(seq 100); do kill -0 $mission 2>/dev/null || break; sleep 0.01; done
    ms=$(( ($(date +%s%N) - t0) / 1000000 ))
    if kill -0 $mission 2>/dev/null; then fail "kestrel-mission still flies 1 s after SIG$sig"; kill -9 $mission; fi
    wait $mission; status=$?
    [[ $status -eq $code ]] || fail "kestrel-mission exited $status after SIG$sig, not $code"
    grep -q "^end: interrupted by SIG$sig (interrupted after .* s simulated)" "$dir/mission-$sig.txt" ||
      fail "kestrel-mission: no interrupted summary: $(grep -v "^\[" "$dir/mission-$sig.txt" | head -3)"
    grep -q "^known fraction: " "$dir/mission-$sig.txt" || fail "kestrel-mission: no figures in its summary"
    [[ $(wc -l <"$dir/m-$sig.csv") -ge 2 ]] || fail "kestrel-mission: no CSV rows written"
    "$build/bin/kestrel-map-score" --world $world --map "$dir/m-$sig.kmap" >"$dir/score-$sig.txt" 2>&1 ||
      fail "kestrel-mission: the map written on SIG$sig does not load: $(tail -2 "$dir/score-$sig.txt")"
    printf "%-26s %s: exit %3d after %4d ms; %s; map and CSV written\n" kestrel-mission "$sig" "$status" \
      "$ms" "$(grep "^end: " "$dir/mission-$sig.txt" | cut -c1-80)"
  }
  start_all 1
  start_mission INT
  sleep 2.5  # every program past its start-up (the simulator builds its world, ...)
  stop_each 1 INT 130
  stop_mission INT 130
  start_all 2
  start_mission TERM
  sleep 2.5
  stop_each 2 TERM 143
  stop_mission TERM 143
  [[ $failures -eq 0 ]] && echo PASS
  exit $(( failures > 0 ))
' _ "$build" "$root"
