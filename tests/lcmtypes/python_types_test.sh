#!/usr/bin/env bash
# Kestrel's Python message types (lcm-gen --python, built into <build>/lcmtypes/python) decode a
# log written by the C++ types: write_log writes the log and the expected field values, and
# tools/python/read_log.py must print every one of them, for every message of the log.
# Usage: python_types_test.sh WRITE_LOG READ_LOG_PY PYTHON_DIR [PYTHON]
set -euo pipefail
writer=$1; reader=$2; pydir=$3; python=${4:-/usr/bin/python3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$writer" "$work/run.lcmlog" >"$work/expected.txt"
PYTHONPATH="$pydir" "$python" "$reader" "$work/run.lcmlog" >"$work/decoded.txt"
failures=0
while read -r channel check; do
  if ! grep -E "^[0-9.]+ $channel kestrel\." "$work/decoded.txt" | grep -qF " $check"; then
    echo "FAIL: $channel: no '$check' in: $(grep " $channel " "$work/decoded.txt" | cut -c1-300)"
    failures=$((failures + 1))
  fi
done <"$work/expected.txt"
events=$(wc -l <"$work/decoded.txt")
undecoded=$(grep -c "not a kestrel type" "$work/decoded.txt" || true)
expected_events=$(cut -d' ' -f1 "$work/expected.txt" | sort -u | wc -l)
[[ $events -eq $expected_events && $undecoded -eq 0 ]] ||
  { echo "FAIL: $events events decoded ($undecoded unknown), expected $expected_events"; failures=$((failures + 1)); }
grep -E "^[0-9.]+ (POSE_VICON|HEARTBEAT_MAPPER|MAP_STATUS) " "$work/decoded.txt" | cut -c1-200
[[ $failures -eq 0 ]] || exit 1
echo "PASS: $events messages ($(wc -l <"$work/expected.txt") field checks) decoded by the Python types"
