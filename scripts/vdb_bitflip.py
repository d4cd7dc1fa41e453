#!/usr/bin/env python3
"""Bit-flip run over `morsegs persistence` (issue 13): flips 1-16 random bits of a valid
.vdb (70% anywhere, 30% in its first 2 KB, where the headers are), N times, and checks
each run ends with exit 0 or a one-line error (exit 1), never a crash or a timeout;
reports the exit codes and the worst peak RSS. Failing inputs are kept as bad-N.vdb.

    scripts/vdb_bitflip.py build/apps/morsegs model.vdb [N=200] [SEED=1]
"""
import os, random, subprocess, sys, tempfile

cli, src = sys.argv[1], open(sys.argv[2], 'rb').read()
n = int(sys.argv[3]) if len(sys.argv) > 3 else 200
random.seed(int(sys.argv[4]) if len(sys.argv) > 4 else 1)
work = tempfile.mkdtemp(prefix='mgs-bitflip-')
path = os.path.join(work, 'flip.vdb')
stats, worst, bad = {}, 0, 0
for i in range(n):
    b = bytearray(src)
    for _ in range(random.choice([1, 1, 4, 16])):
        p = random.randrange(len(b)) if random.random() < 0.7 else random.randrange(min(len(b), 2000))
        b[p] ^= 1 << random.randrange(8)
    open(path, 'wb').write(b)
    try:
        r = subprocess.run(['/usr/bin/time', '-f', 'RSS %M', cli, 'persistence', path, '-o', os.path.join(work, 'out'), '--force'],
                           capture_output=True, timeout=120, text=True)
        rc = r.returncode
        worst = max(worst, int(r.stderr.strip().split('RSS ')[-1]))
        lines = [l for l in r.stderr.splitlines() if l.startswith('morsegs ')]
        ok = rc == 0 or (rc == 1 and len(lines) == 1)
    except subprocess.TimeoutExpired:
        rc, ok = 'timeout', False
    if not ok:
        bad += 1
        open('bad-%d.vdb' % i, 'wb').write(b)
        print('BAD', i, rc, file=sys.stderr)
    stats[rc] = stats.get(rc, 0) + 1
print('bitflip: %d runs, exit codes %s, worst peak RSS %d MB, %d bad' % (n, stats, worst // 1024, bad))
sys.exit(1 if bad else 0)
