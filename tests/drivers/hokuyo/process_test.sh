#!/usr/bin/env bash
# The two executables as processes: kestrel-hokuyo-emulator serves a UTM-30LX on a pty (behind a
# stable link), kestrel-hokuyo streams it over UDP multicast in a private network namespace,
# lcm-logger records 3 s; the log must hold about 40 scans/s on SCAN_HOKUYO and heartbeats on
# HEARTBEAT_HOKUYO, and both processes must exit 0 on SIGTERM.
# Usage: process_test.sh KESTREL_HOKUYO KESTREL_HOKUYO_EMULATOR IN_NETNS
set -euo pipefail
driver=$1
emulator=$2
in_netns=$3
exec "$in_netns" bash -c '
  set -euo pipefail
  driver=$1; emulator=$2
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
  dir=$(mktemp -d)
  trap "kill \$(jobs -p) 2>/dev/null || true; rm -rf \$dir" EXIT
  "$emulator" --set link_path="$dir/tty" --set model=UTM-30LX >"$dir/emulator.out" &
  emu=$!
  for i in $(seq 100); do [[ -s "$dir/emulator.out" ]] && break; sleep 0.05; done
  test "$(head -1 "$dir/emulator.out")" = "$dir/tty"
  lcm-logger --quiet --force --lcm-url="$url" "$dir/run.lcmlog" &
  logger=$!
  "$driver" --lcm-url "$url" --set port="$dir/tty" --set profile=UTM-30LX 2>"$dir/driver.err" &
  drv=$!
  sleep 4
  kill -TERM $drv
  driver_status=0; wait $drv || driver_status=$?
  kill -INT $logger; wait $logger || true
  kill -TERM $emu
  emulator_status=0; wait $emu || emulator_status=$?
  cat "$dir/driver.err" >&2
  echo "driver exit $driver_status, emulator exit $emulator_status"
  test $driver_status -eq 0
  test $emulator_status -eq 0
  python3 - "$dir/run.lcmlog" <<PY
import struct, sys
data = open(sys.argv[1], "rb").read()
counts, pos = {}, 0
while pos + 28 <= len(data):
    sync, _, _, clen, dlen = struct.unpack(">IqqII", data[pos:pos + 28])
    assert sync == 0xEDA1DA01, "bad sync word"
    channel = data[pos + 28:pos + 28 + clen].decode()
    counts[channel] = counts.get(channel, 0) + 1
    pos += 28 + clen + dlen
print(counts)
scans = counts.get("SCAN_HOKUYO", 0)
beats = counts.get("HEARTBEAT_HOKUYO", 0)
# Up to 4 s of streaming at 40 Hz minus start-up (TM sync, about 0.1 s): generous bounds.
assert 80 <= scans <= 200, "scans: %d" % scans
assert beats >= 2, "heartbeats: %d" % beats
PY
' _ "$driver" "$emulator"
