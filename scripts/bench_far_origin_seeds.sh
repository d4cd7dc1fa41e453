#!/usr/bin/env bash
# Issue 28's PSNR tolerances, settled over seeds: the single-seed table of
# scripts/bench_far_origin.sh moves by as much between two trainings of the same folder as
# between a centred and a moved one (its control row), so each translation is trained with
# seeds 0..N-1 and compared with the centred run of the same seed. Prints, per translation
# and init, the mean paired PSNR change (moved - centred) with its 95 % t-interval, and
# the same for a control folder moved by 1e-9 (origin stays 0: only the float noise).
#   scripts/bench_far_origin_seeds.sh [--cli PATH] [--work DIR] [--size 200] [--iters 1500]
#       [--views 60] [--seeds 5] [--threads 2] [--translations "1e4 1e5 1e6"]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cli=$here/../build/apps/morsegs work=/tmp/bench_far_origin size=200 iters=1500 views=60 seeds=5 threads=2
translations="1e4 1e5 1e6"
while [ $# -gt 0 ]; do
  case $1 in
    --cli) cli=$2; shift 2 ;; --work) work=$2; shift 2 ;; --size) size=$2; shift 2 ;;
    --iters) iters=$2; shift 2 ;; --views) views=$2; shift 2 ;; --threads) threads=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;; --translations) translations=$2; shift 2 ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done
mkdir -p "$work"
py=/usr/bin/python3
base=$work/data-0
[ -d "$base" ] || "$cli" scene --builtin genus2 -o "$base" --views "$views" --test-views 8 --width "$size" --height "$size" --spp 4 -q > /dev/null
rm -f "$base/gt_mesh.ply"
[ -d "$work/data-0-np" ] || "$py" "$here/translate_scene.py" "$base" "$work/data-0-np" 0 0 0 --no-points
for t in $translations 1e-9; do
  [ -d "$work/data-$t" ] || "$py" "$here/translate_scene.py" "$base" "$work/data-$t" "$t" "$t" "-$t"
  [ -d "$work/data-$t-np" ] || "$py" "$here/translate_scene.py" "$base" "$work/data-$t-np" "$t" "$t" "-$t" --no-points
done
runs=$work/seed-runs; mkdir -p "$runs"
for s in $(seq 0 $((seeds - 1))); do
  for t in 0 1e-9 $translations; do
    for x in "" -np; do
      r=$runs/run-$t$x-s$s
      [ -f "$r/results.json" ] && continue # resumable: finished runs are kept
      "$cli" train "$work/data-$t$x" -o "$r" --iters "$iters" --seed "$s" --checkpoint-every 0 --quiet --threads "$threads" --force > /dev/null
      "$cli" eval "$r" --no-images > /dev/null
    done
  done
done
"$py" - "$runs" "$seeds" "0 1e-9 $translations" <<'PY'
import json, sys, os
from scipy import stats
runs, seeds, ts = sys.argv[1], int(sys.argv[2]), sys.argv[3].split()
def psnr(t, x, s):
    j = json.load(open(os.path.join(runs, f"run-{t}{x}-s{s}", "results.json")))
    return list(j.values())[0]["PSNR"]
print("| translation | init | centred PSNR, mean over seeds | mean change (moved - centred) | 95 % t-interval | max |change| |")
print("|---|---|---|---|---|---|")
for x, name in (("", "points"), ("-np", "no points")):
    c = [psnr("0", x, s) for s in range(seeds)]
    for t in ts[1:]:
        d = [psnr(t, x, s) - c[s] for s in range(seeds)]
        m = sum(d) / seeds
        sd = (sum((v - m) ** 2 for v in d) / (seeds - 1)) ** 0.5
        h = stats.t.ppf(0.975, seeds - 1) * sd / seeds ** 0.5
        label = "control 1e-9" if t == "1e-9" else t
        print(f"| {label} | {name} | {sum(c)/seeds:.3f} dB | {m:+.3f} dB | [{m-h:+.3f}, {m+h:+.3f}] | {max(abs(v) for v in d):.3f} |")
PY
