#!/usr/bin/env bash
# Issue 27's subset at the reference schedule: does compressing it (experiment_baselines.sh,
# 7500 iterations at --schedule-scale 0.25) change a verdict? The full 30,000 iterations
# (--schedule-scale 1) on two scenes (genus2, and netgen-doc's hinge.stl), 3 seeds, no
# H3 sweep, variants: the 3DGS baseline, MorseGS-R and MorseGS-Full on it (their overhead at
# the default schedule is issue 25's figure), 2DGS and Mini-Splatting (the best baselines of
# H1 and H3). 30 runs, about 4× a 7500-iteration run each: ~14 CPU-hours by the plan's prior
# (PLAN=1 prints the estimate; it uses finished runs once there are some).
# Resumable like the other. Then compare the verdicts cell by cell:
#   scripts/experiment_summary.py --compare exp-baselines/results/RESULTS.json exp-30k/results/RESULTS.json
#   scripts/experiment_30k.sh [DIR]   (default exp-30k; the other variables as in experiment_baselines.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
VARIANTS=${VARIANTS:-baseline,2dgs,mini-splatting,morse-r,morse-full} ITERS=${ITERS:-30000} SCALE=${SCALE:-1} \
  SCENES=${SCENES:-genus2 hinge} SEEDS=${SEEDS:-3} SWEEP=${SWEEP:-none} EVALS=${EVALS:-4} \
  FIRST=${FIRST:-baseline,2dgs,mini-splatting} exec scripts/experiment_baselines.sh "${1:-exp-30k}"
