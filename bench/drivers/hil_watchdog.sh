#!/usr/bin/env bash
# The motor driver's watchdog measured in a hardware-in-the-loop hover (docs/design.md §7.12):
# the controller is frozen (SIGSTOP: no respawn, no last words) while the vehicle hovers, and the
# time from the freeze to the ESCs' set points all at zero is read from the log
# (DEV_MOTOR_COMMAND, what the emulated ESCs received). Run as root from the repository root:
#   bench/drivers/hil_watchdog.sh [BUILD_DIR] [WORLD]
set -euo pipefail
build=${1:-build} world=${2:-tests/system/worlds/small_room.yaml}
exec tests/tools/in_netns.sh bash -c '
  set -euo pipefail
  build=$1 world=$2
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export KESTREL_BIN="$build/bin" KESTREL_WORLD="$world" PYTHONPATH="$build/lcmtypes/python"
  eval "$(scripts/world-env "$world")"
  export KESTREL_RUN=$(mktemp -d) KESTREL_RUN_ID=hil-watchdog
  export KESTREL_IMU_PORT=$KESTREL_RUN/imu.tty KESTREL_ESC_BUS=unix:$KESTREL_RUN/esc.sock
  trap "kill -CONT \$(pgrep -f kestrel-controller) 2>/dev/null || true; kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 1; rm -rf \$KESTREL_RUN" EXIT
  "$build/common/procman/kestrel-procman" scripts/sheets/hil_sim.procman --host sim \
    --start cmd:logger --start cmd:sim --start cmd:imu-emulator --start cmd:esc-emulator \
    --log-dir "$KESTREL_RUN/logs" 2>/dev/null &
  sim_runner=$!
  "$build/common/procman/kestrel-procman" scripts/sheets/vehicle.procman --host jetson \
    --start cmd:imu --start cmd:motors --start cmd:controller --log-dir "$KESTREL_RUN/logs" 2>/dev/null &
  vehicle_runner=$!
  sleep 4
  "$build/bin/kestrel-cmd" takeoff --height "$KESTREL_HEIGHT" --wait 20 >/dev/null
  sleep 5
  controller=$(pgrep -P $vehicle_runner -f kestrel-controller)
  frozen=$(date +%s%6N)
  kill -STOP "$controller"
  sleep 3
  kill -TERM $sim_runner; wait $sim_runner || true
  python3 - "$KESTREL_RUN/run.lcmlog" "$frozen" <<EOF
import sys
sys.path.insert(0, "tools/python")
import kestrel
from read_log import decoders, events
table = decoders()
frozen = int(sys.argv[2])
last_command = last_spinning = None
for utime, channel, data in events(sys.argv[1]):
    if channel == "MOTOR_COMMAND" and utime < frozen + 500000:
        last_command = utime
    if channel == "DEV_MOTOR_COMMAND":
        m = table[data[:8]].decode(data)
        if any(t > 0 for t in m.thrust_N):
            last_spinning = utime
print("last motor command %.3f s after the freeze; rotors at zero %.3f s after it "
      "(%.3f s after the last command; command_timeout_s 1.5 plus at most one 5 ms refresh)"
      % ((last_command - frozen) / 1e6, (last_spinning - frozen) / 1e6,
         (last_spinning - last_command) / 1e6))
EOF
' _ "$build" "$world"
