#!/usr/bin/env bash
# Small receive buffers (docs/design.md §7.6): the sim sheet's whole flight, as processes over UDP
# multicast in a private network namespace, with every LCM socket's receive buffer at 212 992
# bytes (net.core.rmem_max of a stock Debian 12 host). The limit inside the namespace is the
# host's net.core.rmem_max, read-only there, so the URL asks for recv_buf_size=106496, which the
# kernel doubles to 212 992 (capped at 2 x rmem_max); ss checks every socket on the port. Asserts:
# kestrel-flight-check lost no map message (every snapshot whole, every delta following) and the
# map messages are sized for the buffer (a chunk in one LCM datagram, a delta in at most three), the
# vehicle explored, came home and landed, the known fraction of the mapper's map, and no datagram
# dropped by any socket (the namespace's UDP RcvbufErrors in /proc/net/snmp, and ss per socket).
# Usage: small_buffer_test.sh BUILD_DIR ROOT IN_NETNS SECONDS WORLD MIN_KNOWN_FRACTION
#   [RECV_BUF_SIZE]   (the URL's request; default 106496, i.e. 212 992 bytes per socket)
set -euo pipefail
build=$1; root=$2; in_netns=$3; seconds=$4; world=$5; min_known=$6; request=${7:-106496}
exec "$in_netns" bash -c '
  set -euo pipefail
  build=$1; root=$2; seconds=$3; world=$4; min_known=$5; request=$6
  cd "$root"
  export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=$request"
  export KESTREL_BIN="$build/bin" KESTREL_RUN=$(mktemp -d) KESTREL_WORLD="$world"
  export KESTREL_SPEED=${KESTREL_SPEED:-1}
  trap "kill -TERM \$(jobs -p) 2>/dev/null || true; sleep 2; kill -9 \$(jobs -p) 2>/dev/null || true; rm -rf \$KESTREL_RUN" EXIT
  # The world'"'"'s map limits, height and geofence (as scripts/demo).
  eval "$(scripts/world-env "$world")"
  rcvbuf_errors() { awk "/^Udp: [0-9]/ { print \$6 }" /proc/net/snmp; }
  before=$(rcvbuf_errors)
  start_s=$(date +%s)
  "$build/common/procman/kestrel-procman" scripts/sheets/sim.procman --host sim --script fly \
    --log-dir "$KESTREL_RUN/logs" 2>"$KESTREL_RUN/runner.log" &
  runner=$!
  status=0
  # The sockets, once every process is up: each one'"'"'s receive buffer (rb) and drops (d).
  ( sleep 8; ss -uamnp "sport = :7667" >"$KESTREL_RUN/sockets.txt" ) &
  "$build/tools/flight_check/kestrel-flight-check" "$LCM_DEFAULT_URL" "$seconds" --until-landed \
    --no-map-loss | tee "$KESTREL_RUN/flight.txt" || status=1
  # Sizes (docs/design.md §7.6): a chunk in one LCM datagram (65 485 payload bytes on MAP3D), a
  # delta in at most three fragments, which an empty 212 992-byte buffer holds.
  read -r chunk delta < <(sed -nE "s/^largest map messages: chunk ([0-9]+) bytes, delta ([0-9]+) bytes/\1 \2/p" "$KESTREL_RUN/flight.txt") || true
  if [[ -z ${chunk:-} ]] || (( chunk > 65485 || delta > 3 * 65487 )); then
    echo "FAIL: map messages too large for the buffer (chunk ${chunk:-?}, delta ${delta:-?} bytes)"; status=1
  fi
  flight_s=$(( $(date +%s) - start_s ))
  wait $!
  sockets_end=$(ss -uamnp "sport = :7667")
  after=$(rcvbuf_errors)
  kill -TERM $runner
  wait $runner || true
  expected=$(( 2 * request ))
  sizes=$(grep -o "rb[0-9]*" "$KESTREL_RUN/sockets.txt" | sort | uniq -c | tr "\n" " ")
  echo "LCM sockets on :7667 (count, receive buffer): $sizes(expected rb$expected each)"
  if [[ -z $sizes ]] || grep -o "rb[0-9]*" "$KESTREL_RUN/sockets.txt" | grep -qv "^rb$expected$"; then
    echo "FAIL: not every socket has a $expected-byte receive buffer"; cat "$KESTREL_RUN/sockets.txt"; status=1
  fi
  drops=$(echo "$sockets_end" | grep -o "users:((\"[^\"]*\"\|,d[0-9]*)" | paste -sd " " | sed -E "s/,d/ d/g")
  echo "per-socket drops at the end (users, d = datagrams dropped): $drops"
  echo "UDP RcvbufErrors in the namespace: $(( after - before ))"
  [[ $(( after - before )) -eq 0 ]] || { echo "FAIL: the kernel dropped datagrams for full receive buffers"; status=1; }
  score=$("$build/tools/map_score/kestrel-map-score" --world "$world" --map "$KESTREL_RUN/mapper.kmap")
  echo "$score"
  known=$(echo "$score" | sed -E "s/.*known fraction: ([0-9.]+).*/\1/")
  if ! awk -v k="$known" -v m="$min_known" "BEGIN { exit !(k >= m) }"; then
    echo "FAIL: known fraction $known below $min_known"; status=1
  fi
  echo "flight: $flight_s s of wall time"
  if [[ $status -ne 0 ]]; then
    for f in "$KESTREL_RUN"/logs/*.log; do echo "== $f"; tail -5 "$f"; done
  fi
  [[ $status -eq 0 ]] && echo "PASS: the whole flight with $expected-byte receive buffers, no map message lost"
  exit $status
' _ "$build" "$root" "$seconds" "$world" "$min_known" "$request"
