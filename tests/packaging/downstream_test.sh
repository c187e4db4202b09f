#!/usr/bin/env bash
# A project outside Kestrel (tests/packaging/downstream) configured against the installed prefix
# only (find_package(Kestrel REQUIRED), kestrel::mapping), built, and run: its checks of a small
# map's posterior after one ray must pass.
# Usage: downstream_test.sh CMAKE GENERATOR SOURCE_DIR PREFIX WORK_DIR
set -euo pipefail
cmake=$1; generator=$2; source=$3; prefix=$4; work=$5
rm -rf "$work"
"$cmake" -S "$source" -B "$work" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >"$work.log" 2>&1 ||
  { cat "$work.log"; echo "FAIL: configure"; exit 1; }
# The headers must come from the prefix, never from the source tree.
grep -q "Kestrel_DIR:PATH=$prefix/lib/cmake/Kestrel" "$work/CMakeCache.txt" ||
  { grep Kestrel_DIR "$work/CMakeCache.txt"; echo "FAIL: Kestrel found outside $prefix"; exit 1; }
"$cmake" --build "$work" >>"$work.log" 2>&1 || { tail -30 "$work.log"; echo "FAIL: build"; exit 1; }
"$work/downstream"
