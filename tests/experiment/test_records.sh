#!/usr/bin/env bash
# scripts/experiment_records.sh: a finished run's records, restored on a machine that never
# saw the experiment, make `morsegs experiment` take the run as finished (nothing trained,
# the report has its figures); a run whose copy stopped before result.json is trained again;
# restore never overwrites and refuses records of other settings.
#   test_records.sh MORSEGS RECORDS_SCRIPT WORKDIR
set -euo pipefail
cli=$1 rec=$2 work=$3
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work" && mkdir -p "$work" && cd "$work"
"$cli" scene --builtin sphere -o ds --views 6 --test-views 2 --width 32 --height 32 --spp 1 --init-points 800 -q > /dev/null
exp() { MGS_THREADS=1 "$cli" experiment ds -o "$1" --iters 200 --seeds 2 --evals 1 --sweep none --topo-res 64 --variants baseline > "$1.log" 2>&1; }
exp first || { cat first.log; fail "first experiment"; }
"$rec" save first records > save.log
grep -q "saved 2 new or changed runs" save.log || { cat save.log; fail "save did not copy both runs"; }
[ ! -e records/runs/ds/baseline/seed_0/point_cloud ] || fail "the model was copied into the records"
[ -f records/runs/ds/baseline/seed_0/eval_200.json ] || fail "eval_200.json not in the records"
"$rec" save first records | grep -q "saved 0 new" || fail "a second save copied unchanged runs again"
# a copy cut off before result.json: that run must be redone
rm records/runs/ds/baseline/seed_1/result.json
"$rec" restore records second > restore.log
grep -q "restored 1 finished runs" restore.log || { cat restore.log; fail "restore"; }
exp second || { cat second.log; fail "second experiment"; }
grep -q "1 finished before" second.log || { cat second.log; fail "the restored run was not taken as finished"; }
grep -q "ds / baseline / seed 1: training" second.log || { cat second.log; fail "the incomplete run was not trained"; }
if grep -q "ds / baseline / seed 0: training" second.log; then cat second.log; fail "the restored run was trained again"; fi
cmp -s first/runs/ds/baseline/seed_0/result.json second/runs/ds/baseline/seed_0/result.json || fail "restored result.json differs"
grep -q "baseline" second/RESULTS.md || fail "the report lacks the restored variant"
# nothing is overwritten: a restore over a folder that has the run keeps its file
echo '{"changed":1}' > keep.json && cp keep.json second/runs/ds/baseline/seed_0/result.json
"$rec" restore records second > /dev/null
cmp -s keep.json second/runs/ds/baseline/seed_0/result.json || fail "restore overwrote an existing result.json"
# other settings: refused, with the file named
mkdir -p third && echo '{"format":"morsegs-experiment","iterations":5}' > third/experiment.json
if "$rec" restore records third 2> third.err; then fail "restore accepted records of other settings"; fi
grep -q "third/experiment.json differs" third.err || { cat third.err; fail "refusal does not name the file"; }
if "$rec" save nowhere records 2> none.err; then fail "save from a folder without runs/ succeeded"; fi
grep -q "nowhere: no runs/ folder" none.err || { cat none.err; fail "bad folder not named"; }
echo "test_records: OK"
