#!/usr/bin/env bash
# Issue 22: the fused .vdb opens in Blender (Debian's blender, --background --python). A
# trained model (genus-2 shape, no point file: hull init) -> morsegs vdb -> Blender imports
# the file, its Volume to Mesh of `sdf` (fused; and the alpha-surface's file) has the pieces and Euler
# characteristic of the mesh morsegs extracted from the same grid; a grid that is not in
# the file fails the check (the check can fail).
#   test_vdb_blender.sh MORSEGS WORKDIR
set -euo pipefail
cli=$1 work=$2
here=$(cd "$(dirname "$0")" && pwd)
command -v blender > /dev/null || { echo "blender not found: scripts/setup.sh installs Debian's blender" >&2; exit 1; }
rm -rf "$work" && mkdir -p "$work" && cd "$work"
"$cli" scene --builtin genus2 -o data --width 64 --height 64 --views 24 --test-views 2 -q > /dev/null
rm -f data/points3d.ply # as a NeRF-synthetic folder comes
"$cli" train data -o run --iters 600 --threads 2 --quiet --checkpoint-every 0 > train.log 2>&1
"$cli" vdb run -o fused.vdb --mesh fused.ply > vdb.log 2>&1
"$cli" vdb run/point_cloud/iteration_600/point_cloud.ply -o alpha.vdb --mesh alpha.ply > vdb_alpha.log 2>&1 # {A = 0.5}
check() {
  blender --background --factory-startup --python-exit-code 1 --python "$here/blender_vdb_check.py" -- "$@" > "blender-$2.log" 2>&1
}
check fused.vdb sdf fused.ply || { cat blender-sdf.log; echo "FAIL: Blender's mesh of sdf differs or did not load" >&2; exit 1; }
grep -E "^(grids|blender|morsegs)" blender-sdf.log
check alpha.vdb sdf alpha.ply || { cat blender-sdf.log; echo "FAIL: Blender's mesh of the alpha-surface differs or did not load" >&2; exit 1; }
grep -E "^(blender|morsegs)" blender-sdf.log
if check fused.vdb no_such_grid fused.ply; then echo "FAIL: the check passed on a grid that is not in the file" >&2; exit 1; fi
grep -q "FAIL: grid no_such_grid" blender-no_such_grid.log || { cat blender-no_such_grid.log; exit 1; }
echo "test_vdb_blender: OK"
