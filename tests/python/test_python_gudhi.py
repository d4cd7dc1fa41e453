"""morsegs.CubicalComplex(top_dimensional_cells=...) against GUDHI 3.7.1's CubicalComplex on
dense random fields: the same pairs (dimension, birth, death) in the same order, the same
cofaces, Betti and persistent Betti numbers, intervals per dimension; the flat Fortran form;
float32 / integer input (ties: the diagram is unique, so it must still match); locations."""
import threading
import time

import gudhi
import numpy as np

import morsegs
import pyt


def distinct_in_float32(a):
    return np.unique(a.astype(np.float32)).size == a.size


def random_field(rng, shape, scale=1.0, offset=0.0):
    """Random float64 values (not float32-representable) that stay distinct after rounding to
    float32, the engine's precision: a random permutation of n levels, each jittered by less
    than half a level. The order of the cells, hence every pair, is then GUDHI's; plain
    rng.random() of 4000 values has a float32 collision about every other draw."""
    n = int(np.prod(shape))
    a = (rng.permutation(n) + 0.45 * rng.random(n)) / n * scale + offset
    a = a.reshape(shape)
    assert distinct_in_float32(a)
    return a


def fields():
    rng = np.random.default_rng(2026)
    shapes = [(9,), (40,), (5, 7), (16, 13), (24, 24), (3, 4, 5), (8, 8, 8), (12, 9, 10), (17, 15, 16)]
    for s in shapes:
        for _ in range(3):
            yield random_field(rng, s)
    yield random_field(rng, (20, 20, 20), 2e3, -1e3)  # other scale, negative values


def test_pairs_equal_gudhi():
    n = 0
    for a in fields():
        g = gudhi.CubicalComplex(top_dimensional_cells=a)
        gp = g.persistence(homology_coeff_field=2, min_persistence=0)
        m = morsegs.CubicalComplex(top_dimensional_cells=a)
        mp = m.persistence()
        assert sorted(gp) == sorted(mp), (a.shape, len(gp), len(mp))
        # GUDHI's order (dimension descending, persistence descending): same list
        assert [d for d, _ in gp] == [d for d, _ in mp]
        assert np.allclose([e - b if e < np.inf else np.inf for _, (b, e) in gp],
                           [e - b if e < np.inf else np.inf for _, (b, e) in mp])
        n += len(gp)
        for d in range(4):
            gi = g.persistence_intervals_in_dimension(d)
            mi = m.persistence_intervals_in_dimension(d)
            assert mi.shape[1] == 2 and mi.dtype == np.float64
            assert sorted(map(tuple, gi.reshape(-1, 2))) == sorted(map(tuple, mi))
        assert g.betti_numbers() == m.betti_numbers()
        for lo, hi in [(0.2, 0.5), (0.5, 0.5), (0.9, 0.1), (-1e9, 1e9), (1e9, 0.0)]:
            assert g.persistent_betti_numbers(lo, hi) == m.persistent_betti_numbers(lo, hi)
        assert g.dimension() == m.dimension() and g.num_simplices() == m.num_simplices()
    print("  %d pairs equal" % n)


def test_min_persistence_equal_gudhi():
    a = random_field(np.random.default_rng(7), (14, 12, 11))
    for mp in (0.0, 0.05, 0.2, 0.5):
        g = gudhi.CubicalComplex(top_dimensional_cells=a).persistence(homology_coeff_field=2, min_persistence=mp)
        m = morsegs.CubicalComplex(top_dimensional_cells=a)
        assert sorted(g) == sorted(m.persistence(min_persistence=mp)), mp
        m.compute_persistence(min_persistence=mp)  # again, from the cached diagram
        assert sorted(g) == sorted(m.persistence(min_persistence=mp))


def test_cofaces_equal_gudhi():
    for a in fields():
        g = gudhi.CubicalComplex(top_dimensional_cells=a)
        g.compute_persistence(homology_coeff_field=2)
        m = morsegs.CubicalComplex(top_dimensional_cells=a)
        m.compute_persistence()
        (gr, ge), (mr, me) = g.cofaces_of_persistence_pairs(), m.cofaces_of_persistence_pairs()
        assert len(gr) == len(mr) and len(ge) == len(me), (len(gr), len(mr), len(ge), len(me))
        for x, y in zip(gr, mr):
            assert y.dtype == np.int64 and y.shape == x.shape, (x.shape, y.shape)
            assert sorted(map(tuple, x)) == sorted(map(tuple, y))
        for x, y in zip(ge, me):
            assert y.shape == x.shape and sorted(x) == sorted(y)
        # the indices are GUDHI's: Fortran-order flat indices into the input
        flat = a.ravel(order="F")
        for h, pairs in enumerate(mr):
            iv = m.persistence_intervals_in_dimension(h)
            got = sorted(zip(flat[pairs[:, 0]], flat[pairs[:, 1]]))
            assert got == sorted(map(tuple, iv[np.isfinite(iv[:, 1])]))


def test_flat_fortran_form():
    a = random_field(np.random.default_rng(3), (6, 5, 4))
    flat = list(a.ravel(order="F"))
    g = gudhi.CubicalComplex(dimensions=[6, 5, 4], top_dimensional_cells=flat).persistence(homology_coeff_field=2)
    m = morsegs.CubicalComplex(dimensions=[6, 5, 4], top_dimensional_cells=flat)
    assert sorted(g) == sorted(m.persistence())
    assert sorted(morsegs.CubicalComplex(top_dimensional_cells=a).persistence()) == sorted(m.persistence())
    # the C-order array given flat in C order is a different field (transposed): documented
    assert m.persistence_locations().shape[1] == 9


def test_other_dtypes_match_gudhi():
    rng = np.random.default_rng(11)
    cases = [rng.random((10, 9, 8)).astype(np.float32),           # reported exactly in float32
             rng.integers(0, 6, size=(9, 9, 9)),                   # many ties
             rng.integers(-3, 3, size=(13, 11)).astype(np.int8),
             rng.random((7, 8)) > 0.5,                              # bool
             random_field(rng, (6, 6, 6)).tolist()]                        # nested lists
    for a in cases:
        g = gudhi.CubicalComplex(top_dimensional_cells=np.asarray(a, dtype=np.float64))
        gp = [p for p in g.persistence(homology_coeff_field=2) if p[1][1] > p[1][0]]
        mp = morsegs.CubicalComplex(top_dimensional_cells=a).persistence()
        assert sorted(gp) == sorted(mp), np.asarray(a).dtype
    # non-contiguous and Fortran-ordered views are read by index, not by memory order
    b = random_field(rng, (12, 10, 14))
    for view in (b[::2, :, 1::3], np.asfortranarray(b), b.transpose(2, 0, 1)):
        g = gudhi.CubicalComplex(top_dimensional_cells=view).persistence(homology_coeff_field=2)
        assert sorted(g) == sorted(morsegs.CubicalComplex(top_dimensional_cells=view).persistence())


def test_locations_point_at_the_values():
    rng = np.random.default_rng(5)
    for shape in [(12, 11, 10), (20, 17), (30,)]:
        a = random_field(rng, shape)
        for kw in ("top_dimensional_cells", "vertices"):
            m = morsegs.CubicalComplex(**{kw: a})
            loc = m.persistence_locations()
            pers = m.persistence()
            assert loc.shape == (len(pers), 9) and loc.dtype == np.float64
            a3 = a.reshape(a.shape + (1,) * (3 - a.ndim))
            for row, (d, (b, e)) in zip(loc, pers):
                assert row[0] == d and row[1] == b and row[2] == e
                x1, y1, z1, x2, y2, z2 = row[3:].astype(int)
                assert a3[x1, y1, z1] == b
                if np.isfinite(e):
                    assert a3[x2, y2, z2] == e
                else:
                    assert (x2, y2, z2) == (-1, -1, -1)
            if a.ndim < 3:
                assert (loc[:, 3 + a.ndim:6] == 0).all()
            if kw == "top_dimensional_cells":  # the values at the voxels are GUDHI's pairs
                g = gudhi.CubicalComplex(top_dimensional_cells=a).persistence(homology_coeff_field=2)
                v = loc[:, 3:9].astype(int)
                ess = np.isinf(loc[:, 2])
                at = np.where(ess, np.inf, a3[v[:, 3], v[:, 4], v[:, 5]])
                assert sorted(g) == sorted(zip(loc[:, 0].astype(int), zip(a3[v[:, 0], v[:, 1], v[:, 2]], at)))


def test_gil_released():
    """Another Python thread runs while the engine computes."""
    a = np.random.default_rng(1).random((48, 48, 48))
    m = morsegs.CubicalComplex(top_dimensional_cells=a)
    done = threading.Event()

    def work():
        m.compute_persistence()
        done.set()

    t = threading.Thread(target=work)
    ticks = 0
    t0 = time.perf_counter()
    t.start()
    while not done.is_set():
        time.sleep(0.001)
        ticks += 1
    t.join()
    dt = time.perf_counter() - t0
    print("  %d ticks of the main thread during %.2f s of computation" % (ticks, dt))
    assert ticks >= min(10, dt / 0.01), ticks


def test_2d_persistence_shape():
    a = np.random.default_rng(9).random((15, 15))
    m = morsegs.CubicalComplex(vertices=a)
    assert m.dimension() == 2 and len(m.betti_numbers()) == 3
    assert m.persistence_intervals_in_dimension(2).shape == (0, 2)
    assert m.persistence_intervals_in_dimension(7).shape == (0, 2)


def test_sklearn_transformer():
    """morsegs.sklearn.CubicalPersistence == GUDHI's diagrams, serial and threaded."""
    from morsegs.sklearn import CubicalPersistence
    rng = np.random.default_rng(12)
    X = [random_field(rng, (10, 11)) for _ in range(6)]
    for jobs in (None, 2):
        out = CubicalPersistence(homology_dimensions=[0, 1], n_jobs=jobs).fit_transform(X)
        one = CubicalPersistence(homology_dimensions=1, n_jobs=jobs).fit_transform(X)
        for x, (d0, d1), e1 in zip(X, out, one):
            g = gudhi.CubicalComplex(top_dimensional_cells=x)
            g.compute_persistence(homology_coeff_field=2)
            assert sorted(map(tuple, d0)) == sorted(map(tuple, g.persistence_intervals_in_dimension(0)))
            assert sorted(map(tuple, d1)) == sorted(map(tuple, g.persistence_intervals_in_dimension(1)))
            assert np.array_equal(d1, e1)
    flat = CubicalPersistence(homology_dimensions=0, newshape=(10, 11)).fit_transform([x.ravel() for x in X])
    assert all(np.array_equal(a, b[0]) for a, b in zip(flat, out))
    assert CubicalPersistence(0).set_params(min_persistence=0.5).get_params()["min_persistence"] == 0.5
    pyt.raises(ValueError, CubicalPersistence(0, input_type="cubes").fit, X)


if __name__ == "__main__":
    pyt.run(globals())
