#!/usr/bin/env bash
# New machine -> set up, build, run `morsegs demo` on the bundled default scene.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh build
build/apps/morsegs demo -o demo-out "$@"
