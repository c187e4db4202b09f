#!/usr/bin/env bash
# Runs a command inside a private network namespace with only a loopback interface, set up for
# LCM UDP multicast (multicast on, 224.0.0.0/4 routed to lo). Nothing can leave the machine.
# Usage: in_netns.sh COMMAND [ARGS...]     (needs root or user namespaces: unshare -n; exits 77
#        with a "KESTREL-SKIP: ..." line where the machine refuses one)
# Use LCM URLs with ttl=0, e.g. udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304
set -euo pipefail
if [[ $# -eq 0 ]]; then
  echo "usage: $0 COMMAND [ARGS...]" >&2
  exit 2
fi
if [[ -z "${KESTREL_IN_NETNS:-}" ]]; then
  unshare_args=(--net)
  # Not root: a user namespace maps us to root inside (where the kernel allows it).
  [[ $(id -u) -eq 0 ]] || unshare_args=(--map-root-user --net)
  # Where the machine refuses (a container, user namespaces off, an AppArmor policy), say so
  # after the marker that ctest's SKIP_REGULAR_EXPRESSION knows (tests/CMakeLists.txt
  # kestrel_netns_test) and exit 77: the test is skipped with this reason, not failed.
  if ! refusal=$(unshare "${unshare_args[@]}" -- true 2>&1); then
    echo "KESTREL-SKIP: no private network namespace here: unshare ${unshare_args[*]} failed" \
      "(${refusal:-no message}); run as root on a machine that allows it" >&2
    exit 77
  fi
  exec unshare "${unshare_args[@]}" -- env KESTREL_IN_NETNS=1 "$0" "$@"
fi
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
# No socket buffer sysctl here: net.core.rmem_max and rmem_default are not per namespace. Inside
# it they are read-only copies of the host's (Linux 6.18; older kernels do not show them), so the
# receive buffer an LCM URL's recv_buf_size=N gets is 2 x min(N, the host's rmem_max), as on the
# host itself (docs/design.md §7.4). Tests that need a given size ask for half of it in the URL.
exec "$@"
