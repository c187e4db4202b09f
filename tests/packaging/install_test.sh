#!/usr/bin/env bash
# Installs the build into a fresh prefix (cmake --install BUILD --prefix PREFIX, as a packager
# does) and checks the layout: every process, the CMake package, headers, configuration, process
# sheets whose binaries resolve from <prefix>/share/kestrel, the viewer page, the lcm-spy jar and
# the Python message types. The fixture of the other packaging_* tests.
# Usage: install_test.sh CMAKE BUILD_DIR PREFIX
set -euo pipefail
cmake=$1; build=$2; prefix=$3
rm -rf "$prefix"
"$cmake" --install "$build" --prefix "$prefix" >"$prefix.log" 2>&1 ||
  { tail -20 "$prefix.log"; echo "FAIL: cmake --install"; exit 1; }
failures=0
need() {  # path under the prefix that must exist
  if [[ ! -e "$prefix/$1" ]]; then echo "FAIL: missing $1"; failures=$((failures + 1)); fi
}
for p in kestrel-procman kestrel-controller kestrel-mapper kestrel-explorer kestrel-sim \
         kestrel-sim-standin kestrel-cmd kestrel-flight-check kestrel-map-score kestrel-mission \
         kestrel-fidelity kestrel-calibrate \
         kestrel-imu kestrel-imu-emulator kestrel-motors kestrel-esc-emulator; do
  [[ -x "$prefix/bin/$p" ]] || { echo "FAIL: bin/$p is not an installed executable"; failures=$((failures + 1)); }
done
for f in lib/cmake/Kestrel/KestrelConfig.cmake lib/cmake/Kestrel/KestrelConfigVersion.cmake \
         lib/cmake/Kestrel/KestrelTargets.cmake include/kestrel/mapping/occupancy_map.h \
         include/kestrel/common/se3.h include/kestrel/kestrel/pose_t.hpp \
         share/kestrel/config/mapper.yaml share/kestrel/config/vehicle/paper.yaml \
         share/kestrel/config/worlds/lasr.yaml share/kestrel/config/sim/sim_ci.yaml \
         share/kestrel/sheets/sim.procman share/kestrel/sheets/host.procman \
         share/kestrel/sheets/chaos_sim.procman share/kestrel/config/sim/standin.yaml \
         share/kestrel/sheets/vehicle.procman share/kestrel/sheets/kestrel.env \
         share/kestrel/sheets/hil_sim.procman share/kestrel/config/drivers/imu.yaml \
         share/kestrel/config/drivers/motors.yaml \
         include/kestrel/bot_procman/orders2_t.hpp share/doc/kestrel-host/copyright; do
  need "$f"
done
# Optional parts, present when their area was built.
[[ ! -x "$build/viewer/bridge/kestrel-viewer" ]] || need share/kestrel/web/index.html
[[ ! -f "$build/lcmtypes/kestrel_lcmtypes.jar" ]] || need share/java/kestrel_lcmtypes.jar
[[ ! -d "$build/lcmtypes/python/kestrel" ]] || need lib/python3/dist-packages/kestrel/pose_t.py

# Every command of every installed sheet, run from share/kestrel as a bot-procman deputy runs it
# (the installed kestrel-procman --dry-run, with the installed sheets/kestrel.env and no
# $KESTREL_BIN), starts a Kestrel binary from <prefix>/bin, or a program on PATH (lcm-logger).
cd "$prefix/share/kestrel"
for pair in sim:sim chaos_sim:sim hil_sim:sim host:base vehicle:jetson; do
  sheet=sheets/${pair%%:*}.procman
  if ! out=$(env -u KESTREL_BIN -u KESTREL_RUN "$prefix/bin/kestrel-procman" "$sheet" \
               --host "${pair##*:}" --dry-run 2>&1); then
    echo "FAIL: $sheet does not resolve:"; echo "$out"; failures=$((failures + 1)); continue
  fi
  while read -r program; do
    if [[ $(basename "$program") == kestrel-* ]]; then
      [[ $(cd "$(dirname "$program")" && pwd) == "$prefix/bin" ]] ||
        { echo "FAIL: $sheet runs $program, outside $prefix/bin"; failures=$((failures + 1)); }
    fi
  done < <(sed -n "s/^  program //p" <<<"$out")
  [[ $(grep -c "^  program " <<<"$out") -ge 3 ]] ||
    { echo "FAIL: $sheet: fewer than 3 commands resolved"; failures=$((failures + 1)); }
done
files=$(find "$prefix" -type f | wc -l)
echo "installed $files files, $(du -sh "$prefix" | cut -f1) into $prefix"
[[ $failures -eq 0 ]] && echo "PASS: install layout" || { echo "$failures failures"; exit 1; }
