#!/usr/bin/env bash
# The demo's sheet from an install: in <prefix>/share/kestrel, with no build tree and no
# $KESTREL_BIN, the installed kestrel-procman runs the installed sim.procman's "fly" script (its
# binaries from <prefix>/bin through the sheet's relative default) in a private network
# namespace, and the installed kestrel-flight-check must see every process flying and mapping.
# Usage: installed_sheet_test.sh PREFIX IN_NETNS SECONDS
set -euo pipefail
prefix=$1; in_netns=$2; seconds=${3:-30}
exec "$in_netns" env -u KESTREL_BIN -u KESTREL_BUILD bash -c '
  set -euo pipefail
  prefix=$1; seconds=$2
  cd "$prefix/share/kestrel"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"
  export KESTREL_RUN=$(mktemp -d)
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 2; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$KESTREL_RUN" EXIT
  "$prefix/bin/kestrel-procman" sheets/sim.procman --host sim --script fly \
    --log-dir "$KESTREL_RUN/logs" 2>"$KESTREL_RUN/runner.log" &
  runner=$!
  status=0
  "$prefix/bin/kestrel-flight-check" "$LCM_DEFAULT_URL" "$seconds" || status=1
  # The processes are the installed ones.
  for p in kestrel-sim kestrel-controller kestrel-mapper kestrel-explorer; do
    pid=$(pgrep -f "^\.\./\.\./bin/$p " | head -1 || true)
    if [[ -z $pid ]] || [[ $(readlink -f /proc/$pid/exe) != "$(readlink -f "$prefix/bin/$p")" ]]; then
      echo "FAIL: $p is not running from $prefix/bin"; status=1
    fi
  done
  if [[ $status -ne 0 ]]; then
    tail -5 "$KESTREL_RUN/runner.log"
    for f in "$KESTREL_RUN"/logs/*.log; do echo "== $f"; tail -5 "$f"; done
  fi
  kill -TERM $runner
  wait $runner || true
  test -s "$KESTREL_RUN/run.lcmlog" || { echo "FAIL: no LCM log"; status=1; }
  [[ $status -eq 0 ]] && echo "PASS: the installed sim sheet flies from $prefix/share/kestrel"
  exit $status
' _ "$prefix" "$seconds"
