#!/usr/bin/env bash
# Crash-safety soak for `morsegs train` (issue 13).
#
#   scripts/soak.sh [--kills N] [--iters N] [--cli PATH] [--work DIR] [--seed S]
#   scripts/soak.sh --short          # the slow-suite version: 6 kills, 240 iterations
#   scripts/soak.sh --faults         # only disk full, read-only RUN, two trainers
#
# Soak: trains a small builtin scene uninterrupted (one thread, fixed seed) as the
# reference, then trains it again while SIGKILLing the trainer at random moments and
# resuming with --resume, N times (checkpoints every 5 iterations, so many kills land in a
# checkpoint write). After every kill the run folder must hold a checkpoint (once the first
# was written), every resume must load it, and the final point_cloud.ply must be
# byte-identical to the reference. Exits non-zero on any failure; prints the figures.
#
# Faults: a full disk (a small tmpfs when this runs as root and can mount, else
# RLIMIT_FSIZE through ulimit -f) and a read-only RUN (a read-only bind mount as root,
# else chmod) give a one-line error naming the file and leave the previous checkpoint
# byte-identical; a second trainer on a RUN in use is refused naming the holder.
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cli=${MGS_CLI:-$here/build/apps/morsegs}
work=""
kills=40
iters=400
seed=7
mode=soak
while [ $# -gt 0 ]; do
  case "$1" in
    --kills) kills=$2; shift ;;
    --iters) iters=$2; shift ;;
    --cli) cli=$2; shift ;;
    --work) work=$2; shift ;;
    --seed) seed=$2; shift ;;
    --short) kills=6; iters=240 ;;
    --faults) mode=faults ;;
    -h|--help) sed -n 2,20p "$0"; exit 0 ;;
    *) echo "soak.sh: unknown option $1" >&2; exit 2 ;;
  esac
  shift
done
[ -x "$cli" ] || { echo "soak.sh: $cli: morsegs binary not found (build first or pass --cli)" >&2; exit 2; }
[ -n "$work" ] || work=$(mktemp -d /tmp/mgs-soak-XXXXXX)
mkdir -p "$work"
work=$(cd "$work" && pwd)
export MGS_THREADS=1
fail=0
die() { echo "soak: FAIL: $*" >&2; fail=1; }
mounts=()
cleanup() {
  for m in "${mounts[@]}"; do umount "$m" 2>/dev/null; done
  [ -n "${holder:-}" ] && kill -9 "$holder" 2>/dev/null
}
trap cleanup EXIT

ds=$work/ds
if [ ! -f "$ds/transforms_train.json" ]; then
  "$cli" scene --builtin sphere -o "$ds" --views 8 --test-views 1 --width 32 --height 32 --init-points 300 -q --force \
    > "$work/scene.log" 2>&1 || { cat "$work/scene.log"; exit 1; }
fi
# Densification, opacity reset and SH increase all happen inside the run.
common=(--threads 1 --seed "$seed" --checkpoint-every 5 --densify-from 20 --densify-every 40 --densify-until 200
        --opacity-reset-every 120 --quiet)
train() { "$cli" train "$ds" "$@" "${common[@]}"; }

if [ "$mode" = faults ]; then
  # ---- disk full ----------------------------------------------------------------------
  run=$work/full
  rm -rf "$run"; mkdir -p "$run"
  use_tmpfs=0
  if [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=3m tmpfs "$run" 2>/dev/null; then use_tmpfs=1; mounts+=("$run"); fi
  train -o "$run" --iters 60 > "$work/full1.log" 2>&1 || { cat "$work/full1.log"; die "disk full: first run failed"; }
  cp "$run/checkpoint.mgsckpt" "$work/ckpt.before"
  if [ $use_tmpfs = 1 ]; then
    # leave ~40 KB: the next checkpoint (hundreds of KB) cannot be written
    free_kb=$(df -k --output=avail "$run" | tail -1)
    dd if=/dev/zero of="$run/filler" bs=1k count=$((free_kb - 40)) 2> /dev/null
    train -o "$run" --resume --iters 200 > "$work/full2.log" 2>&1; rc=$?
    rm -f "$run/filler"
    how="tmpfs of 3 MB"
  else
    ( trap '' XFSZ; ulimit -f 100; exec "$cli" train "$ds" -o "$run" --resume --iters 200 "${common[@]}" ) > "$work/full2.log" 2>&1; rc=$?
    how="ulimit -f 100 (RLIMIT_FSIZE)"
  fi
  msg=$(cat "$work/full2.log")
  [ "$rc" = 1 ] || die "disk full ($how): exit $rc, expected 1: $msg"
  msg=$(grep "^morsegs train:" "$work/full2.log")
  [ "$(grep -c "^morsegs train:" "$work/full2.log")" = 1 ] || die "disk full: expected a one-line error, got: $(cat "$work/full2.log")"
  grep -q "checkpoint.mgsckpt" "$work/full2.log" || die "disk full: message does not name the checkpoint: $msg"
  cmp -s "$run/checkpoint.mgsckpt" "$work/ckpt.before" || die "disk full: previous checkpoint changed"
  ls -a "$run" | grep -q "tmp-" && die "disk full: temp file left in $run"
  echo "soak: disk full ($how): exit $rc, '$msg'; previous checkpoint intact"
  # ...and the run resumes once there is space again
  train -o "$run" --resume --iters 80 > "$work/full3.log" 2>&1 || die "disk full: resume after freeing space failed: $(cat "$work/full3.log")"
  if [ $use_tmpfs = 1 ]; then umount "$run"; mounts=(); fi

  # ---- read-only RUN ------------------------------------------------------------------
  run=$work/ro
  rm -rf "$run"
  train -o "$run" --iters 60 > "$work/ro1.log" 2>&1 || { cat "$work/ro1.log"; die "read-only: first run failed"; }
  cp "$run/checkpoint.mgsckpt" "$work/ckpt.before"
  if [ "$(id -u)" = 0 ] && mount --bind "$run" "$run" 2>/dev/null && mount -o remount,ro,bind "$run" 2>/dev/null; then
    mounts+=("$run"); how="read-only bind mount"
  elif [ "$(id -u)" != 0 ]; then
    chmod a-w "$run"; how="chmod a-w"
  else
    umount "$run" 2>/dev/null; how=""
  fi
  if [ -n "$how" ]; then
    train -o "$run" --resume --iters 200 > "$work/ro2.log" 2>&1; rc=$?
    msg=$(cat "$work/ro2.log")
    [ "$rc" = 1 ] || die "read-only RUN ($how): exit $rc, expected 1: $msg"
    msg=$(grep "^morsegs train:" "$work/ro2.log")
    [ "$(grep -c "^morsegs train:" "$work/ro2.log")" = 1 ] || die "read-only RUN: expected a one-line error, got: $(cat "$work/ro2.log")"
    grep -q "$run" "$work/ro2.log" || die "read-only RUN: message does not name the folder: $msg"
    cmp -s "$run/checkpoint.mgsckpt" "$work/ckpt.before" || die "read-only RUN: previous checkpoint changed"
    echo "soak: read-only RUN ($how): exit $rc, '$msg'; previous checkpoint intact"
    if [ "$how" = "chmod a-w" ]; then chmod u+w "$run"; else umount "$run"; mounts=(); fi
  else
    echo "soak: read-only RUN: skipped (root without mount permission)"
  fi

  # ---- two trainers on one RUN ----------------------------------------------------------
  run=$work/two
  rm -rf "$run"
  "$cli" train "$ds" -o "$run" --iters 3000 "${common[@]}" > "$work/two1.log" 2>&1 &
  holder=$!
  for _ in $(seq 200); do [ -f "$run/checkpoint.mgsckpt" ] && break; sleep 0.05; done
  train -o "$run" --resume --iters 3000 > "$work/two2.log" 2>&1; rc=$?
  msg=$(cat "$work/two2.log")
  [ "$rc" = 1 ] || die "second trainer: exit $rc, expected 1: $msg"
  grep -q "another morsegs train (pid $holder)" "$work/two2.log" || die "second trainer: message does not name the holder: $msg"
  train -o "$run" --force --iters 10 > "$work/two3.log" 2>&1; rc=$?
  [ "$rc" = 1 ] || die "second trainer with --force: exit $rc, expected 1"
  kill -0 "$holder" 2>/dev/null || die "second trainer disturbed the first"
  [ -f "$run/cfg_args" ] || die "second trainer with --force removed the first one's files"
  kill -9 "$holder"; wait "$holder" 2>/dev/null; holder=""
  # the lock dies with its holder: a resume now works
  timeout 3 "$cli" train "$ds" -o "$run" --resume --iters 3000 "${common[@]}" > "$work/two4.log" 2>&1; rc=$?
  [ $rc = 0 ] || [ $rc = 124 ] || die "resume after the holder was killed: exit $rc: $(cat "$work/two4.log")"
  echo "soak: second trainer refused: '$msg'"
  [ $fail = 0 ] && echo "soak: faults OK" && rm -rf "$work"
  exit $fail
fi

# ---- soak -------------------------------------------------------------------------------
ref=$work/ref
run=$work/run
rm -rf "$ref" "$run"
t0=$(date +%s.%N)
train -o "$ref" --iters "$iters" > "$work/ref.log" 2>&1 || { cat "$work/ref.log"; exit 1; }
t1=$(date +%s.%N)
dur=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')
final=point_cloud/iteration_$iters/point_cloud.ply
RANDOM=$seed
killed=0; resumes=0; fresh=0; in_write=0; no_ckpt_window=0; starts=0
while [ $killed -lt "$kills" ]; do
  if [ -f "$run/checkpoint.mgsckpt" ]; then
    args=(--resume); resumes=$((resumes + 1))
  else
    args=(--force); fresh=$((fresh + 1))
  fi
  starts=$((starts + 1))
  "$cli" train "$ds" -o "$run" --iters "$iters" "${args[@]}" "${common[@]}" > "$work/part.log" 2>&1 &
  pid=$!
  # a random moment within the reference's run time
  delay=$(awk -v d="$dur" -v r="$RANDOM" 'BEGIN { printf "%.3f", d * r / 32768 }')
  sleep "$delay"
  if kill -9 $pid 2>/dev/null; then
    wait $pid 2>/dev/null
    killed=$((killed + 1))
    ls -a "$run" 2>/dev/null | grep -q "checkpoint.mgsckpt.tmp-" && in_write=$((in_write + 1))
    if [ ! -f "$run/checkpoint.mgsckpt" ]; then
      no_ckpt_window=$((no_ckpt_window + 1))
      # before its first checkpoint a killed run has trained nothing: --resume must say so
      # (the next start is a fresh one with --force)
      if [ -f "$run/cfg_args" ]; then
        "$cli" train "$ds" -o "$run" --resume "${common[@]}" > "$work/nockpt.log" 2>&1
        grep -q "no checkpoint to resume from" "$work/nockpt.log" ||
          die "kill $killed: record but no checkpoint, --resume: $(cat "$work/nockpt.log")"
      fi
    fi
  else
    wait $pid; rc=$?
    [ $rc = 0 ] || die "a run ended with exit $rc before it was killed: $(cat "$work/part.log")"
    # finished before the kill: start over so every kill hits a live run
    [ $rc = 0 ] && rm -rf "$run"
  fi
  [ $fail = 0 ] || break
done
# the last run goes to the end: a resume, or a fresh start when the last kill came before
# the first checkpoint (or the last run had finished and was removed) -- both must give
# the uninterrupted run's model
if [ -f "$run/checkpoint.mgsckpt" ]; then
  train -o "$run" --iters "$iters" --resume > "$work/last.log" 2>&1 || die "final resume failed: $(cat "$work/last.log")"
  resumes=$((resumes + 1))
else
  train -o "$run" --iters "$iters" --force > "$work/last.log" 2>&1 || die "final fresh run failed: $(cat "$work/last.log")"
  fresh=$((fresh + 1))
fi
same=no
cmp -s "$ref/$final" "$run/$final" && same=yes
[ $same = yes ] || die "final model differs from the uninterrupted run ($ref/$final vs $run/$final)"
echo "soak: $iters iterations, reference run ${dur}s; $killed SIGKILLs survived ($in_write during a checkpoint write," \
     "$no_ckpt_window before the first checkpoint), $resumes resumes, $fresh fresh starts; final model byte-identical: $same"
[ $fail = 0 ] && rm -rf "$work"
exit $fail
