#!/usr/bin/env bash
# Flights back to back in one process (docs/design.md §7.9): kestrel-mission --soak flies three
# small-room explorations in one process; after each, the process holds the same open files and
# threads as after the first (nothing a flight opens or starts outlives it), and every flight
# explored, landed and touched nothing. Resident memory is reported, not asserted (the allocator
# keeps freed pages; bench/soak/soak measures an hour).
# Usage: soak_test.sh KESTREL_MISSION ROOT
set -euo pipefail
mission=$1; root=$2
out=$(mktemp)
trap 'rm -f "$out"' EXIT
"$mission" --root "$root" --world tests/system/worlds/small_room.yaml --sim config/sim/sim_ci.yaml \
  --seed 1 --soak 100 --no-quality >"$out"
grep '^soak flight' "$out"
flights=$(grep -c '^soak flight' "$out")
[[ $flights -ge 3 ]] || { echo "FAIL: $flights flights, expected at least 3"; exit 1; }
first=$(grep -m1 '^soak flight' "$out" | grep -oE 'open files [0-9]+, threads [0-9]+')
while read -r line; do
  now=$(echo "$line" | grep -oE 'open files [0-9]+, threads [0-9]+')
  [[ $now == "$first" ]] || { echo "FAIL: after flight 1: $first; later: $now"; exit 1; }
  echo "$line" | grep -q ', collisions 0, landed,' || { echo "FAIL: $line"; exit 1; }
done < <(grep '^soak flight' "$out")
echo "PASS: $flights flights in one process, $first after each"
