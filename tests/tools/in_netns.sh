#!/usr/bin/env bash
# Runs a command inside a private network namespace with only a loopback interface, set up for
# LCM UDP multicast (multicast on, 224.0.0.0/4 routed to lo). Nothing can leave the machine.
# Usage: in_netns.sh COMMAND [ARGS...]     (needs root or user namespaces: unshare -n)
# Use LCM URLs with ttl=0, e.g. udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608
set -euo pipefail
if [[ $# -eq 0 ]]; then
  echo "usage: $0 COMMAND [ARGS...]" >&2
  exit 2
fi
if [[ -z "${KESTREL_IN_NETNS:-}" ]]; then
  if [[ $(id -u) -eq 0 ]]; then
    exec unshare --net -- env KESTREL_IN_NETNS=1 "$0" "$@"
  fi
  # Not root: a user namespace maps us to root inside (where the kernel allows it).
  exec unshare --map-root-user --net -- env KESTREL_IN_NETNS=1 "$0" "$@"
fi
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
# Large LCM messages are fragmented; give sockets room (inside this namespace only).
sysctl -qw net.core.rmem_max=33554432 2>/dev/null || true
exec "$@"
