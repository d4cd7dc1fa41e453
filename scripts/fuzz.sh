#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/) and runs each for $1 seconds
# (default 20) from its seed corpus in tests/fuzz/corpus/NAME.
#   scripts/fuzz.sh [SECONDS]      the test command's short run
#   scripts/fuzz.sh --long [MIN]   depth run, not in CI: every target MIN minutes (>= 10,
#                                  default 10); prints executions and findings per target
# A finding stops the run (crash-*, leak-*, oom-*, timeout-* files in the working dir):
# reduce it, fix it, and add it to tests/fuzz/corpus/NAME as a regression seed.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=20
if [ "${1:-}" = "--long" ]; then
  mins=${2:-10}
  [ "$mins" -ge 10 ] || { echo "fuzz.sh: --long runs at least 10 minutes per target" >&2; exit 2; }
  secs=$((mins * 60))
elif [ -n "${1:-}" ]; then
  secs=$1
fi
only=${MGS_FUZZ_ONLY:-}
CC=clang CXX=clang++ MGS_TARGET=fuzzers scripts/build.sh build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMGS_FUZZ=ON -DMGS_NATIVE=OFF
shopt -s nullglob
# the short run fuzzes two targets at a time (one per core of a 2-core CI machine)
jobs=${MGS_FUZZ_JOBS:-2}
[ "$secs" -ge 600 ] && jobs=1
run_one() {
  local f=$1 name corpus work stat
  name=$(basename "$f")
  corpus=tests/fuzz/corpus/${name#fuzz_}
  work=build-fuzz/corpus-${name#fuzz_}
  mkdir -p "$work"
  [ -d "$corpus" ] && cp -n "$corpus"/* "$work"/ 2>/dev/null || true
  echo "fuzz: $name for ${secs}s"
  "$f" -max_total_time="$secs" -rss_limit_mb=4096 -timeout=10 -artifact_prefix="build-fuzz/$name-" "$work" \
    > "build-fuzz/$name.log" 2>&1 || { tail -50 "build-fuzz/$name.log"; echo "fuzz: $name FAILED"; return 1; }
  # libFuzzer's last status line: "#N DONE cov: ... corp: ..."
  stat=$(grep -E "^#[0-9]+" "build-fuzz/$name.log" | tail -1 | awk '{print $1, "execs,", $3, $4, $5, $6, $7, $8}')
  echo "fuzz: $name clean after ${secs}s: ${stat}"
}
ran=0 failed=0
pids=()
for f in build-fuzz/tests/fuzz/fuzz_*; do
  [ -x "$f" ] || continue
  name=$(basename "$f")
  [ -n "$only" ] && [[ ",$only," != *",$name,"* ]] && continue
  run_one "$f" & pids+=($!)
  ran=$((ran+1))
  if [ "${#pids[@]}" -ge "$jobs" ]; then
    wait "${pids[0]}" || failed=1
    pids=("${pids[@]:1}")
  fi
done
for p in "${pids[@]}"; do wait "$p" || failed=1; done
[ "$failed" = 0 ] || { echo "fuzz: a fuzzer failed (above)"; exit 1; }
echo "fuzz: $ran fuzzers ran clean"
