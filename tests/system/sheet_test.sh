#!/usr/bin/env bash
# The sim sheet through the runner, multi-process: kestrel-procman starts the
# simulator, controller, mapper, explorer and logger as separate processes over UDP multicast in
# a private network namespace and runs the sheet's "fly" script (take-off by kestrel-cmd);
# kestrel-flight-check then listens and asserts every process alive, message counts, entropy falling,
# the vehicle moving. Finally the mapper is killed with -9 and must be respawned by the runner,
# resuming from its checkpoint (the same run: the runner gives the respawn the same run id);
# kestrel-cmd params shows its configuration, and the log holds every process's configuration.
# Usage: sheet_test.sh BUILD_DIR ROOT IN_NETNS SECONDS
set -euo pipefail
build=$1; root=$2; in_netns=$3; seconds=${4:-40}
exec "$in_netns" bash -c '
  set -euo pipefail
  build=$1; root=$2; seconds=$3
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export KESTREL_BIN="$build/bin" KESTREL_RUN=$(mktemp -d) KESTREL_SPEED=${KESTREL_SPEED:-1}
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 2; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$KESTREL_RUN" EXIT
  "$build/common/procman/kestrel-procman" scripts/sheets/sim.procman --host sim --script fly \
    --log-dir "$KESTREL_RUN/logs" 2>"$KESTREL_RUN/runner.log" &
  runner=$!
  status=0
  "$build/tools/flight_check/kestrel-flight-check" "$LCM_DEFAULT_URL" "$seconds" || status=1
  # Fault: kill -9 the mapper; the runner respawns it and it resumes from its checkpoint.
  # The mapper of this run (its checkpoint is in $KESTREL_RUN), not one of another test.
  mapper_pid=$(pgrep -f "^$build/bin/kestrel-mapper .*checkpoint_path=$KESTREL_RUN/" | head -1)
  kill -9 "$mapper_pid"
  for i in $(seq 100); do
    grep -q "resumed from checkpoint .* of this run" "$KESTREL_RUN/logs/mapper.log" 2>/dev/null && break
    sleep 0.1
  done
  if grep -q "resumed from checkpoint .* of this run" "$KESTREL_RUN/logs/mapper.log"; then
    echo "mapper killed with -9, respawned, resumed: $(grep "resumed from checkpoint" "$KESTREL_RUN/logs/mapper.log" | tail -1)"
  else
    echo "FAIL: the mapper did not resume after kill -9"; tail -20 "$KESTREL_RUN/runner.log"; status=1
  fi
  # The configuration on request (docs/design.md §6): the respawned mapper answers with the
  # checkpoint path this sheet set on its command line, marked as an override.
  "$build/tools/cmd/kestrel-cmd" params kestrel-mapper --seconds 2 >"$KESTREL_RUN/params.txt" || true
  if grep -Eq "^    checkpoint_path: $KESTREL_RUN/mapper.kmap +# override$" "$KESTREL_RUN/params.txt"; then
    echo "kestrel-cmd params: the mapper runs with checkpoint_path $KESTREL_RUN/mapper.kmap (override)"
  else
    echo "FAIL: kestrel-cmd params kestrel-mapper did not show the checkpoint path override"
    head -20 "$KESTREL_RUN/params.txt"; status=1
  fi
  if [[ $status -ne 0 ]]; then
    for f in "$KESTREL_RUN"/logs/*.log; do echo "== $f"; tail -5 "$f"; done
  fi
  kill -TERM $runner
  wait $runner || true
  test -s "$KESTREL_RUN/run.lcmlog" || { echo "FAIL: no LCM log"; status=1; }
  # The log describes itself: the configuration of every process, and of the respawned mapper.
  params=$(PYTHONPATH="$build/lcmtypes/python" python3 tools/python/read_log.py \
             "$KESTREL_RUN/run.lcmlog" --channel "PARAMS_.*" || true)
  for channel in PARAMS_SIM PARAMS_CONTROLLER PARAMS_MAPPER PARAMS_EXPLORER; do
    grep -q " $channel " <<<"$params" || { echo "FAIL: no $channel in the log"; status=1; }
  done
  mapper_lives=$(grep " PARAMS_MAPPER " <<<"$params" | grep -o "epoch=[0-9]*" | sort -u | wc -l)
  if [[ $mapper_lives -ge 2 ]]; then
    echo "the log holds every process'"'"'s configuration, the mapper'"'"'s from $mapper_lives lives"
  else
    echo "FAIL: the log holds the mapper'"'"'s configuration from $mapper_lives lives, not 2"; status=1
  fi
  exit $status
' _ "$build" "$root" "$seconds"
