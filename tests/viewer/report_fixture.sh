#!/usr/bin/env bash
# ctest fixture of the report_* tests: two short recorded missions on LASR (40 simulated s each,
# a few wall seconds): the combined mode (log, final map, the mission's time series) and the
# frontier baseline (log only), in OUT; and the combined run exported with the world (OUT/export).
# Usage: report_fixture.sh KESTREL_MISSION KESTREL_REPORT_EXPORT SOURCE_DIR OUT
set -euo pipefail
mission=$1 exporter=$2 root=$3 out=$4
rm -rf "$out"
mkdir -p "$out"
common=(--root "$root" --world config/worlds/lasr.yaml --sim config/sim/sim_ci.yaml --max-time 40)
"$mission" "${common[@]}" --log "$out/combined.lcmlog" --map "$out/combined.kmap" \
  --csv "$out/combined.csv" >"$out/combined.txt" 2>"$out/combined.err"
"$mission" "${common[@]}" --explorer-set mode=frontier --no-quality \
  --log "$out/frontier.lcmlog" >"$out/frontier.txt" 2>"$out/frontier.err"
cd "$root"
"$exporter" --log "$out/combined.lcmlog" --world config/worlds/lasr.yaml --times 25,39 \
  --out "$out/export"
ls -l "$out"
