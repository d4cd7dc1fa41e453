#!/usr/bin/env bash
# A NeRF-synthetic folder rendered by Blender (not by `morsegs scene`), laid out as lego is:
# no point file, Blender's camera matrices and `camera_angle_x`, frames without extension,
# transparent background, cameras on the upper hemisphere mostly
# (scripts/blender_nerf_scene.py, assimp-testmodels' Wuson at 64²). Trained and evaluated
# against the mesh Blender rendered, in the transforms' frame: a camera convention or frame
# that is off by a flip or a transpose fails the PSNR or the Chamfer bound; so does a wrong
# GT frame (checked: the same eval against the GT mirrored upside down must fail the bound).
#   test_blender_scene.sh MORSEGS WORKDIR
set -euo pipefail
cli=$1 work=$2
here=$(cd "$(dirname "$0")/../.." && pwd)
mesh=/usr/share/assimp/models/OBJ/WusonOBJ.obj
command -v blender > /dev/null || { echo "blender not found: scripts/setup.sh installs Debian's blender" >&2; exit 1; }
[ -f "$mesh" ] || { echo "$mesh not found: scripts/setup.sh installs assimp-testmodels" >&2; exit 1; }
rm -rf "$work" && mkdir -p "$work" && cd "$work"
blender -b --factory-startup --python-exit-code 1 -P "$here/scripts/blender_nerf_scene.py" -- "$mesh" data 64 30 6 > blender.log 2>&1 ||
  { tail -20 blender.log; echo "FAIL: Blender did not render the scene" >&2; exit 1; }
[ ! -e data/points3d.ply ] && [ -f data/train/r_29.png ] && [ -f data/transforms_test.json ]
"$cli" train data -o run --iters 800 --schedule-scale 0.05 --threads 2 --quiet --checkpoint-every 0 > train.log 2>&1 ||
  { cat train.log; exit 1; }
grep -q "no initial points; random init" train.log || { cat train.log; echo "FAIL: expected the random init of a folder without points" >&2; exit 1; }
"$cli" eval run --no-images --mesh data/gt_mesh_blender.ply > eval.log 2>&1 || { cat eval.log; exit 1; }
grep -E "PSNR|Chamfer|default surface" eval.log
/usr/bin/python3 - run/results.json data/gt_mesh_blender.ply <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
r = r[next(iter(r))]  # {"ours_N": ...}, as the reference's results.json
psnr = r["PSNR"]; geo = r["geometry"]
cham = min(geo["chamfer"], geo.get("fused", {}).get("chamfer", float("inf")))
print("psnr %.2f dB, best surface Chamfer %.4f" % (psnr, cham))
ok = psnr > 30 and cham < 0.025
sys.exit(0 if ok else "FAIL: psnr %.2f (> 30 dB expected), Chamfer %.4f (< 0.025 expected)" % (psnr, cham))
PY
# the bound can fail: the GT mirrored upside down (a frame error) must be refused by it
/usr/bin/python3 - data/gt_mesh_blender.ply mirrored.ply <<'PY'
import struct, sys
b = open(sys.argv[1], "rb").read(); i = b.index(b"end_header\n") + 11
head = b[:i].decode()
assert "binary_little_endian" in head and "property float x\nproperty float y\nproperty float z\nelement face" in head, head
nv = int(head.split("element vertex ")[1].split()[0])
v = list(struct.unpack("<%df" % (3 * nv), b[i:i + 12 * nv]))
v[2::3] = [-z for z in v[2::3]]
open(sys.argv[2], "wb").write(b[:i] + struct.pack("<%df" % (3 * nv), *v) + b[i + 12 * nv:])
PY
"$cli" eval run --no-images --mesh mirrored.ply > eval_mirrored.log 2>&1 || { cat eval_mirrored.log; exit 1; }
m=$(grep -E "^  Chamfer distance" eval_mirrored.log | awk '{print $3}')
/usr/bin/python3 -c "import sys; c=float('$m'); print('mirrored GT: Chamfer %.4f' % c); sys.exit(0 if c > 0.025 else 'FAIL: the mirrored GT passed the bound')"
echo "test_blender_scene: OK"
