#!/usr/bin/env bash
# morsegs bench train --method NAME=ARGS trains NAME through the train command's option table
# and setup: "3dgs=" (no options) must train exactly what the default ADC run trains (same
# PSNR to the digit, same count), a 2DGS method must be a different model, bad method
# arguments must fail naming the method and the option.
#   test_bench_methods.sh MORSEGS WORKDIR
set -euo pipefail
cli=$1 work=$2
rm -rf "$work" && mkdir -p "$work" && cd "$work"
common=(bench train --scenes sphere --res 32 --iters 120 --no-peer --threads 1 --work "$work/data")
"$cli" "${common[@]}" -o default > default.log 2>&1
"$cli" "${common[@]}" -o methods --method "3dgs=" --method "surfels=--model 2dgs" > methods.log 2>&1
row() { awk -F, -v c="$2" '$2 == c && $3 == 120 {print $7 "," $8}' "$1/train.csv"; }
d=$(row default adc) m=$(row methods 3dgs) s=$(row methods surfels)
echo "default adc: $d   method 3dgs=: $m   method surfels: $s"
[ -n "$d" ] && [ "$d" = "$m" ] || { echo "FAIL: --method '3dgs=' differs from the default run ($m vs $d)" >&2; exit 1; }
[ -n "$s" ] && [ "$s" != "$m" ] || { echo "FAIL: the 2dgs method trained the same model" >&2; exit 1; }
grep -q "terms_ms" methods/train.csv || { echo "FAIL: no terms column" >&2; exit 1; }
# time to quality: the default target (the lowest final PSNR, floored to 0.1 dB) is reached by
# both methods, at a wall time between the two evaluations around the crossing
for cfg in 3dgs surfels; do
  line=$(grep "| sphere | $cfg |" methods/reach.md) || { cat methods/reach.md; echo "FAIL: no reach row for $cfg" >&2; exit 1; }
  echo "reach: $line"
  target=$(echo "$line" | awk -F'|' '{print $4 + 0}') wall=$(echo "$line" | awk -F'|' '{print $6 + 0}')
  awk -F, -v cfg="$cfg" -v target="$target" -v wall="$wall" '$1 == "sphere" && $2 == cfg {
      if (!done && $8 + 0 >= target) { hi = $4; done = 1 } else if (!done) lo = $4 }
    END { if (!done || wall > hi + 0.05 || wall < lo - 0.05) { print "FAIL: reach wall " wall " not in [" lo ", " hi "]"; exit 1 } }' \
    methods/train.csv || exit 1
done
# --from: the same time-to-quality table again from the CSV, without training
"$cli" bench train --from methods/train.csv -o again > again.log 2>&1
cmp methods/reach.md again/reach.md || { diff methods/reach.md again/reach.md; echo "FAIL: --from gives another reach.md" >&2; exit 1; }
[ -s again/train_cpu.png ] || { echo "FAIL: no CPU-time plot" >&2; exit 1; }
echo "not,a,csv" > bad.csv
if "$cli" bench train --from bad.csv -o bad4 > bad4.log 2>&1; then echo "FAIL: a bad CSV passed" >&2; exit 1; fi
grep -q "bad.csv: not a train.csv" bad4.log || { cat bad4.log; exit 1; }
"$cli" "${common[@]}" -o reach --method "3dgs=" --reach 99 > reach.log 2>&1
grep -q "| sphere | 3dgs | 99.00 | not reached by 120" reach/reach.md || { cat reach/reach.md; echo "FAIL: 99 dB reported reached" >&2; exit 1; }
if "$cli" "${common[@]}" -o bad --reach 30,abc > bad3.log 2>&1; then echo "FAIL: a bad --reach passed" >&2; exit 1; fi
grep -q "needs PSNR targets" bad3.log || { cat bad3.log; exit 1; }
if "$cli" "${common[@]}" -o bad --method "x=--no-such-option 3" > bad.log 2>&1; then echo "FAIL: a bad option passed" >&2; exit 1; fi
grep -q -- "--method x: unknown option --no-such-option" bad.log || { cat bad.log; exit 1; }
if "$cli" "${common[@]}" -o bad --method "noequals" > bad2.log 2>&1; then echo "FAIL: NAME=ARGS not checked" >&2; exit 1; fi
grep -q "needs NAME=ARGS" bad2.log || { cat bad2.log; exit 1; }
echo "test_bench_methods: OK"
