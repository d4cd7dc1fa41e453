"""Bad input to `morsegs` is a Python exception with a message that says what is wrong, never
a crash: dtypes (complex, object, str refused; bool/int/float converted as GUDHI does), rank,
NaN/inf, empty arrays, flat-form dimensions, fields other than Z/2, negative min_persistence,
sizes the engine refuses (its C message carried), files that are missing or not .vdb, the
C extension called directly with the wrong arrays, distances on malformed diagrams."""
import os

import numpy as np

import morsegs
import pyt
from morsegs import _morsegs
from pyt import raises

CC = morsegs.CubicalComplex


def test_dtypes():
    a = np.random.default_rng(0).random((4, 4, 4))
    raises(TypeError, CC, top_dimensional_cells=a.astype(np.complex128), match="complex128")
    raises(TypeError, CC, vertices=a.astype(object), match="object")
    raises(TypeError, CC, top_dimensional_cells=np.array([["a", "b"], ["c", "d"]]))
    raises(TypeError, CC, top_dimensional_cells=np.array(["2020-01-01"], dtype="datetime64[D]"))
    raises(ValueError, CC, top_dimensional_cells=[[1.0, 2.0], [3.0]])  # ragged
    ref = CC(top_dimensional_cells=a).persistence()
    for t in (np.float32, np.float16, np.int32, np.uint8, np.int64, np.longdouble):
        p = CC(top_dimensional_cells=(a * 100).astype(t)).persistence()
        assert p and all(isinstance(b, float) for _, (b, _) in p), t
    assert len(CC(top_dimensional_cells=a.astype(np.float32)).persistence()) == len(ref)
    assert CC(vertices=np.zeros((3, 3), dtype=bool)).persistence() == [(0, (0.0, float("inf")))]


def test_rank_and_empty():
    raises(ValueError, CC, top_dimensional_cells=np.float64(3.0), match="0-dimensional")
    raises(ValueError, CC, top_dimensional_cells=np.zeros((2, 2, 2, 2)), match="1, 2 and 3")
    for empty in ([], np.zeros((0,)), np.zeros((3, 0, 2)), np.zeros((0, 0))):
        raises(ValueError, CC, top_dimensional_cells=empty, match="empty")
    raises(ValueError, CC, vertices=[[]], match="empty")
    raises(ValueError, CC, match="exactly one")
    raises(ValueError, CC, top_dimensional_cells=[1.0], vertices=[1.0], match="exactly one")
    raises(ValueError, CC, perseus_file="x.txt", match="perseus")
    # one voxel is a complex too
    assert CC(top_dimensional_cells=[5.0]).persistence() == [(0, (5.0, float("inf")))]


def test_non_finite():
    a = np.random.default_rng(1).random((5, 6, 7))
    b = a.copy()
    b[1, 2, 3] = np.nan
    raises(ValueError, CC, top_dimensional_cells=b, match="(1, 2, 3)")
    b[1, 2, 3] = np.inf
    raises(ValueError, CC, vertices=b, match="non-finite")
    raises(ValueError, CC, vertices=a.astype(np.float32) * np.float32(np.nan))
    b[1, 2, 3] = 1e300  # finite in float64, not in the engine's float32
    raises(ValueError, CC, vertices=b, match="float32")


def test_flat_form():
    raises(ValueError, CC, dimensions=[2, 3], top_dimensional_cells=[1.0] * 5, match="do not hold")
    raises(ValueError, CC, dimensions=[2, 3], top_dimensional_cells=np.zeros((2, 3)), match="flat")
    raises(ValueError, CC, dimensions=[-2, -3], top_dimensional_cells=[1.0] * 6)
    raises(TypeError, CC, dimensions=5, top_dimensional_cells=[1.0] * 5)
    raises(ValueError, CC, dimensions=[1, 1, 1, 2], top_dimensional_cells=[1.0, 2.0], match="1, 2 and 3")


def test_options():
    c = CC(top_dimensional_cells=np.random.default_rng(2).random((4, 5)))
    raises(ValueError, c.compute_persistence, homology_coeff_field=11, match="Z/2")
    raises(ValueError, c.persistence, homology_coeff_field=3)
    raises(ValueError, c.persistence, min_persistence=-1, match="min_persistence")
    raises(ValueError, c.persistence, min_persistence=float("nan"))
    raises(ValueError, c.vertices_of_persistence_pairs, match="vertices")
    raises(ValueError, CC(vertices=[[1.0, 2.0]]).cofaces_of_persistence_pairs, match="top_dimensional_cells")
    assert c.persistence(homology_coeff_field=2.0)  # 2.0 is 2
    # methods before compute_persistence compute with the defaults (GUDHI asserts instead)
    d = CC(top_dimensional_cells=[[3.0, 1.0], [2.0, 0.5]])
    assert d.betti_numbers() == [1, 0, 0]


def test_engine_limits_carry_the_c_message():
    e = raises(ValueError, CC(vertices=np.zeros((600000, 1, 1), dtype=np.float32)).compute_persistence)
    assert "persistence: bad dense dimensions 600000x1x1" in str(e), e


def test_c_extension_directly():
    good = np.zeros((2, 2, 2), dtype=np.float32)
    raises(TypeError, _morsegs.dense_persistence, good.astype(np.float64), match="float32")
    raises(TypeError, _morsegs.dense_persistence, np.zeros((2, 2), dtype=np.float32))
    raises(TypeError, _morsegs.dense_persistence, np.asfortranarray(np.zeros((2, 3, 4), dtype=np.float32)))
    raises(TypeError, _morsegs.dense_persistence, [1.0, 2.0])
    raises(ValueError, _morsegs.dense_persistence, np.zeros((0, 2, 2), dtype=np.float32))
    raises(ValueError, _morsegs.dense_persistence, good, 7, match="construction")
    bad = good.copy()
    bad[0, 1, 1] = np.nan
    raises(ValueError, _morsegs.dense_persistence, bad, match="non-finite")
    raises(TypeError, _morsegs.diagram_distance, np.zeros((2, 3)), np.zeros((2, 2)))
    raises(ValueError, _morsegs.write_diagram, "/tmp/x.txt", np.zeros(2, np.int64), np.zeros((1, 2)),
           np.zeros((2, 6), np.int64), np.zeros((2, 6)), np.zeros(2, np.uint8), False)


def test_files():
    d = pyt.tmpdir("errors")
    raises(FileNotFoundError, CC.from_vdb, os.path.join(d, "missing.vdb"), match="missing.vdb")
    junk = os.path.join(d, "junk.vdb")
    with open(junk, "wb") as fh:
        fh.write(b"this is not a vdb file" * 10)
    e = raises(Exception, CC.from_vdb, junk)
    assert isinstance(e, (ValueError, OSError)) and "junk.vdb" in str(e), e
    empty = os.path.join(d, "empty.vdb")
    open(empty, "wb").close()
    raises(Exception, CC.from_vdb, empty, match="empty.vdb")
    raises(ValueError, CC.from_vdb, junk, construction="X", match="construction")
    raises(ValueError, CC.from_vdb, junk, filtration="up", match="filtration")
    raises(ValueError, CC.from_vdb, junk, band=-2, match="band")
    c = CC(top_dimensional_cells=[[1.0, 2.0], [0.0, 3.0]])
    raises(OSError, c.write_persistence_diagram, os.path.join(d, "no", "such", "dir", "d.txt"))
    raises(TypeError, CC.from_grid, "not a grid")


def test_distances():
    raises(ValueError, morsegs.bottleneck_distance, np.zeros((3, 3)), np.zeros((2, 2)), match="(n, 2)")
    raises(ValueError, morsegs.bottleneck_distance, [(0.0, float("nan"))], [(0.0, 1.0)], match="NaN")
    raises(TypeError, morsegs.bottleneck_distance, np.zeros((2, 2), complex), np.zeros((2, 2)))
    raises(ValueError, morsegs.bottleneck_distance, [(0, 1)], [(0, 1)], e=-1)
    raises(ValueError, morsegs.wasserstein_distance, [(0, 1)], [(0, 2)], order=0.5, match="order")
    raises(NotImplementedError, morsegs.wasserstein_distance, [(0, 1)], [(0, 2)], matching=True)
    assert morsegs.bottleneck_distance([], []) == 0.0
    assert morsegs.wasserstein_distance(np.zeros((0, 2)), [(0.0, 2.0)]) == 1.0


if __name__ == "__main__":
    pyt.run(globals())
