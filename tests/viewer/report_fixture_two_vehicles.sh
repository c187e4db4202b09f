#!/usr/bin/env bash
# ctest fixture of the report_*two_vehicles tests: a short recorded mission with two vehicles
# (V1_, V2_: docs/design.md §7.10) on LASR, 30 simulated s (both explorers plan about ten times;
# under 10 wall s here), without the map score; exported without a world into OUT/export.
# Usage: report_fixture_two_vehicles.sh KESTREL_MISSION KESTREL_REPORT_EXPORT SOURCE_DIR OUT
set -euo pipefail
mission=$1 exporter=$2 root=$3 out=$4
rm -rf "$out"
mkdir -p "$out"
"$mission" --root "$root" --world config/worlds/lasr.yaml --sim config/sim/sim_ci.yaml --seed 1 \
  --max-time 30 --vehicles 2 --no-quality --progress 0 --log "$out/two.lcmlog" \
  >"$out/two.txt" 2>"$out/two.err"
"$exporter" --log "$out/two.lcmlog" --out "$out/export"
ls -l "$out"
