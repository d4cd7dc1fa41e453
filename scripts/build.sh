#!/usr/bin/env bash
# Configures and builds into build/ (or $1 with extra cmake args after it).
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-build}; shift || true
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" > "$dir.configure.log" 2>&1 || { cat "$dir.configure.log"; exit 1; }
# MGS_TARGET limits the build to one target (the fuzz build builds only "fuzzers").
cmake --build "$dir" -j"$(nproc)" ${MGS_TARGET:+--target "$MGS_TARGET"}
