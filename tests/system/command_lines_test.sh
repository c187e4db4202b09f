#!/usr/bin/env bash
# Every Kestrel process and tool refuses a mistyped option, a stray argument and a malformed
# number with exit code 2 and a message naming it, and prints its usage on --help (exit 0); the
# shared parser is common/process.h (CLI11).
# Usage: command_lines_test.sh BUILD_DIR
set -uo pipefail
build=$1
failures=0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect CODE PATTERN COMMAND...: exit code CODE and PATTERN (grep -E) in stdout + stderr.
expect() {
  local code=$1 pattern=$2
  shift 2
  timeout 20 "$@" >"$work/out.txt" 2>&1 </dev/null
  local rc=$?
  [[ $rc -eq $code ]] || { fail "'$*' exited $rc, expected $code: $(head -c 400 "$work/out.txt")"; return; }
  grep -Eqi -- "$pattern" "$work/out.txt" ||
    fail "'$*' did not say '$pattern': $(head -c 400 "$work/out.txt")"
}

# Each process: its binary, and a command line that is right except for one malformed number
# ("" where the process has no numeric option of its own).
declare -A numeric=(
  [tools/cmd/kestrel-cmd]="takeoff --height 2m"
  [tools/mission/kestrel-mission]="--seed x"
  [tools/map_score/kestrel-map-score]="--world w.yaml --map m.kmap --range-m x"
  [tools/fidelity/kestrel-fidelity]="--log l.lcmlog --world w.yaml --period-s x"
  [tools/fidelity/kestrel-calibrate]="--log l.lcmlog --world w.yaml --every x"
  [tools/flight_check/kestrel-flight-check]="memq:// 10s"
  [tools/fault/kestrel-fault]="malformed --count-per-channel x"
  [tools/world_env/kestrel-world-env]=""
  [drivers/usb/kestrel-devices]="--watch soon"
  [viewer/report/kestrel-report-export]="--log a.lcmlog --out d --threshold x"
  [viewer/foxglove/kestrel-mcap-export]="--log a.lcmlog --out b.mcap --map-period x"
  [mapping/kestrel-mapper]=""
  [control/kestrel-controller]=""
  [exploration/kestrel-explorer]=""
  [sim/kestrel-sim]=""
  [sim/kestrel-sim-standin]=""
  [common/procman/kestrel-procman]=""
  [drivers/vicon/kestrel-vicon]=""
  [drivers/vicon/kestrel-vicon-emitter]=""
  [drivers/hokuyo/kestrel-hokuyo]=""
  [drivers/hokuyo/kestrel-hokuyo-emulator]=""
  [drivers/xtion/kestrel-xtion]=""
  [drivers/imu/kestrel-imu]=""
  [drivers/imu/kestrel-imu-emulator]=""
  [drivers/motors/kestrel-motors]=""
  [drivers/motors/kestrel-esc-emulator]=""
  [viewer/bridge/kestrel-viewer]=""
)
checked=0
for rel in "${!numeric[@]}"; do
  bin=$build/$rel
  if [[ ! -x $bin ]]; then
    fail "$rel was not built"
    continue
  fi
  checked=$((checked + 1))
  expect 2 "unknown option --hieght" "$bin" --hieght 2
  expect 2 "unknown option --lcm-urll" "$bin" --lcm-urll memq://
  expect 2 "--config" "$bin" --config
  expect 0 "Common options" "$bin" --help
  if [[ -n ${numeric[$rel]} ]]; then
    # shellcheck disable=SC2086  # the words of the command line
    expect 2 "is not a number|could not convert" "$bin" ${numeric[$rel]}
  fi
done
# No own positional arguments: a stray word is refused (the mapper once ignored everything).
expect 2 "unexpected argument .stray." "$build/mapping/kestrel-mapper" stray
expect 2 "unexpected argument .stray." "$build/sim/kestrel-sim" --set a=1 stray
# kestrel-world-env: one world file, no more.
expect 2 "unexpected argument .stray." "$build/tools/world_env/kestrel-world-env" w.yaml stray
# kestrel-cmd goto: a coordinate that is not a number is named.
expect 2 "not a coordinate" "$build/tools/cmd/kestrel-cmd" goto 1 x 0
# kestrel-report (a shell wrapper): --help and -h print the usage and exit 0 wherever they stand;
# an option without its value is named.
expect 0 "usage: kestrel-report" "$build/viewer/report/kestrel-report" --help
expect 0 "usage: kestrel-report" "$build/viewer/report/kestrel-report" --log a.lcmlog -h
expect 2 "--out needs a value" "$build/viewer/report/kestrel-report" --log a.lcmlog --out
# A choice outside its set is named.
expect 2 "--compression" "$build/viewer/foxglove/kestrel-mcap-export" --log a --out b --compression lz4

echo "$checked processes checked, $failures failures"
[[ $failures -eq 0 ]]
