#!/usr/bin/env bash
# The vehicle's rate loop measured as it runs (docs/design.md §2.6): kestrel-controller on the wall
# clock (as on the vehicle) flying kestrel-sim at real time, hovering for SECONDS after take-off,
# with the real-time settings given, optionally beside a CPU load. Prints the whole run's loop
# lateness (period jitter) and IMU-sample age at each motor command: median, 99th percentile,
# maximum, from the controller's loop_timing_path histograms (10 us bins).
# Run as root (a private network namespace; SCHED_FIFO where the kernel allows it):
#   bench/control/rate_loop.sh [--build DIR] [--seconds S] [--fifo PRIORITY] [--cpus LIST]
#                              [--lock-memory] [--load N] [--out CSV]
#   --load N: N busy processes (sha256sum of /dev/zero) beside it, the case SCHED_FIFO is for.
# The same figures through the vehicle's drivers: the hardware-in-the-loop test prints them
# (tests/system/hil_test.sh, docs/design.md §7.12).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$root/build seconds=30 fifo=0 cpus="" lock=false load=0 out=""
while [[ $# -gt 0 ]]; do
  case $1 in
    --build) build=$2; shift 2 ;;
    --seconds) seconds=$2; shift 2 ;;
    --fifo) fifo=$2; shift 2 ;;
    --cpus) cpus=$2; shift 2 ;;
    --lock-memory) lock=true; shift ;;
    --load) load=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    *) echo "unknown argument $1" >&2; exit 2 ;;
  esac
done
exec "$root/tests/tools/in_netns.sh" bash -c '
  set -euo pipefail
  root=$1 build=$2 seconds=$3 fifo=$4 cpus=$5 lock=$6 load=$7 out=$8
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  dir=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 1; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  for ((i = 0; i < load; i++)); do sha256sum /dev/zero & done
  rt=(--set realtime.fifo_priority=$fifo --set realtime.lock_memory=$lock)
  [[ -z $cpus ]] || rt+=(--set "realtime.cpus=[$cpus]")
  sim=(--config config/sim/sim_ci.yaml --set world_file=tests/system/worlds/small_room.yaml
       --set speed_factor=1 --set depth.enabled=false --set lidar.enabled=false)
  "$build/bin/kestrel-sim" "${sim[@]}" >"$dir/sim.log" 2>&1 &
  "$build/bin/kestrel-controller" --vehicle config/vehicle/paper.yaml "${rt[@]}" \
    --set loop_timing_path=$dir/timing.csv >"$dir/controller.log" 2>&1 &
  controller=$!
  sleep 2
  "$build/bin/kestrel-cmd" takeoff --height 0.8 --wait 10 >/dev/null || { tail -n 5 "$dir"/*.log; exit 1; }
  sleep "$seconds"
  grep -h "rate loop\|refused" "$dir/controller.log" | sed -E "s/^\[[0-9.]*\] //" | head -3
  kill -TERM $controller; wait $controller || true
  [[ -z $out ]] || cp "$dir/timing.csv" "$out"
  tools/python/loop_timing.py "$dir/timing.csv"
' _ "$root" "$build" "$seconds" "$fifo" "$cpus" "$lock" "$load" "$out"
