"""morsegs.bottleneck_distance / wasserstein_distance against GUDHI's (gudhi.bottleneck_distance
with e=0, gudhi.wasserstein.wasserstein_distance over POT), on random diagrams and on the
diagrams of two fields; essential points; write_persistence_diagram read back."""
import json
import math
import os

import gudhi
import numpy as np
from gudhi.wasserstein import wasserstein_distance as gudhi_wasserstein

import morsegs
import pyt


def random_diagram(rng, n):
    b = rng.random(n)
    return np.stack([b, b + rng.random(n) * 0.5], axis=1)


def test_random_diagrams():
    rng = np.random.default_rng(3)
    for n, m in [(0, 5), (1, 1), (7, 12), (30, 25), (60, 80)]:
        a, b = random_diagram(rng, n), random_diagram(rng, m)
        assert math.isclose(morsegs.bottleneck_distance(a, b), gudhi.bottleneck_distance(a, b, 0.0), rel_tol=1e-12,
                            abs_tol=1e-14)
        for order, q in [(1.0, np.inf), (2.0, np.inf), (1.0, 2.0), (3.0, 1.0)]:
            w, g = morsegs.wasserstein_distance(a, b, order=order, internal_p=q), \
                gudhi_wasserstein(a, b, order=order, internal_p=q)
            assert math.isclose(w, g, rel_tol=1e-9, abs_tol=1e-12), (n, m, order, q, w, g)


def test_essential_points():
    a = np.array([[0.0, 1.0], [0.2, np.inf]])
    b = np.array([[0.1, 0.9], [0.5, np.inf]])
    c = np.array([[0.1, 0.9]])
    assert math.isclose(morsegs.bottleneck_distance(a, b), 0.3)
    assert morsegs.bottleneck_distance(a, c) == np.inf
    assert math.isclose(morsegs.wasserstein_distance(a, b), gudhi_wasserstein(a, b))
    assert morsegs.wasserstein_distance(a, c) == np.inf == gudhi_wasserstein(a, c)
    assert math.isclose(morsegs.wasserstein_distance(a, c, keep_essential_parts=False),
                        gudhi_wasserstein(a, c, keep_essential_parts=False))


def test_field_diagrams():
    rng = np.random.default_rng(5)
    f = rng.random((14, 14, 14))
    g = f + 0.05 * rng.standard_normal(f.shape)
    cf, cg = morsegs.CubicalComplex(top_dimensional_cells=f), morsegs.CubicalComplex(top_dimensional_cells=g)
    gf, gg = gudhi.CubicalComplex(top_dimensional_cells=f), gudhi.CubicalComplex(top_dimensional_cells=g)
    gf.compute_persistence(homology_coeff_field=2)
    gg.compute_persistence(homology_coeff_field=2)
    for d in range(3):
        a, b = cf.persistence_intervals_in_dimension(d), cg.persistence_intervals_in_dimension(d)
        ref = gudhi.bottleneck_distance(gf.persistence_intervals_in_dimension(d),
                                        gg.persistence_intervals_in_dimension(d), 0.0)
        got = morsegs.bottleneck_distance(a, b)
        assert math.isclose(got, ref, rel_tol=1e-6, abs_tol=1e-7), (d, got, ref)  # float32 vs float64 pairs
        # stability: bottleneck <= sup |f - g|
        assert got <= np.abs(f - g).max() + 1e-6


def test_write_persistence_diagram():
    d = pyt.tmpdir("distances")
    f = np.random.default_rng(6).random((9, 8, 7))
    c = morsegs.CubicalComplex(vertices=f)
    pers = c.persistence(min_persistence=0.1)
    txt, js = os.path.join(d, "d.txt"), os.path.join(d, "d.json")
    c.write_persistence_diagram(txt)
    c.write_persistence_diagram(js)
    rows = []
    for line in open(txt):
        if line.strip() and not line.startswith("#"):
            k, b, e = line.split()
            rows.append((int(k), (float(b), float(e))))
    assert sorted(rows) == sorted(pers)
    doc = json.load(open(js))
    assert doc["meta"]["construction"] == "V" and doc["meta"]["shape"] == [9, 8, 7]
    assert len(doc["pairs"]) == len(pers)
    loc = c.persistence_locations()
    got = sorted((p["dim"], p["birth"], tuple(p["birth_cell"]["voxel"])) for p in doc["pairs"])
    assert got == sorted((int(r[0]), r[1], tuple(int(x) for x in r[3:6])) for r in loc)


if __name__ == "__main__":
    pyt.run(globals())
