#!/usr/bin/env bash
# --schedule-scale so small that densification runs every few iterations warns (the counts
# are no longer the reference's); the 4x compression the experiment uses does not.
#   test_schedule_scale_cli.sh MORSEGS WORKDIR
set -euo pipefail
cli=$1 work=$2
rm -rf "$work" && mkdir -p "$work" && cd "$work"
"$cli" scene --builtin sphere -o data --width 24 --height 24 --views 4 --test-views 1 -q > /dev/null
"$cli" train data -o a --iters 2 --schedule-scale 0.05 --quiet > a.log 2>&1
grep -q "warning: --schedule-scale 0.05: densification every 5 iteration(s) (unscaled: 100)" a.log || { cat a.log; echo "FAIL: no warning at 0.05" >&2; exit 1; }
"$cli" train data -o b --iters 2 --schedule-scale 0.25 --quiet > b.log 2>&1
if grep -q "warning: --schedule-scale" b.log; then cat b.log; echo "FAIL: warned at 0.25" >&2; exit 1; fi
"$cli" train data -o c --iters 2 --schedule-scale 0.05 --densify-until 0 --quiet > c.log 2>&1
if grep -q "warning: --schedule-scale" c.log; then cat c.log; echo "FAIL: warned without densification" >&2; exit 1; fi
echo "test_schedule_scale_cli: OK"
