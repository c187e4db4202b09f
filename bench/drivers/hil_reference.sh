#!/usr/bin/env bash
# The all-LCM reference of the hardware-in-the-loop test (docs/design.md §7.12): the scripted
# flight of tests/system/hil_test.sh (take-off, hover 8 s, 1 m along x in 3 s, landing) with
# kestrel-sim and kestrel-controller alone, on LCM, at real time; prints its hover and go-to errors
# (hil_check.py). The test's hover bound is this figure plus 0.02 m (docs/STATUS.md, "Hardware in
# the loop"). Run as root from the repository root:
#   bench/drivers/hil_reference.sh [BUILD_DIR] [WORLD]
set -euo pipefail
build=${1:-build} world=${2:-tests/system/worlds/small_room.yaml}
exec tests/tools/in_netns.sh bash -c '
  set -euo pipefail
  build=$1 world=$2
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export PYTHONPATH="$build/lcmtypes/python" KESTREL_BIN="$build/bin"
  eval "$(scripts/world-env "$world")"
  run=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 1; rm -rf \$run" EXIT
  lcm-logger --quiet --force "$run/run.lcmlog" &
  logger=$!
  "$build/bin/kestrel-sim" --config config/sim/sim_ci.yaml --set speed_factor=1 \
    --set world_file="$world" >"$run/sim.log" 2>&1 &
  sim=$!
  "$build/bin/kestrel-controller" --vehicle config/vehicle/paper.yaml >"$run/controller.log" 2>&1 &
  controller=$!
  sleep 2
  "$build/bin/kestrel-cmd" takeoff --height "$KESTREL_HEIGHT" --wait 20 >/dev/null
  sleep 8
  "$build/bin/kestrel-cmd" goto 1 0 0 --relative --duration 3 --wait 8 >/dev/null
  sleep 1
  "$build/bin/kestrel-cmd" land --wait 5 >/dev/null
  sleep 6
  kill -TERM $controller $sim; wait $controller $sim || true
  kill -INT $logger; wait $logger || true
  echo "all-LCM: $(tests/system/hil_check.py "$run/run.lcmlog" --max-hover-rms 0.05 --max-track-rms 0.10)"
' _ "$build" "$world"
