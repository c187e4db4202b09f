#!/usr/bin/env bash
# Builds a libFuzzer target with Debian's clang (ASan + UBSan) and runs it for a bounded time.
# Usage: run_fuzzer.sh NAME SECONDS OUT_DIR -- CLANG_ARGS...   (sources, -I paths, defines)
# Exit 0: no crash and no sanitizer report within SECONDS. A crash input is kept in OUT_DIR.
# Skips (exit 0 with a notice) only when clang++ is absent; scripts/setup installs it.
set -euo pipefail
name=$1; seconds=$2; out=$3; shift 3
[[ ${1:-} == "--" ]] && shift
clang=$(command -v clang++ || command -v clang++-14 || true)
if [[ -z "$clang" ]]; then
  echo "run_fuzzer: clang++ not installed; $name not fuzzed" >&2
  exit 0
fi
mkdir -p "$out/corpus-$name"
"$clang" -std=c++17 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -o "$out/$name" "$@"
cd "$out"
exec "./$name" -max_total_time="$seconds" -timeout=5 -rss_limit_mb=512 -print_final_stats=1 \
  "corpus-$name"
