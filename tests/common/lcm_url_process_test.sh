#!/usr/bin/env bash
# A Kestrel process asks for the receive buffer the host grants (docs/design.md §7.6): given a URL
# asking twice net.core.rmem_max, kestrel-cmd says it asks rmem_max instead and what its sockets
# get, and with a URL the host grants whole it says nothing about it.
# Usage: lcm_url_process_test.sh KESTREL_CMD IN_NETNS
set -euo pipefail
cmd=$1 in_netns=$2
exec "$in_netns" bash -c '
  set -euo pipefail
  cmd=$1
  rmem_max=$(cat /proc/sys/net/core/rmem_max)
  out=$("$cmd" status --seconds 0.2 \
          --lcm-url "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=$((2 * rmem_max))" 2>&1)
  want="LCM: asking recv_buf_size=$rmem_max, what net.core.rmem_max allows, for the $((2 * rmem_max)) the URL asked: sockets get $((2 * rmem_max)) bytes"
  grep -qF "$want" <<<"$out" || { echo "FAIL: expected \"$want\" in:"; echo "$out"; exit 1; }
  out=$("$cmd" status --seconds 0.2 \
          --lcm-url "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=$rmem_max" 2>&1)
  if grep -q "LCM: asking" <<<"$out"; then echo "FAIL: resized a request the host grants:"; echo "$out"; exit 1; fi
  echo "a URL asking $((2 * rmem_max)) bytes was sized to net.core.rmem_max = $rmem_max"
' _ "$cmd"
