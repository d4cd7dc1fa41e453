#!/usr/bin/env bash
# Issue 28's figure: one scene trained at translations 0, 1e4, 1e5, 1e6 (cameras and
# points moved together by (T, T, -T); and the same without points3d.ply, random init),
# same seed and iterations; test PSNR, and the persistence of the exported SDF
# (`morsegs vdb` + `morsegs persistence`): Betti numbers at 0 and the bottleneck distance
# to the centred model's diagram (GUDHI, /usr/bin/python3), in voxels.
#   scripts/bench_far_origin.sh [--cli PATH] [--work DIR] [--size 200] [--iters 1500] [--views 60]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cli=$here/../build/apps/morsegs work=/tmp/bench_far_origin size=200 iters=1500 views=60 threads=2 extra=
while [ $# -gt 0 ]; do
  case $1 in
    --cli) cli=$2; shift 2 ;; --work) work=$2; shift 2 ;; --size) size=$2; shift 2 ;;
    --iters) iters=$2; shift 2 ;; --views) views=$2; shift 2 ;; --threads) threads=$2; shift 2 ;;
    --extra) extra=$2; shift 2 ;; # one more translation, e.g. 123456.789 (not on the origin grid)
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$work"
py=/usr/bin/python3
base=$work/data-0
[ -d "$base" ] || "$cli" scene --builtin genus2 -o "$base" --views "$views" --test-views 8 --width "$size" --height "$size" --spp 4 -q > /dev/null
rm -f "$base/gt_mesh.ply"
"$py" "$here/translate_scene.py" "$base" "$work/data-0-np" 0 0 0 --no-points
psnr() { "$py" -c "import json,sys; j=json.load(open(sys.argv[1])); print('%.3f' % list(j.values())[0]['PSNR'])" "$1/results.json"; }
bottleneck() { # centred diagram, moved diagram, voxel -> distance in voxels
  "$py" - "$1" "$2" "$3" <<'PY'
import sys, gudhi
def load(p):
    d = {0: [], 1: [], 2: []}
    for line in open(p):
        w = line.split()
        if len(w) == 3 and not line.startswith('#'):
            d[int(w[0])].append((float(w[1]), float(w[2])))
    return d
a, b = load(sys.argv[1]), load(sys.argv[2])
d = max(gudhi.bottleneck_distance(a[k], b[k]) for k in range(3)) / float(sys.argv[3])
print('%.3g' % (d if d > 1e-9 else 0))  # GUDHI gives ~1e-307 for equal diagrams
PY
}
printf '| translation | test PSNR (points) | test PSNR (no points) | Betti b0 b1 b2 at 0 (points) | bottleneck to centred (voxels) | train s |\n|---|---|---|---|---|---|\n'
for t in 0 1e4 1e5 1e6 ${extra:-}; do
  d=$work/data-$t dnp=$work/data-$t-np
  if [ "$t" != 0 ]; then
    "$py" "$here/translate_scene.py" "$base" "$d" "$t" "$t" "-$t"
    "$py" "$here/translate_scene.py" "$base" "$dnp" "$t" "$t" "-$t" --no-points
  fi
  for x in "" -np; do
    "$cli" train "${d}$x" -o "$work/run-$t$x" --iters "$iters" --seed 0 --checkpoint-every 0 --quiet --threads "$threads" --force > /dev/null
    "$cli" eval "$work/run-$t$x" --no-images > /dev/null
  done
  "$cli" vdb "$work/run-$t/point_cloud/iteration_$iters/point_cloud.ply" -o "$work/run-$t/model.vdb" --force > "$work/run-$t/vdb.log" 2>&1
  voxel=$(sed -n 's/.*voxel size \([0-9.eE+-]*\),.*/\1/p' "$work/run-$t/vdb.log" | tail -1)
  "$cli" persistence "$work/run-$t/model.vdb" -o "$work/run-$t/pers" --force > /dev/null
  betti=$(awk '/^b[012] /{printf "%s ", $2}' "$work/run-$t/pers/betti.txt")
  bn=$(bottleneck "$work/run-0/pers/diagram.txt" "$work/run-$t/pers/diagram.txt" "$voxel")
  secs=$("$py" -c "import json,sys; print('%.0f' % json.load(open(sys.argv[1]))['train_seconds'])" "$work/run-$t/train_stats.json")
  label=$([ "$t" = 0 ] && echo "none" || echo "($t, $t, -$t)")
  printf '| %s | %s dB | %s dB | %s| %s | %s |\n' "$label" "$(psnr "$work/run-$t")" "$(psnr "$work/run-$t-np")" "$betti" "$bn" "$secs"
done
