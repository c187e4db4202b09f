#!/usr/bin/env bash
# kestrel-report end to end on the fixture's recorded missions (report_fixture.sh): the wrapper
# writes every figure under its fixed name, report_check_figures.py finds their pixels where the
# data puts them, the same check fails on an empty and on a displaced map, --results reads a demo
# folder, and bad input ends with a clear message and a non-zero exit.
# Usage: report_figures_test.sh REPORT_BUILD_DIR SOURCE_DIR FIXTURE_DIR WORK_DIR
set -uo pipefail
bin=$1 root=$2 fixture=$3 work=$4
python=/usr/bin/python3
check=$root/tests/viewer/report_check_figures.py
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
rm -rf "$work"
mkdir -p "$work"
cd "$root"

# 1. The figures of a run with an overlaid run.
out=$work/report
if ! "$bin/kestrel-report" --log "$fixture/combined.lcmlog" --world config/worlds/lasr.yaml \
  --out "$out" --times 25,39 --label combined --runs "$fixture/frontier.lcmlog:frontier"; then
  fail "kestrel-report failed"
fi
expected="fig1_map3d.json fig1_map3d.png fig2_map2d_0_t25s.json fig2_map2d_0_t25s.png fig2_map2d_1_t39s.json fig2_map2d_1_t39s.png fig3_entropy.json fig3_entropy.png fig3_entropy.svg"
got=$(cd "$out" && ls -1 fig* | tr '\n' ' ' | sed 's/ $//')
[[ $got == "$expected" ]] || fail "figure names: got '$got', expected '$expected'"
"$python" "$check" --figures "$out" --data "$out/data/main" --runs 2 || fail "figure check"
# The run's configuration: the mission's four nodes, each value under its file.
config=$out/configuration.txt
[[ $(grep -c "^kestrel-mission on " "$config" 2>/dev/null) == 4 ]] ||
  fail "configuration.txt does not list the mission's 4 nodes"
grep -Eq "^    mode: volumetric$" "$config" || fail "configuration.txt lacks the explorer's mode"
grep -Eq "^  .*config/mapper.yaml:$" "$config" || fail "configuration.txt lacks the mapper's file"
grep -Eq "^    seed: 1 +# override$" "$config" || fail "configuration.txt lacks the simulator's seed override"

# 2. The same check must fail on an empty map and on a map displaced by 3 m.
neg=$work/negative
cp -r "$out/data/main" "$neg"
head -n 1 "$out/data/main/occupied.csv" >"$neg/occupied.csv"
"$python" "$bin/kestrel_report.py" --data "$neg" --out "$neg/fig" --only map3d >/dev/null ||
  fail "drawing the empty map"
if "$python" "$check" --figures "$neg/fig" --data "$out/data/main" --only map3d >"$work/empty.txt"; then
  fail "the check passed on an empty map"
fi
grep -q "FAIL fig1 map" "$work/empty.txt" || fail "the empty map did not fail on the map panel"
awk -F, 'NR == 1 { print; next } { printf "%.4f,%s,%s,%s\n", $1 + 3.0, $2, $3, $4 }' \
  "$out/data/main/occupied.csv" >"$neg/occupied.csv"
"$python" "$bin/kestrel_report.py" --data "$neg" --out "$neg/fig" --only map3d >/dev/null ||
  fail "drawing the displaced map"
if "$python" "$check" --figures "$neg/fig" --data "$out/data/main" --only map3d >"$work/shifted.txt"; then
  fail "the check passed on a displaced map"
fi

# 3. A demo results folder: the log and the world from its summary.
demo=$work/results/demo-test
mkdir -p "$demo"
ln -s "$fixture/combined.lcmlog" "$demo/run.lcmlog"
echo "Kestrel demo: config/worlds/lasr.yaml, separate processes from scripts/sheets/sim.procman at 1x" \
  >"$demo/summary.txt"
"$bin/kestrel-report" --results "$demo" >"$work/results.txt" 2>&1 || fail "--results: $(cat "$work/results.txt")"
[[ -f $demo/report/fig1_map3d.png ]] || fail "--results wrote no fig1 in $demo/report"
grep -q '"name": "truth"' "$demo/report/fig1_map3d.json" 2>/dev/null ||
  fail "--results did not find the world in summary.txt"

# 4. Bad input: a clear message and a non-zero exit.
expect_error() {  # expect_error CODE PATTERN COMMAND...
  local code=$1 pattern=$2
  shift 2
  "$@" >"$work/err.txt" 2>&1
  local rc=$?
  [[ $rc -eq $code ]] || fail "'$*' exited $rc, expected $code: $(cat "$work/err.txt")"
  grep -q -- "$pattern" "$work/err.txt" || fail "'$*' did not say '$pattern': $(cat "$work/err.txt")"
}
expect_error 2 "are required" "$bin/kestrel-report" --log "$fixture/combined.lcmlog"
expect_error 1 "no log file" "$bin/kestrel-report" --log "$work/missing.lcmlog" --out "$work/x"
head -c 5000 /dev/urandom >"$work/garbage.lcmlog"
expect_error 1 "has no MAP3D message" "$bin/kestrel-report" --log "$work/garbage.lcmlog" --out "$work/x"
expect_error 2 "Could not convert: --times" "$bin/kestrel-report-export" \
  --log "$fixture/combined.lcmlog" --out "$work/x" --times 10,abc
head -c 3000000 "$fixture/combined.lcmlog" >"$work/cut.lcmlog"
expect_error 0 "ends inside an event" "$bin/kestrel-report" --log "$work/cut.lcmlog" --out "$work/cut"

if [[ $failures -gt 0 ]]; then
  echo "$failures failures"
  exit 1
fi
echo "all report figure checks passed"
