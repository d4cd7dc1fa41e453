#!/usr/bin/env bash
# Issue 27's run: MorseGS against the proposal's own baselines and on top of them, not in the
# test command. The three built-in scenes, four meshes nobody here made (netgen-doc's
# hinge.stl and part1.stl, gmsh-doc's lever.stl.gz, assimp-testmodels' textured duck.dae)
# at RES² (200), and a real COLMAP folder (colmap-hinge: COLMAP's SfM on 300² renders of
# the hinge, `scripts/colmap_scene.sh` with MIN_TRACK_LEN=3; GT mesh moved into its frame), the reference schedule compressed to
# ITERS (7500) with --schedule-scale SCALE (0.25), SEEDS (5) seeds, variants:
#   baseline, morse-r, morse-full                      3DGS and MorseGS on it
#   2dgs, 2dgs-morse-r (measured against 2dgs)         MorseGS' loss on 2DGS
#   mini-splatting, ms-morse-r (against mini-splatting) MorseGS' loss on Mini-Splatting
#   sugar, gaussianpro, topology-gs                    the other baselines
#   morse-d, morse-i                                   MorseGS' other components on 3DGS
# SuGaR, GaussianPro and Topology-GS (no MorseGS variant sits on them) with SEEDS_OTHER (3)
# seeds. H3's Pareto fronts (SWEEP_VARIANTS): baseline swept by --grad-threshold and morse-d
# by its spawning knob --gap-max, each ×{0.25,0.5,2,4}; mini-splatting by its simplification
# fraction (--simplify-fraction 0.5 × {0.25,0.5,1.5,2}: 0.125 … 1, the flag's range).
# Resumable: finished runs are kept and a run cut off continues from its checkpoint (a
# session's processes end when it stops). Cost (2-core machine, measured on the finished runs
# of 2026-11-27, one core each, two or four runs sharing the machine): a 7500-iteration 200²
# 3DGS run takes ~1,100 CPU-seconds with its EVALS (2) evaluation points, 2DGS ~1,700,
# Mini-Splatting ~1,200, SuGaR and GaussianPro ~1,400; the default plan (5 scenes × (9
# variants × 5 seeds + 3 × 3 seeds) + 3 × 4 × 5 scenes × 3 sweep seeds = 450 runs) is far
# beyond a 2-core machine's day, and even 3 seeds without sweeps (180 runs) is ~61 core-hours.
# PLAN=1 prints the estimate from the finished runs' own CPU times: run it where there are
# cores, or over many sessions with the variants that matter first (VARIANTS). Runs go seed by seed; in each seed
# the FIRST variants (the proposal's baselines) on every scene come before the MorseGS
# variants, so a run stopped early compares the baselines on every scene, then has every
# scene and variant with its first seeds.
#   scripts/experiment_baselines.sh [DIR]   (default exp-baselines; build/ must hold morsegs)
# RES, ITERS, SCALE, SEEDS, EVALS (2), VIEWS, TEST_VIEWS, SCENES ("sphere genus2 thin hinge lever"),
# SWEEP ("0.25,0.5,2,4"; "none"), SWEEP_SEEDS (3), SWEEP_VARIANTS, MORSEGS (a frozen binary for a run spread over days),
# VARIANTS (the twelve above; --base, --variant-seeds, SWEEP_VARIANTS and FIRST keep the listed ones),
# FIRST ("baseline,2dgs,mini-splatting,sugar,gaussianpro"), MGS_THREADS (1), JOBS (2: runs at a time, one core each), NICE (10), PLAN (1: print the
# runs and the estimated time, train nothing), REEVALUATE (1: the finished runs are evaluated again with this binary,
# once, after the evaluation changed; nothing is trained again), RECORDS (a folder kept in git: finished runs' records are restored from it
# before the experiment starts and saved to it every 5 minutes and at the end, scripts/experiment_records.sh — a new
# machine has no DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-exp-baselines}
M=${MORSEGS:-build/apps/morsegs}
[ -x "$M" ] || { echo "experiment_baselines.sh: $M not found: run scripts/build.sh build first" >&2; exit 2; }
hinge=/usr/share/doc/netgen/examples/hinge.stl
lever=/usr/share/doc/gmsh-doc/converters/stl_to_cartesian/lever.stl.gz
part1=/usr/share/doc/netgen/examples/part1.stl
duck=/usr/share/assimp/models/Collada/duck.dae
RES=${RES:-200}; ITERS=${ITERS:-7500}; SCALE=${SCALE:-0.25}; SEEDS=${SEEDS:-5}; EVALS=${EVALS:-2}
SCENES=${SCENES:-sphere genus2 thin hinge lever duck part1 colmap-hinge}
S="--views ${VIEWS:-60} --test-views ${TEST_VIEWS:-20} --width $RES --height $RES"
mkdir -p "$dir/scenes"
data=()
for b in $SCENES; do
  if [ ! -f "$dir/scenes/$b/scene.json" ] && [ ! -d "$dir/scenes/$b/sparse/0" ]; then
    case $b in
      hinge) [ -f "$hinge" ] || { echo "experiment_baselines.sh: $hinge missing: apt-get install netgen-doc" >&2; exit 2; }
             "$M" scene "$hinge" -o "$dir/scenes/hinge" $S -q ;;
      lever) [ -f "$lever" ] || { echo "experiment_baselines.sh: $lever missing: apt-get install gmsh-doc" >&2; exit 2; }
             zcat "$lever" > "$dir/scenes/lever.stl" && "$M" scene "$dir/scenes/lever.stl" -o "$dir/scenes/lever" $S -q ;;
      part1) [ -f "$part1" ] || { echo "experiment_baselines.sh: $part1 missing: apt-get install netgen-doc" >&2; exit 2; }
             "$M" scene "$part1" -o "$dir/scenes/part1" $S -q ;;
      duck) [ -f "$duck" ] || { echo "experiment_baselines.sh: $duck missing: apt-get install assimp-testmodels" >&2; exit 2; }
            "$M" scene "$duck" -o "$dir/scenes/duck" $S -q ;;
      colmap-hinge) command -v colmap > /dev/null || { echo "experiment_baselines.sh: colmap missing: apt-get install colmap" >&2; exit 2; }
            MORSEGS="$M" MIN_TRACK_LEN=3 scripts/colmap_scene.sh "$hinge" "$dir/scenes/colmap-hinge" ;;
      *) "$M" scene --builtin "$b" -o "$dir/scenes/$b" $S -q ;;
    esac
  fi
  data+=("$dir/scenes/$b")
done
V=${VARIANTS:-baseline,2dgs,mini-splatting,sugar,gaussianpro,topology-gs,morse-r,2dgs-morse-r,ms-morse-r,morse-full,morse-d,morse-i}
has() { case ",$V," in *",$1,"*) return 0 ;; esac; return 1; }
keep() { local out= x; for x in ${1//,/ }; do has "$x" && out=${out:+$out,}$x; done; echo "$out"; }
extra=()
has 2dgs-morse-r && has 2dgs && extra+=(--base 2dgs-morse-r=2dgs)
has ms-morse-r && has mini-splatting && extra+=(--base ms-morse-r=mini-splatting)
for v in sugar gaussianpro topology-gs; do has $v && extra+=(--variant-seeds "$v=${SEEDS_OTHER:-3}"); done
sv=$(keep "${SWEEP_VARIANTS:-baseline,mini-splatting,morse-d}"); [ -n "$sv" ] && extra+=(--sweep-variants "$sv")
# its own sweep (the knob the issue names), unless sweeps are off (SWEEP=none: experiment_30k.sh)
has mini-splatting && [ "${SWEEP:-}" != none ] && extra+=(--knob mini-splatting=--simplify-fraction:0.5 --sweep-of mini-splatting=0.25,0.5,1.5,2)
fv=$(keep "${FIRST:-baseline,2dgs,mini-splatting,sugar,gaussianpro}"); [ -n "$fv" ] && extra+=(--first "$fv")
if [ -n "${RECORDS:-}" ]; then
  scripts/experiment_records.sh restore "$RECORDS" "$dir/results"
  if [ -z "${PLAN:-}" ]; then
    scripts/experiment_records.sh watch "$dir/results" "$RECORDS" 300 &
    watcher=$!
    trap 'kill $watcher 2> /dev/null; scripts/experiment_records.sh save "$dir/results" "$RECORDS"' EXIT
  fi
fi
run=exec; [ -n "${RECORDS:-}" ] && run=
MGS_THREADS=${MGS_THREADS:-1} $run nice -n "${NICE:-10}" "$M" experiment "${data[@]}" -o "$dir/results" \
  --iters "$ITERS" --evals "$EVALS" --seeds "$SEEDS" --sweep "${SWEEP:-0.25,0.5,2,4}" --sweep-seeds "${SWEEP_SEEDS:-3}" \
  --train-arg=--schedule-scale="$SCALE" \
  --variant 2dgs="--model 2dgs" --variant 2dgs-morse-r="--model 2dgs --preset morse-r" \
  --variant mini-splatting="--strategy mini-splatting" \
  --variant ms-morse-r="--strategy mini-splatting --preset morse-r" \
  --variant sugar="--preset sugar" --variant gaussianpro="--strategy gaussianpro" \
  --variants "$V" "${extra[@]}" --jobs "${JOBS:-2}" ${PLAN:+--plan} ${REEVALUATE:+--reevaluate}
