#!/usr/bin/env bash
# kestrel-report's figures and summary of a two-vehicle run (report_fixture_two_vehicles.sh,
# docs/design.md §7.10): the 2D-map figures draw each vehicle's path in its own colour
# (report_check_figures.py finds each one's samples on a line of its colour), and vehicles.txt
# has one line per vehicle with its path length.
# Usage: report_figures_two_vehicles_test.sh REPORT_BUILD_DIR SOURCE_DIR FIXTURE_DIR WORK_DIR
set -uo pipefail
bin=$1 root=$2 fixture=$3 work=$4
python=/usr/bin/python3
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
rm -rf "$work"
mkdir -p "$work"
data=$fixture/export
"$python" "$bin/kestrel_report.py" --data "$data" --out "$work" --label two >"$work/out.txt" 2>&1 ||
  fail "kestrel_report.py: $(cat "$work/out.txt")"
"$python" "$root/tests/viewer/report_check_figures.py" --figures "$work" --data "$data" \
  --only map2d || fail "figure check"
grep -q '"prefix": "V2_"' "$work"/fig2_map2d_0_*.json 2>/dev/null ||
  fail "fig2's sidecar does not list V2_"
# vehicles.txt: V1_ then V2_, each with the path length of vehicles.csv.
[[ $(wc -l <"$work/vehicles.txt" 2>/dev/null) == 2 ]] || fail "vehicles.txt has not 2 lines"
for k in 1 2; do
  length=$(awk -F, -v p="V${k}_" '$2 == p { printf "%.2f", $6 }' "$data/vehicles.csv")
  [[ -n $length ]] || fail "vehicles.csv has no V${k}_"
  sed -n "${k}p" "$work/vehicles.txt" | grep -q "^V${k}_: path $length m (" ||
    fail "vehicles.txt line $k is not V${k}_ with path $length m: $(sed -n "${k}p" "$work/vehicles.txt")"
done
cat "$work/vehicles.txt"
if [[ $failures -gt 0 ]]; then
  echo "$failures failures"
  exit 1
fi
echo "the two vehicles' figures and summary passed"
