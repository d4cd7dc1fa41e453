#!/usr/bin/python3
"""GUDHI reference for tests/topogs: reads points (text, 3 per line) from a file and prints
the persistence diagram "dim birth death" (death 'inf' for essential classes).
  --rips MAX_EDGE : RipsComplex(max_edge_length).create_simplex_tree(max_dimension=2), dims 0,1
  --weak-alpha    : the alpha complex's Delaunay triangulation (all simplices) re-valued by
                    each simplex's longest edge, dims 0..2"""
import sys, itertools, math
import gudhi

def main():
    args = sys.argv[1:]
    path = args[-1]
    pts = [tuple(map(float, l.split())) for l in open(path) if l.strip()]
    if args[0] == '--rips':
        st = gudhi.RipsComplex(points=pts, max_edge_length=float(args[1])).create_simplex_tree(max_dimension=2)
        dims = (0, 1)
    else:
        st = gudhi.AlphaComplex(points=pts).create_simplex_tree()
        # GUDHI's alpha complex drops duplicate points: vertex ids index `pts` still
        for s, _ in list(st.get_simplices()):
            v = 0.0
            for a, b in itertools.combinations(s, 2):
                v = max(v, math.dist(pts[a], pts[b]))
            st.assign_filtration(s, v)
        st.make_filtration_non_decreasing()
        dims = (0, 1, 2)
    for dim, (b, d) in st.persistence(homology_coeff_field=2, min_persistence=0.0):
        if dim in dims:
            print(dim, repr(b), 'inf' if math.isinf(d) else repr(d))

main()
