#!/usr/bin/env bash
# The chaos regression (docs/design.md §7.11): one simulated exploration through the chaos sheet
# (scripts/sheets/chaos_sim.procman: every process its own, over UDP multicast in a private
# network namespace, each sensor stand-in losing 10% of its frames, motion capture lost for 1 s
# at 30 s) during which kill -9 hits in turn the LIDAR and depth stand-ins, the mapper, the
# explorer and the controller, each respawned by the runner, and then a burst of malformed
# messages goes out on every channel (kestrel-fault). Asserts: the mission completes
# (kestrel-flight-check --until-landed: the explorer done, the controller idle again; the map at
# least MIN_KNOWN known), the vehicle never left the geofence, never touched anything, came home
# and landed, the controller held (no LAND, ESTOP or IDLE) while the explorer or the controller
# was down and the respawned controller took over in HOLD (chaos_check.py), every process counted
# in its heartbeat exactly the malformed messages sent on the channels it reads, each stand-in
# lost about 10% of its frames, and the
# mapper's final map equals the run's log replayed into a fresh mapper that follows the live
# mapper's recorded decisions (which scans, which rays, which poses: docs/design.md §3.6) bit for
# bit, whatever the load.
# Environment: KESTREL_BUSY_LOOPS=N runs N busy loops beside the flight (a loaded host: the
# label "loaded" test, -DKESTREL_LOADED_TESTS=ON); KESTREL_CHAOS_IGNORE_DECISIONS=1 replays
# without the decisions (to show the check fails then when the live mapper fell behind).
# Usage: chaos_test.sh BUILD_DIR ROOT IN_NETNS SECONDS WORLD MIN_KNOWN
set -euo pipefail
build=$1; root=$2; in_netns=$3; seconds=$4; world=$5; min_known=$6
exec "$in_netns" bash -c '
  set -euo pipefail
  build=$1; root=$2; seconds=$3; world=$4; min_known=$5
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export KESTREL_BIN="$build/bin" KESTREL_RUN=${KESTREL_CHAOS_RUN:-$(mktemp -d)} KESTREL_WORLD="$world"
  export KESTREL_SPEED=1
  mkdir -p "$KESTREL_RUN"
  [[ -n ${KESTREL_CHAOS_RUN:-} ]] || trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 2; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$KESTREL_RUN" EXIT
  # The world map limits, height and geofence (as scripts/demo).
  eval "$(scripts/world-env "$world")"
  # A loaded host: busy loops beside the flight for its whole duration.
  for i in $(seq "${KESTREL_BUSY_LOOPS:-0}"); do bash -c "while :; do :; done" & done
  [[ ${KESTREL_BUSY_LOOPS:-0} -eq 0 ]] || echo "load: ${KESTREL_BUSY_LOOPS} busy loops beside the flight"
  "$build/common/procman/kestrel-procman" scripts/sheets/chaos_sim.procman --host sim --script fly \
    --log-dir "$KESTREL_RUN/logs" 2>"$KESTREL_RUN/runner.log" &
  runner=$!
  start_s=$(date +%s)
  # The faults, at wall times after the start (speed 1; take-off about 5 s in). Only this
  # runner children are hit (other tests may run the same binaries beside this one).
  kill9() {
    local pattern=$1 heartbeat=$2 pid
    pid=$(pgrep -P "$runner" -f "$pattern" | head -1 || true)
    if [[ -z $pid ]]; then echo "FAULT: no process matching $pattern to kill"; return; fi
    kill -9 "$pid"
    echo "$heartbeat $(date +%s%6N)" >>"$KESTREL_RUN/kills.txt"
    echo "fault at $(( $(date +%s) - start_s )) s: kill -9 $pattern (pid $pid)"
  }
  (
    sleep 8; kill9 "kestrel-sim-standin .*sensor=scan" HEARTBEAT_STANDIN_SCAN
    sleep 3; kill9 "kestrel-sim-standin .*sensor=depth" HEARTBEAT_STANDIN_DEPTH
    sleep 3; kill9 "kestrel-mapper " HEARTBEAT_MAPPER
    sleep 4; kill9 "kestrel-explorer " HEARTBEAT_EXPLORER
    sleep 8; [[ -n ${KESTREL_CHAOS_SPARE_CONTROLLER:-} ]] || kill9 "kestrel-controller " HEARTBEAT_CONTROLLER
    sleep 8
    echo "fault at $(( $(date +%s) - start_s )) s: malformed burst on every channel"
    "$build/bin/kestrel-fault" malformed --seconds-listen 1 --count-per-channel 8 --seed 7 \
      >"$KESTREL_RUN/burst.txt" 2>&1 || echo "FAULT: kestrel-fault failed: $(tail -2 "$KESTREL_RUN/burst.txt")"
    echo "burst: $(grep -c . "$KESTREL_RUN/burst.txt") lines, $(tail -1 "$KESTREL_RUN/burst.txt")"
  ) &
  faults=$!
  status=0
  "$build/tools/flight_check/kestrel-flight-check" "$LCM_DEFAULT_URL" "$seconds" --until-landed \
    >"$KESTREL_RUN/flight.txt" || status=1
  tail -4 "$KESTREL_RUN/flight.txt"
  wait $faults || true
  echo "flight: $(( $(date +%s) - start_s )) s of wall time"
  # Input ends: the simulator first, then the rest (the mapper applies what it holds and says its
  # map hash; the logger has everything the mapper got).
  pkill -TERM -P "$runner" -f "kestrel-sim " || true
  sleep 2
  kill -TERM $runner
  wait $runner || true
  for b in $(jobs -p); do [[ $b == "$runner" || $b == "$faults" ]] || kill "$b" 2>/dev/null || true; done
  live=$(sed -nE "s/.*stopped: .* map hash ([0-9a-f]+).*/\1/p" "$KESTREL_RUN/logs/mapper.log" | tail -1)
  grep -h "caught up\|resumed from" "$KESTREL_RUN/logs/mapper.log" | sed -E "s/^\[[0-9.]*\] //" | cut -c1-220
  # How often the live mapper changed its ray stride under the load (its log).
  echo "overload: $(grep -c "overload: ray stride" "$KESTREL_RUN/logs/mapper.log" || true) ray-stride changes in the mapper log"
  decisions=$(ls "$KESTREL_RUN"/mapper-decisions-*.lcmlog 2>/dev/null | head -1)
  replay() {
    "$build/bin/kestrel-mapper" --config config/mapper.yaml --set map.min_m=$KESTREL_MAP_MIN \
      --set map.max_m=$KESTREL_MAP_MAX --set traversal_thread=false \
      --replay "$KESTREL_RUN/run.lcmlog" "$@"
  }
  if [[ -n ${KESTREL_CHAOS_IGNORE_DECISIONS:-} ]]; then
    replay=$(replay --ignore-decisions) || true
  else
    [[ -n $decisions ]] || { echo "FAIL: the mapper wrote no decisions_log"; status=1; }
    replay=$(replay --decisions "$decisions") || true
  fi
  echo "$replay"
  if [[ -n $live && $replay == *"map hash $live"* ]]; then
    echo "the final map equals the log replayed into a fresh mapper: hash $live"
  else
    echo "FAIL: the live map (hash ${live:-none}) differs from the replay"; status=1
  fi
  score=$("$build/tools/map_score/kestrel-map-score" --world "$world" --map "$KESTREL_RUN/mapper.kmap")
  echo "$score"
  known=$(echo "$score" | sed -E "s/.*known fraction: ([0-9.]+).*/\1/")
  if ! awk -v k="$known" -v m="$min_known" "BEGIN { exit !(k >= m) }"; then
    echo "FAIL: known fraction $known below $min_known"; status=1
  fi
  PYTHONPATH="$build/lcmtypes/python" python3 tests/system/chaos_check.py "$KESTREL_RUN/run.lcmlog" \
    "$KESTREL_RUN/kills.txt" --fence-min "$KESTREL_FENCE_MIN" --fence-max "$KESTREL_FENCE_MAX" \
    --burst "$KESTREL_RUN/burst.txt" || status=1
  if [[ $status -ne 0 ]]; then
    cat "$KESTREL_RUN/flight.txt"
    for f in "$KESTREL_RUN"/logs/*.log; do echo "== $f"; tail -8 "$f"; done
  fi
  [[ $status -eq 0 ]] && echo "PASS: the exploration survived every fault"
  exit $status
' _ "$build" "$root" "$seconds" "$world" "$min_known"
