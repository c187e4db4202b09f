#!/usr/bin/env bash
# kestrel-mission's progress lines (tools/mission/mission.h progress_period_s): one every
# --progress S simulated seconds, time rising by S, the known fraction in [0, 1]; none with
# --progress 0, and none by default when CI=true.
# Usage: mission_progress_test.sh KESTREL_MISSION SOURCE_ROOT
set -uo pipefail
mission=$1
root=$2
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
run() {  # run ARGS...: the progress lines of a 30 s flight in the small room
  "$mission" --root "$root" --world tests/system/worlds/small_room.yaml \
    --sim config/sim/sim_ci.yaml --max-time 30 "$@" 2>&1 >/dev/null | grep '^progress:'
}
lines=$(unset CI; run --progress 10)
echo "$lines"
[[ $(echo "$lines" | grep -c .) -eq 4 ]] || fail "expected 4 lines (0, 10, 20, 30 s), got: $lines"
echo "$lines" | awk '{ t = $2 + 0; if (NR > 1 && (t - last < 9.9 || t - last > 10.1)) bad = 1; last = t }
                     END { exit bad }' || fail "times do not rise by 10 s"
echo "$lines" | awk '{ for (i = 1; i <= NF; ++i) if ($i == "known") { k = $(i + 1) + 0;
                       if (k < 0 || k > 1) bad = 1 } } END { exit bad }' ||
  fail "a known fraction outside [0, 1]"
echo "$lines" | tail -n 1 | grep -Eq "exploring|returning|done" || fail "not exploring at 30 s"
[[ -z $(unset CI; run --progress 0) ]] || fail "--progress 0 printed progress"
[[ -z $(CI=true run) ]] || fail "CI=true printed progress by default"
[[ $(CI=true run --progress 15 | grep -c .) -eq 3 ]] || fail "--progress 15 under CI: not 3 lines"
echo "$failures failures"
[[ $failures -eq 0 ]]
