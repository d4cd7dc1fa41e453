#!/usr/bin/env bash
# Keeps a `morsegs experiment`'s finished runs across machines. A session's machine can be
# new (its /work/runs gone: session 9 lost the 11 runs of sessions 7–8 that way), and a run's
# folder holds its model (MBs); what the report needs of a finished run is small:
# result.json (the harness takes a run as finished when it reads), eval_<N>.json, cfg_args,
# experiment_args, saves.csv. These, and the experiment's experiment.json, are copied to a
# records folder kept in git; on a new machine they are copied back before the experiment
# starts, so it trains only what is missing and writes its report from every run.
#   scripts/experiment_records.sh save    RESULTS RECORDS   copy finished runs' records out
#   scripts/experiment_records.sh restore RECORDS RESULTS   copy them into RESULTS (runs it
#                                                           lacks only; nothing is overwritten)
#   scripts/experiment_records.sh watch   RESULTS RECORDS [SECONDS (300)]   save every SECONDS
# restore refuses when RESULTS/experiment.json exists and differs from the records' (other
# iterations or evaluation points: the harness would refuse the mix too).
set -euo pipefail
files="result.json cfg_args experiment_args saves.csv"
die() { echo "experiment_records.sh: $*" >&2; exit 2; }
copy_runs() { # FROM TO ONLY_MISSING
  local from=$1 to=$2 only_missing=$3 n=0 r d f
  while IFS= read -r r; do
    d=${r%/result.json}; d=${d#"$from"/}
    if [ "$only_missing" = 1 ] && [ -f "$to/$d/result.json" ]; then continue; fi
    if [ "$only_missing" = 0 ] && [ -f "$to/$d/result.json" ] && cmp -s "$r" "$to/$d/result.json"; then continue; fi
    mkdir -p "$to/$d"
    # result.json last: a run copied half-way is not taken as finished
    for f in $files "$from/$d"/eval_*.json; do
      f=${f##*/}
      [ "$f" = result.json ] && continue
      if [ -f "$from/$d/$f" ]; then cp -p "$from/$d/$f" "$to/$d/$f.tmp" && mv "$to/$d/$f.tmp" "$to/$d/$f"; fi
    done
    cp -p "$r" "$to/$d/result.json.tmp" && mv "$to/$d/result.json.tmp" "$to/$d/result.json"
    n=$((n + 1))
  done < <(find "$from/runs" -name result.json 2> /dev/null | sort)
  echo "$n"
}
[ $# -ge 3 ] || die "usage: $0 save RESULTS RECORDS | restore RECORDS RESULTS | watch RESULTS RECORDS [SECONDS]"
cmd=$1; a=${2%/}; b=${3%/}
case $cmd in
  save|watch)
    # watch starts with the experiment, before its first run folder exists
    [ "$cmd" = watch ] || [ -d "$a/runs" ] || die "$a: no runs/ folder (not a morsegs experiment's -o folder)"
    mkdir -p "$b"
    while :; do
      [ -d "$a/runs" ] || { sleep "${4:-300}"; continue; }
      [ -f "$a/experiment.json" ] && cp -p "$a/experiment.json" "$b/experiment.json"
      n=$(copy_runs "$a" "$b" 0)
      [ "$cmd" = save ] && { echo "saved $n new or changed runs of $a to $b"; break; }
      [ "$n" = 0 ] || echo "$(date -u +%H:%M:%S) saved $n runs of $a to $b"
      sleep "${4:-300}"
    done ;;
  restore)
    [ -d "$a" ] || { echo "experiment_records.sh: no records folder $a yet: nothing restored (a new experiment)"; exit 0; }
    if [ -f "$a/experiment.json" ] && [ -f "$b/experiment.json" ] && ! cmp -s "$a/experiment.json" "$b/experiment.json"; then
      die "$b/experiment.json differs from $a/experiment.json: the records were made with other settings; restore into a new folder"
    fi
    mkdir -p "$b"
    [ -f "$a/experiment.json" ] && [ ! -f "$b/experiment.json" ] && cp -p "$a/experiment.json" "$b/experiment.json"
    n=0; [ -d "$a/runs" ] && n=$(copy_runs "$a" "$b" 1)
    echo "restored $n finished runs from $a into $b" ;;
  *) die "unknown command '$cmd' (save, restore or watch)" ;;
esac
