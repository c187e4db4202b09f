#!/usr/bin/env bash
# Two vehicles exploring together as separate processes (docs/exploration.md, "Several
# vehicles"): scripts/sheets/two_vehicles_sim.procman through kestrel-procman in a private network
# namespace, UDP multicast, the simulator at SPEED x real time. Both explorers must end by their
# end rule, fly home and land; the mapper's map (its last checkpoint) must be MIN_KNOWN known; from
# the log, the vehicles never touch anything and keep their separation (horizontal distance while
# their heights differ by less than 0.6 m) of at least 1.1 m (the explorers plan 1.2 m).
# Usage: two_vehicle_sheet_test.sh BUILD_DIR ROOT IN_NETNS SECONDS SPEED MIN_KNOWN
set -euo pipefail
build=$1; root=$2; in_netns=$3; seconds=$4; speed=$5; min_known=$6
exec "$in_netns" bash -c '
  set -euo pipefail
  build=$1; root=$2; seconds=$3; speed=$4; min_known=$5
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export KESTREL_BIN="$build/bin" KESTREL_RUN=$(mktemp -d) KESTREL_SPEED=$speed
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 2; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$KESTREL_RUN" EXIT
  "$build/bin/kestrel-procman" scripts/sheets/two_vehicles_sim.procman --host sim --script fly \
    --log-dir "$KESTREL_RUN/logs" 2>"$KESTREL_RUN/runner.log" &
  runner=$!
  status=0
  landed=0
  for i in $(seq "$seconds"); do
    sleep 1
    if grep -q "sent land" "$KESTREL_RUN/logs/explorer-v1.log" 2>/dev/null &&
       grep -q "sent land" "$KESTREL_RUN/logs/explorer-v2.log" 2>/dev/null; then
      landed=1; echo "both explorers sent land after $i s"; break
    fi
  done
  sleep 4  # the last checkpoint (every 2 s) and the landings
  kill -TERM $runner
  wait $runner || true
  [[ $landed -eq 1 ]] || { echo "FAIL: not both explorers sent land within $seconds s"; status=1; }
  for v in v1 v2; do
    line=$(grep -E "returned home|landed elsewhere" "$KESTREL_RUN/logs/explorer-$v.log" | tail -1 || true)
    echo "explorer-$v: ${line#*info }"
    grep -q "returned home" <<<"$line" || { echo "FAIL: explorer-$v did not return home"; status=1; }
    grep -q "exploration ended by the gain rule" "$KESTREL_RUN/logs/explorer-$v.log" ||
      { echo "FAIL: explorer-$v did not end by the gain rule"; status=1; }
  done
  score=$("$build/bin/kestrel-map-score" --world config/worlds/lasr.yaml --map "$KESTREL_RUN/mapper.kmap")
  echo "$score"
  known=$(echo "$score" | sed -E "s/.*known fraction: ([0-9.]+).*/\1/")
  awk -v k="$known" -v m="$min_known" "BEGIN { exit !(k >= m) }" ||
    { echo "FAIL: known fraction $known below $min_known"; status=1; }
  PYTHONPATH="$build/lcmtypes/python" python3 tools/python/read_log.py "$KESTREL_RUN/run.lcmlog" \
    --channel "V[12]_SIM_TRUTH" >"$KESTREL_RUN/truth.txt"
  python3 - "$KESTREL_RUN/truth.txt" <<"PY" || status=1
import math, re, sys
at = {}
last = {}
for line in open(sys.argv[1]):
    m = re.match(r"\S+ (V[12])_SIM_TRUTH \S+ utime=(\d+) .*position_m=\[([^\]]*)\].*collision_count=(\d+)", line)
    if not m:
        continue
    v, utime, p, count = m.group(1), int(m.group(2)), [float(x) for x in m.group(3).split(",")], int(m.group(4))
    at.setdefault(utime, {})[v] = p
    last[v] = count
nearest = math.inf
for both in at.values():
    if len(both) == 2 and abs(both["V1"][2] - both["V2"][2]) < 0.6:
        nearest = min(nearest, math.hypot(both["V1"][0] - both["V2"][0], both["V1"][1] - both["V2"][1]))
pairs = sum(1 for both in at.values() if len(both) == 2)
c1, c2 = last.get("V1"), last.get("V2")
print(f"{pairs} simultaneous states; smallest separation {nearest:.3f} m; collisions V1 {c1}, V2 {c2}")
ok = pairs > 1000 and nearest >= 1.1 and c1 == 0 and c2 == 0
if not ok:
    print("FAIL: separation or collisions")
sys.exit(0 if ok else 1)
PY
  if [[ $status -ne 0 ]]; then
    for f in "$KESTREL_RUN"/logs/*.log; do echo "== $f"; tail -n 5 "$f"; done
  fi
  exit $status
' _ "$build" "$root" "$seconds" "$speed" "$min_known"
