#!/usr/bin/env bash
# Seeds the Vicon parser's corpus with two datagrams written byte by byte from the documented
# layout (frame, count; id 0, size 72, name, 6 doubles), then runs tests/tools/run_fuzzer.sh.
# Usage: run_vicon_fuzz.sh SECONDS OUT_DIR SOURCE_DIR EIGEN_INCLUDE_DIR
set -euo pipefail
seconds=$1; out=$2; src=$3; eigen=$4
corpus="$out/corpus-vicon_packet_fuzz"
mkdir -p "$corpus"
name='kestrel\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0'   # 7 + 17 NULs = 24 bytes
d1000='\0\0\0\0\0\x40\x8f\x40'; dhalfpi='\x18\x2d\x44\x54\xfb\x21\xf9\x3f'; d0='\0\0\0\0\0\0\0\0'
printf "\x04\x03\x02\x01\x01\x00\x48\x00${name}${d1000}${d0}${d1000}${dhalfpi}${d0}${d0}" \
  > "$corpus/seed-one-object"
printf '\x07\x00\x00\x00\x00' > "$corpus/seed-empty-frame"
exec "$src/tests/tools/run_fuzzer.sh" vicon_packet_fuzz "$seconds" "$out" -- \
  "$src/tests/drivers/vicon/vicon_fuzz.cc" "$src/drivers/vicon/vicon_packet.cc" \
  -I"$src" -I"$eigen"
