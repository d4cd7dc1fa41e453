#!/usr/bin/env python3
"""Independent reference diagrams for tests/topo: reads a field written by the C tests and
prints its persistence diagram (Z/2, dims 0-2) computed by
  --ref phat : Debian's PHAT (python3-phat), twist reduction of the EXPLICIT boundary matrix of
               the full cubical complex (V or T construction), cells ordered by
               (value, dim, index in the doubled grid, x-major);
  --ref gudhi: GUDHI 3.7 CubicalComplex(top_dimensional_cells) (T construction only).
Field file: b"MGSF", int32 nx, ny, nz, construction (0=V, 1=T), superlevel (0/1),
float64 w (clamp half-width, inf = none), then nx*ny*nz float32 values, index (x*ny+y)*nz+z.
Values are converted to float64 exactly, negated for superlevel, clamped to [-w, w].
Output: one line per pair with positive persistence, "dim birth death" (%.17g, death "inf"
for essential classes), sorted. Exit 2 on bad input."""
import struct
import sys

import numpy as np


def read_field(path):
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:4] != b"MGSF":
        sys.exit("reference.py: %s: not a field file" % path)
    nx, ny, nz, cons, sup = struct.unpack_from("<5i", data, 4)
    (w,) = struct.unpack_from("<d", data, 24)
    vals = np.frombuffer(data, dtype="<f4", count=nx * ny * nz, offset=32).astype(np.float64)
    f = vals.reshape(nx, ny, nz)
    if sup:
        f = -f
    f = np.clip(f, -w, w)
    return f, cons


def doubled_values(f, cons):
    """Value of every cell of the doubled grid (V: max of vertices; T: min of cofaces)."""
    g = f
    for axis in range(3):
        g = np.moveaxis(g, axis, 0)
        n = g.shape[0]
        if cons == 0:
            out = np.empty((2 * n - 1,) + g.shape[1:])
            out[0::2] = g
            out[1::2] = np.maximum(g[:-1], g[1:])
        else:
            out = np.empty((2 * n + 1,) + g.shape[1:])
            out[1::2] = g
            pad = np.full((1,) + g.shape[1:], np.inf)
            left = np.concatenate([pad, g])
            right = np.concatenate([g, pad])
            out[0::2] = np.minimum(left, right)
        g = np.moveaxis(out, 0, axis)
    return g


def phat_diagram(f, cons):
    import phat

    vals = doubled_values(f, cons)
    shape = vals.shape
    a, b, c = np.meshgrid(*[np.arange(s) for s in shape], indexing="ij")
    dim = ((a & 1) + (b & 1) + (c & 1)).ravel()
    v = vals.ravel()
    idx = np.arange(v.size)
    order = np.lexsort((idx, dim, v))
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    strides = (shape[1] * shape[2], shape[2], 1)
    coords = (a.ravel(), b.ravel(), c.ravel())
    bd = np.full((v.size, 6), -1, dtype=np.int64)
    for ax in range(3):
        odd = (coords[ax] & 1) == 1
        ids = idx[odd]
        bd[ids, 2 * ax] = rank[ids - strides[ax]]
        bd[ids, 2 * ax + 1] = rank[ids + strides[ax]]
    cols = []
    bd_sorted = bd[order]
    dim_sorted = dim[order]
    for i in range(order.size):
        row = bd_sorted[i]
        cols.append((int(dim_sorted[i]), sorted(int(x) for x in row if x >= 0)))
    bm = phat.boundary_matrix(representation=phat.representations.vector_vector, columns=cols)
    pairs = bm.compute_persistence_pairs(reduction=phat.reductions.twist_reduction)
    vs = v[order]
    paired = np.zeros(order.size, dtype=bool)
    out = []
    for (bi, di) in pairs:
        paired[bi] = paired[di] = True
        if vs[di] > vs[bi]:
            out.append((int(dim_sorted[bi]), float(vs[bi]), float(vs[di])))
    for i in np.nonzero(~paired)[0]:
        out.append((int(dim_sorted[i]), float(vs[i]), float("inf")))
    return out


def gudhi_diagram(f, cons):
    import gudhi

    if cons != 1:
        sys.exit("reference.py: GUDHI 3.7 builds the T construction only")
    cc = gudhi.CubicalComplex(top_dimensional_cells=f)
    out = []
    for d, (b, e) in cc.persistence(homology_coeff_field=2, min_persistence=0):
        if e > b:
            out.append((int(d), float(b), float(e)))
    return out


def main():
    if len(sys.argv) != 4 or sys.argv[1] != "--ref" or sys.argv[2] not in ("phat", "gudhi"):
        print("usage: reference.py --ref phat|gudhi FIELD", file=sys.stderr)
        sys.exit(2)
    f, cons = read_field(sys.argv[3])
    diag = phat_diagram(f, cons) if sys.argv[2] == "phat" else gudhi_diagram(f, cons)
    for d, b, e in sorted(diag):
        print("%d %.17g %s" % (d, b, "inf" if e == float("inf") else "%.17g" % e))


if __name__ == "__main__":
    main()
