#!/usr/bin/python3
"""`import morsegs` beside GUDHI on one dense N^3 array (docs/python.md has the figures).

    PYTHONPATH=build/python /usr/bin/python3 scripts/bench_python.py [--size 256] [--sigma 4]
        [--field smooth|noise] [--skip-gudhi] [--threads K]

The field: white noise (seed 0), Gaussian-smoothed with std --sigma voxels by FFT (`smooth`,
a volume with structure at a few voxels) or left raw (`noise`, the worst case: a critical
cell every few cells), rescaled to [0, 1] and rounded to float32 — the values then exist
exactly in both libraries (GUDHI reads them as float64), so their diagrams must be equal as
multisets whatever order each gives to ties. Each run is a separate process (its own peak
RSS): morsegs T, morsegs V, then GUDHI 3.7's CubicalComplex(top_dimensional_cells) (T).
Prints the seconds (construction + persistence, Z/2, every positive pair), peak RSS, pair
counts, whether the T diagrams are equal, and one Markdown table."""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

CHILD = r"""
import json, resource, sys, time
import numpy as np
engine, construction, path, out = sys.argv[1:5]
f = np.load(path)
t0 = time.perf_counter()
if engine == "morsegs":
    import morsegs
    if len(sys.argv) > 5: morsegs.set_num_threads(int(sys.argv[5]))
    cc = morsegs.CubicalComplex(**{("top_dimensional_cells" if construction == "T" else "vertices"): f})
    p = cc.persistence()
else:
    import gudhi
    cc = gudhi.CubicalComplex(top_dimensional_cells=f)
    p = cc.persistence(homology_coeff_field=2, min_persistence=0)
dt = time.perf_counter() - t0
d = np.array([(k, b, e) for k, (b, e) in p if e > b], dtype=np.float64).reshape(-1, 3)
np.save(out, d[np.lexsort((d[:, 2], d[:, 1], d[:, 0]))])
print(json.dumps({"seconds": dt, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                  "pairs": int(len(d))}))
"""


def make_field(n, sigma, kind):
    rng = np.random.default_rng(0)
    f = rng.standard_normal((n, n, n), dtype=np.float32)
    if kind == "smooth":
        k = np.fft.fftfreq(n).astype(np.float32)
        g = np.exp(-2 * (np.pi * sigma) ** 2 * k ** 2).astype(np.float32)
        F = np.fft.rfftn(f)
        F *= g[:, None, None] * g[None, :, None] * g[None, None, : n // 2 + 1]
        f = np.fft.irfftn(F, s=f.shape).astype(np.float32)
    f -= f.min()
    f /= f.max()
    return np.ascontiguousarray(f, dtype=np.float32)


def run(engine, construction, path, out, threads):
    env = dict(os.environ)
    args = [sys.executable, "-c", CHILD, engine, construction, path, out] + ([str(threads)] if threads else [])
    r = subprocess.run(args, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit("bench_python: %s %s failed:\n%s" % (engine, construction, r.stderr))
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--sigma", type=float, default=4.0)
    ap.add_argument("--field", choices=("smooth", "noise"), default="smooth")
    ap.add_argument("--skip-gudhi", action="store_true")
    ap.add_argument("--threads", type=int, default=0, help="morsegs worker threads (0: all cores)")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="mgs_bench_python_")
    path = os.path.join(tmp, "field.npy")
    t0 = time.perf_counter()
    np.save(path, make_field(a.size, a.sigma, a.field))
    print("field: %d^3 %s (sigma %g), float32, made in %.1f s; load average %s" %
          (a.size, a.field, a.sigma, time.perf_counter() - t0, " ".join("%.1f" % x for x in os.getloadavg())))
    rows = []
    for engine, cons in [("morsegs", "T"), ("morsegs", "V")] + ([] if a.skip_gudhi else [("gudhi", "T")]):
        out = os.path.join(tmp, "%s_%s.npy" % (engine, cons))
        r = run(engine, cons, path, out, a.threads)
        r.update(engine=engine, construction=cons, out=out)
        rows.append(r)
        print("%-8s %s: %8.2f s  peak RSS %7.0f MB  %d pairs" % (engine, cons, r["seconds"], r["peak_rss_mb"], r["pairs"]))
        sys.stdout.flush()
    equal = None
    if not a.skip_gudhi:
        equal = bool(np.array_equal(np.load(rows[0]["out"]), np.load(rows[2]["out"])))
        print("T diagrams equal (morsegs == GUDHI, as multisets of (dim, birth, death)): %s" % equal)
        print("ratio GUDHI / morsegs (T): time %.1fx, peak RSS %.1fx" %
              (rows[2]["seconds"] / rows[0]["seconds"], rows[2]["peak_rss_mb"] / rows[0]["peak_rss_mb"]))
    print("\n| %d³ %s field | seconds | peak RSS (MB) | pairs |\n|---|---|---|---|" % (a.size, a.field))
    for r in rows:
        print("| %s (%s) | %.2f | %.0f | %d |" % (r["engine"], r["construction"], r["seconds"], r["peak_rss_mb"],
                                                   r["pairs"]))
    for r in rows:
        os.unlink(r["out"])
    os.unlink(path)
    os.rmdir(tmp)
    return 0 if equal in (None, True) else 1


if __name__ == "__main__":
    sys.exit(main())
