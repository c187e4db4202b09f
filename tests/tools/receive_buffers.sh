#!/usr/bin/env bash
# The host's UDP receive-buffer limits, reported and checked before the multi-process tests
# (docs/design.md §7.6): prints net.core.rmem_max and rmem_default and what an LCM URL asking
# recv_buf_size=N gets, and checks on a real UDP socket that the kernel grants 2 x min(N, rmem_max)
# (the rule kestrel processes size their request by, common/lcm_url.h). Fails if the rule does
# not hold here. scripts/test runs it before ctest; ctest runs it as the netns tests' fixture.
# Usage: receive_buffers.sh [--report]   (--report: print only, never fail)
set -euo pipefail
report_only=false
[[ ${1:-} != --report ]] || report_only=true
rmem_max=$(cat /proc/sys/net/core/rmem_max 2>/dev/null || echo "")
rmem_default=$(cat /proc/sys/net/core/rmem_default 2>/dev/null || echo "")
if [[ -z $rmem_max ]]; then
  echo "receive buffers: /proc/sys/net/core/rmem_max is not readable here; LCM URLs keep their recv_buf_size"
  exit 0
fi
grant() { echo $((2 * ($1 < rmem_max ? $1 : rmem_max))); }
echo "receive buffers: net.core.rmem_max = $rmem_max bytes, rmem_default = ${rmem_default:-?} bytes;" \
  "an LCM URL asking recv_buf_size=4194304 gets $(grant 4194304) bytes per socket" \
  "(the sheets' 4 MiB needs rmem_max >= 4194304: sysctl -w net.core.rmem_max=4194304)"
$report_only && exit 0
# The rule, on real sockets: asked -> granted.
/usr/bin/python3 - "$rmem_max" <<'PY'
import socket, sys
rmem_max = int(sys.argv[1])
failed = False
for asked in (4096, 106496, rmem_max, 4194304, 8388608):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, asked)
    got = s.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
    s.close()
    want = 2 * min(asked, rmem_max)
    # The kernel has a floor (SOCK_MIN_RCVBUF, about 2 KB) far below every size asked here.
    status = "ok" if got == want else "FAIL"
    failed = failed or got != want
    print(f"  SO_RCVBUF {asked:>8}: granted {got:>8}, 2 x min(asked, rmem_max) = {want:>8}  {status}")
sys.exit(1 if failed else 0)
PY
