#!/usr/bin/env bash
# Runs one libFuzzer target of tests/fuzz for a bounded time from its seeds (docs/design.md §7.7).
# Usage: run_fuzz.sh TARGET SECONDS WORK_DIR SEED_DIR... [-- EXTRA_LIBFUZZER_FLAGS...]
# The corpus lives in WORK_DIR/corpus (kept between runs); a crashing input is written to
# WORK_DIR/crash-*. Exit 0: no crash, no sanitizer report, no property broken within SECONDS.
# A missing TARGET (clang++ absent at configure time) skips with exit 77.
set -euo pipefail
target=$1; seconds=$2; work=$3; shift 3
seeds=()
while [[ $# -gt 0 && $1 != "--" ]]; do seeds+=("$1"); shift; done
[[ ${1:-} == "--" ]] && shift
if [[ ! -x $target ]]; then
  echo "run_fuzz: $target not built (clang++ missing when configured)" >&2
  exit 77
fi
mkdir -p "$work/corpus"
for dir in "${seeds[@]}"; do
  [[ -d $dir ]] && cp -n "$dir"/* "$work/corpus/" 2>/dev/null || true
done
cd "$work"
exec "$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=1024 -max_len=131072 -error_exitcode=1 \
  -print_final_stats=1 -artifact_prefix="$work/" "$@" corpus
