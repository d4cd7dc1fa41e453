"""morsegs.CubicalComplex(vertices=...) against PHAT (python3-phat): the explicit boundary
matrix of the V-construction (vertices = voxels, a cell's value the max of its vertices) built
in tests/topo/reference.py, reduced by PHAT's twist reduction; the same pairs (dimension,
birth, death). vertices_of_persistence_pairs points at vertices holding the birth and death."""
import os
import sys

import numpy as np

import morsegs
import pyt

sys.path.insert(0, os.path.join(pyt.SOURCE_DIR, "tests", "topo"))
import reference  # noqa: E402  (the PHAT / GUDHI reference of the C tests)


def random_field(rng, shape):
    """Distinct after rounding to float32 (see test_python_gudhi.random_field)."""
    n = int(np.prod(shape))
    a = ((rng.permutation(n) + 0.45 * rng.random(n)) / n).reshape(shape)
    assert np.unique(a.astype(np.float32)).size == n
    return a


def phat_pairs(a):
    f = a.reshape(a.shape + (1,) * (3 - a.ndim))
    return sorted((d, (b, e)) for d, b, e in reference.phat_diagram(f, 0))


def test_pairs_equal_phat():
    rng = np.random.default_rng(42)
    n = 0
    for shape in [(12,), (6, 9), (14, 11), (4, 5, 6), (7, 7, 7), (9, 8, 10), (11, 10, 9)]:
        for _ in range(2):
            a = random_field(rng, shape)
            ref = phat_pairs(a)
            got = sorted(morsegs.CubicalComplex(vertices=a).persistence())
            assert got == ref, (shape, len(got), len(ref))
            n += len(ref)
    print("  %d pairs equal" % n)


def test_ties_equal_phat():
    """Integer fields (many equal values): the diagram is unique, whatever the tie order."""
    rng = np.random.default_rng(8)
    for shape in [(10, 10), (7, 8, 9)]:
        a = rng.integers(0, 5, size=shape)
        assert sorted(morsegs.CubicalComplex(vertices=a).persistence()) == phat_pairs(a.astype(np.float64))


def test_vertices_of_persistence_pairs():
    rng = np.random.default_rng(4)
    for shape in [(9, 8, 7), (13, 12)]:
        a = random_field(rng, shape)
        m = morsegs.CubicalComplex(vertices=a)
        m.compute_persistence()
        regular, essential = m.vertices_of_persistence_pairs()
        flat = a.ravel(order="F")  # GUDHI's indices: Fortran-order flat index of the vertex
        got = []
        for h, pairs in enumerate(regular):
            assert pairs.dtype == np.int64 and pairs.ndim == 2 and pairs.shape[1] == 2
            got += [(h, (flat[b], flat[d])) for b, d in pairs]
        for h, births in enumerate(essential):
            assert births.ndim == 1
            got += [(h, (flat[b], np.inf)) for b in births]
        assert sorted(got) == phat_pairs(a)
        assert essential[0].tolist() == [int(np.argmin(flat))]  # the global minimum


if __name__ == "__main__":
    pyt.run(globals())
