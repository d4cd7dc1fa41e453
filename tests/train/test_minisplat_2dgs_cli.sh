#!/usr/bin/env bash
# `morsegs train --model 2dgs --strategy mini-splatting` end to end: the built-in sphere at
# 48x48 (8 views), the reference schedule compressed to 650 iterations (--schedule-scale
# 0.03: reinitialisations at 150 and 300, simplification at 450, the 1 % cut at 600;
# densification every 3 iterations, held in check by a higher gradient threshold and
# blur-split floor). Both reinitialisations and both simplifications run, each
# simplification lowers the count (the first to at most half), the model written is 2DGS
# (two scale columns) and its test PSNR is finite and well above the untrained model's
# (10.2 dB on this scene with --freeze; measured: 22.3 dB with 1029 surfels, 2DGS with ADC at
# the same settings 23.3 dB with 7363).
#   test_minisplat_2dgs_cli.sh MORSEGS WORKDIR
set -euo pipefail
cli=$1 work=$2
rm -rf "$work" && mkdir -p "$work" && cd "$work"
fail() { cat train.log 2>/dev/null | grep -v "^train " || true; echo "FAIL: $*" >&2; exit 1; }
"$cli" scene --builtin sphere -o data --views 8 --test-views 4 --width 48 --height 48 --spp 2 --init-points 1000 > /dev/null
rm data/gt_mesh.ply # eval: the image metrics only (the geometry's fusion would cost most of the test's time)
"$cli" train data -o run --model 2dgs --strategy mini-splatting --iters 650 --schedule-scale 0.03 \
  --grad-threshold 0.001 --ms-blur-min-px 24 --seed 1 --threads 1 > train.log 2>&1 || fail "training failed"
for it in 150 300; do
  grep -q "mini-splatting: iteration $it: depth reinitialisation" train.log || fail "no reinitialisation at $it"
done
# "mini-splatting: iteration 450: simplification, A -> B Gaussians"
read -r a b < <(sed -n 's/.*iteration 450: simplification, \([0-9]*\) -> \([0-9]*\) Gaussians.*/\1 \2/p' train.log)
[ -n "${a:-}" ] || fail "no simplification at 450"
[ "$b" -gt 0 ] && [ $((2 * b)) -le "$a" ] || fail "simplification $a -> $b: not at most half"
read -r c d < <(sed -n 's/.*iteration 600: 1 % importance cut, \([0-9]*\) -> \([0-9]*\) Gaussians.*/\1 \2/p' train.log)
[ "${c:-}" = "$b" ] && [ "$d" -gt 0 ] && [ "$d" -lt "$c" ] || fail "1 % cut at 600: '${c:-}' -> '${d:-}' after $b"
ply=run/point_cloud/iteration_650/point_cloud.ply
head -c 2000 "$ply" | grep -aq "property float scale_1" || fail "no scale_1 in $ply"
if head -c 2000 "$ply" | grep -aq "property float scale_2"; then fail "$ply has a third scale: not 2DGS"; fi
"$cli" eval run --no-images > eval.log 2>&1 || { cat eval.log; fail "eval failed"; }
psnr=$(tr -d '\n\t ' < run/results.json | sed -n 's/.*"ours_650":{"PSNR":\([-0-9.eE+]*\),.*/\1/p')
n=$(tr -d '\n\t ' < run/results.json | sed -n 's/.*"gaussians":\([0-9]*\),.*/\1/p')
echo "mini-splatting on 2dgs: simplification $a -> $b, 1 % cut -> $d surfels; test PSNR $psnr dB ($n surfels)"
[ "$n" = "$d" ] || fail "results.json counts $n surfels, the run ended with $d"
awk -v p="$psnr" 'BEGIN { exit !(p == p + 0 && p > 18 && p < 100) }' || fail "test PSNR '$psnr' not in (18, 100) dB"
echo "test_minisplat_2dgs_cli: OK"
