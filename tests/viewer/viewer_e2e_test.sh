#!/usr/bin/env bash
# Live viewer end to end: a short simulated mission is recorded as an LCM log; in a
# private network namespace lcm-logplayer replays it over UDP multicast into kestrel-viewer, and
# headless Chromium (Debian's, driven by playwright-core from viewer/web/node_modules) opens the
# page before the replay and another one after it. Both must show exactly the number of voxels
# that viewer_expected_voxels (mapping/map_replica.h over the same log) counts, and a screenshot
# must show content. Exit 77 (ctest: skipped) when chromium, node or the npm packages are missing.
# Usage: viewer_e2e_test.sh MISSION VIEWER EXPECTED_VOXELS IN_NETNS ROOT
# Set KESTREL_VIEWER_SCREENSHOT=FILE.png to keep the screenshot (an indexed-colour PNG: small
# enough for docs/figures), KESTREL_VIEWER_MISSION_S to fly longer than 35 simulated seconds,
# KESTREL_VIEWER_SPEED for another replay speed than 4.
set -euo pipefail
mission=$1; viewer=$2; expected_voxels=$3; in_netns=$4; root=$5
web=$root/viewer/web
skip() { echo "SKIP: $*"; exit 77; }
[[ -x /usr/bin/chromium ]] || skip "Debian's chromium (/usr/bin/chromium) is not installed"
command -v node >/dev/null || skip "node is not installed"
[[ -f $web/node_modules/playwright-core/package.json ]] ||
  skip "viewer/web/node_modules/playwright-core is missing (scripts/setup runs npm ci there)"
[[ -f $web/node_modules/three/build/three.module.js ]] ||
  skip "viewer/web/node_modules/three is missing (scripts/setup runs npm ci there)"
# playwright-core states the oldest Node it runs on ("engines": {"node": ">=20"}); Debian 12's
# nodejs is 18.
need_major=$(sed -n 's/.*"node": *">= *\([0-9]*\).*/\1/p' "$web/node_modules/playwright-core/package.json")
have_major=$(node -p 'process.versions.node.split(".")[0]')
if [[ -n $need_major && $have_major -lt $need_major ]]; then
  skip "node $(node --version) is older than playwright-core's Node >= $need_major"
fi
staged=$(dirname "$viewer")/web
if [[ ! -f $staged/three.module.js ]]; then
  echo "FAIL: three.js is installed but not staged in $staged: re-run cmake, then build"
  exit 1
fi
command -v lcm-logplayer >/dev/null || { echo "FAIL: lcm-logplayer not found"; exit 1; }

dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cd "$root"
"$mission" --root "$root" --world config/worlds/lasr.yaml --sim config/sim/sim_ci.yaml \
  --max-time "${KESTREL_VIEWER_MISSION_S:-35}" --no-quality --log "$dir/run.lcmlog" >"$dir/summary.txt"
"$expected_voxels" "$dir/run.lcmlog" 0.5 >"$dir/expected.txt"
expected=$(awk '$1 == "occupied" {print $2}' "$dir/expected.txt")
map_seq=$(awk '$1 == "map_seq" {print $2}' "$dir/expected.txt")
if ! grep -q "^current 1$" "$dir/expected.txt" || [[ $expected -lt 100 ]]; then
  echo "FAIL: the recorded map is not usable as a reference"
  cat "$dir/expected.txt"
  exit 1
fi
echo "reference: $expected occupied cells at map_seq $map_seq ($(stat -c %s "$dir/run.lcmlog") bytes of log)"

set +e
"$in_netns" bash -c '
  set -euo pipefail
  viewer=$1; root=$2; dir=$3; expected=$4; map_seq=$5
  url="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
  "$viewer" --config "$root/config/viewer.yaml" --lcm-url "$url" --set port=8740 \
    2>"$dir/viewer.log" &
  v=$!
  for _ in $(seq 100); do
    (exec 3<>/dev/tcp/127.0.0.1/8740) 2>/dev/null && break
    sleep 0.1
  done
  status=0
  node "$root/tests/viewer/viewer_e2e.mjs" --web "$root/viewer/web" \
    --url http://127.0.0.1:8740/ --lcm-url "$url" --log "$dir/run.lcmlog" \
    --expected "$expected" --map-seq "$map_seq" --screenshot "$dir/viewer.png" \
    --speed "${KESTREL_VIEWER_SPEED:-4}" ${KESTREL_VIEWER_SCREENSHOT:+--figure "$dir/figure.png"} \
    || status=$?
  ticks=$(getconf CLK_TCK)
  awk -v t="$ticks" "{printf \"kestrel-viewer CPU time: %.2f s (user+system)\\n\", (\$14+\$15)/t}" /proc/$v/stat
  kill -TERM $v
  wait $v || { echo "FAIL: kestrel-viewer exited with $?"; status=1; }
  exit $status
' _ "$viewer" "$root" "$dir" "$expected" "$map_seq"
status=$?
set -e
if [[ $status -ne 0 ]]; then
  echo "--- kestrel-viewer log"
  tail -20 "$dir/viewer.log"
  exit 1
fi
if [[ -n ${KESTREL_VIEWER_SCREENSHOT:-} ]]; then
  cp "$dir/figure.png" "$KESTREL_VIEWER_SCREENSHOT"
fi
