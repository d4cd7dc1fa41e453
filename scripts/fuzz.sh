#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/) and runs each for $1 seconds
# (default 20) from its seed corpus in tests/fuzz/corpus/NAME.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-20}
CC=clang CXX=clang++ MGS_TARGET=fuzzers scripts/build.sh build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMGS_FUZZ=ON -DMGS_NATIVE=OFF
shopt -s nullglob
ran=0
for f in build-fuzz/tests/fuzz/fuzz_*; do
  [ -x "$f" ] || continue
  name=$(basename "$f")
  corpus=tests/fuzz/corpus/${name#fuzz_}
  work=build-fuzz/corpus-${name#fuzz_}
  mkdir -p "$work"
  [ -d "$corpus" ] && cp -n "$corpus"/* "$work"/ 2>/dev/null || true
  echo "fuzz: $name for ${secs}s"
  "$f" -max_total_time="$secs" -rss_limit_mb=4096 -timeout=10 "$work" > "build-fuzz/$name.log" 2>&1 || { tail -50 "build-fuzz/$name.log"; echo "fuzz: $name FAILED"; exit 1; }
  ran=$((ran+1))
done
echo "fuzz: $ran fuzzers ran clean"
