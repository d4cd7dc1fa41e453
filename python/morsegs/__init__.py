"""morsegs: persistent homology of scalar fields on cubical complexes, with GUDHI's names.

    import numpy as np, morsegs
    f = np.random.default_rng(0).random((64, 64, 64))
    cc = morsegs.CubicalComplex(top_dimensional_cells=f)     # T: voxels are cubes (GUDHI's)
    cc.persistence()                    # [(dim, (birth, death)), ...], GUDHI's order, inf essential
    cc.persistence_locations()          # (n, 9): dim, birth, death, x1, y1, z1, x2, y2, z2
    morsegs.CubicalComplex(vertices=f)  # V: voxels are vertices (lower star; PHAT / CubicalRipser V)
    morsegs.CubicalComplex.from_vdb("scene.vdb")   # a sparse narrow band, as `morsegs persistence`

Conventions (docs/python.md has the full manual):
  - Arrays are indexed a[x, y, z] in C order (the voxel at index (x, y, z) is a[x, y, z]);
    1-, 2- and 3-dimensional arrays are accepted. GUDHI's flat form (`dimensions=[n0, n1, n2]`
    with a flat list in Fortran order, first index fastest) is accepted too and means the
    array a = flat.reshape(dimensions, order="F").
  - Homology over Z/2 (homology_coeff_field=2; other fields raise ValueError), dimensions 0-2.
  - The engine filters in float32: values are rounded to float32 to order the cells, and each
    reported birth/death is read back from the input at the voxel that sets it (so float64
    input gives float64 values, exactly GUDHI's when no two values collide after rounding).
  - Only pairs of positive persistence are computed: min_persistence must be >= 0.
"""
import json
import math
import os
import tempfile
import warnings

import numpy as np

from . import _morsegs

__all__ = ["CubicalComplex", "bottleneck_distance", "wasserstein_distance", "set_num_threads",
           "get_num_threads"]
__version__ = "0.1.0"

_V, _T = 0, 1
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def set_num_threads(n):
    """Worker threads of the library (TBB) for the whole process; 0 = all cores."""
    _morsegs.set_num_threads(int(n))


def get_num_threads():
    return _morsegs.get_num_threads()


def _as_field(x, dimensions, what):
    """User input -> (array in the user's index order, values to report from, float32 3D copy)."""
    try:
        a = np.asarray(x)
    except (ValueError, TypeError) as e:  # ragged nested lists and the like
        raise ValueError("%s: not convertible to a numeric array (%s)" % (what, e)) from None
    if a.dtype.kind not in "biuf":
        raise TypeError("%s: dtype %s is not a real number type (bool, int, uint or float expected)"
                        % (what, a.dtype))
    if dimensions is not None:
        try:
            dims = tuple(int(d) for d in dimensions)
        except TypeError:
            raise TypeError("%s: dimensions must be a sequence of integers" % what) from None
        if a.ndim != 1:
            raise ValueError("%s: with dimensions=, give a flat sequence (got shape %s)" % (what, a.shape))
        if any(d < 0 for d in dims) or int(np.prod(dims, dtype=np.int64)) != a.size:
            raise ValueError("%s: dimensions %s do not hold the %d values given" % (what, list(dims), a.size))
        a = a.reshape(dims, order="F")  # GUDHI's flat form: first index fastest
    if a.ndim == 0 or a.ndim > 3:
        raise ValueError("%s: a %d-dimensional array (shape %s); the engine handles 1, 2 and 3 dimensions"
                         % (what, a.ndim, a.shape))
    if a.size == 0:
        raise ValueError("%s: empty array (shape %s)" % (what, a.shape))
    # Types float32 holds exactly report from the float32 copy; others from a float64 copy.
    exact32 = a.dtype.kind == "b" or (a.dtype.kind == "f" and a.dtype.itemsize <= 4) or \
        (a.dtype.kind in "iu" and a.dtype.itemsize <= 2)
    wide = None if exact32 else np.array(a, dtype=np.float64, order="C", copy=True)
    check = wide if wide is not None else a
    if check.dtype.kind == "f":
        finite = np.isfinite(check)
        if not finite.all():
            idx = tuple(int(i) for i in np.argwhere(~finite)[0])
            raise ValueError("%s: non-finite value %r at index %s (NaN and inf are not filtration values here)"
                             % (what, float(check[idx]), idx))
        if wide is not None and np.abs(wide).max() > _FLOAT32_MAX:
            raise ValueError("%s: values beyond the float32 range (max |value| %g); the engine filters in float32"
                             % (what, float(np.abs(wide).max())))
    shape3 = a.shape + (1,) * (3 - a.ndim)
    f32 = np.ascontiguousarray(a, dtype=np.float32).reshape(shape3)
    report = (wide if wide is not None else f32).reshape(shape3)
    return a.shape, report, f32


def _check_field(homology_coeff_field, min_persistence):
    if isinstance(homology_coeff_field, bool) or int(homology_coeff_field) != homology_coeff_field or \
            int(homology_coeff_field) != 2:
        raise ValueError("homology_coeff_field=%r: the engine computes over Z/2 only (use 2)" % (homology_coeff_field,))
    m = float(min_persistence)
    if math.isnan(m) or m < 0:
        raise ValueError("min_persistence=%r: must be >= 0 (pairs of zero persistence are not computed)"
                         % (min_persistence,))
    return m


class CubicalComplex:
    """Cubical complex of a 1-3D scalar field (dense numpy array) or of a sparse OpenVDB band.

    CubicalComplex(top_dimensional_cells=a)  T construction: a[x, y, z] is the value of a cube,
        a lower cell takes the minimum of its cofaces (GUDHI's CubicalComplex, CubicalRipser T).
    CubicalComplex(vertices=a)               V construction: a[x, y, z] is the value of a vertex,
        a cell takes the maximum of its vertices (lower star; PHAT on the explicit complex,
        CubicalRipser V, GUDHI >= 3.8's vertices=).
    dimensions=[n0, ...] with a flat sequence: GUDHI's Fortran-order flat form.
    CubicalComplex.from_vdb(path, grid=None, ...) / from_grid(pyopenvdb grid): sparse bands.
    Persistence is computed over Z/2, sublevel filtration (superlevel for fog grids).
    """

    def __init__(self, *, top_dimensional_cells=None, vertices=None, dimensions=None, perseus_file=None):
        if perseus_file:
            raise ValueError("perseus_file is not supported: load the file into a numpy array")
        if (top_dimensional_cells is None) == (vertices is None):
            raise ValueError("give exactly one of top_dimensional_cells= or vertices=")
        if top_dimensional_cells is not None:
            self._construction, what, x = _T, "top_dimensional_cells", top_dimensional_cells
        else:
            self._construction, what, x = _V, "vertices", vertices
        self._shape, self._report, self._f32 = _as_field(x, dimensions, what)
        self._grid = None
        self._raw = None
        self._pairs = None
        self._min_persistence = None

    # ------------------------------------------------------------ sparse input
    @classmethod
    def from_vdb(cls, path, grid=None, *, construction="V", band=None, filtration=None, check=True):
        """The narrow band of a .vdb grid, exactly as `morsegs persistence PATH` reads it.

        grid: name of the float grid (default: the first level set, else the first float grid).
        construction: "V" (default) or "T". band: clamp to [-band, band] voxels (default: the
        grid's background). filtration: None (sublevel for level sets, superlevel for fog),
        "sublevel" or "superlevel" (values then stay in density units, birth >= death).
        check: validate a level set's band first (as the CLI does without --no-check).
        Coordinates in persistence_locations() are the grid's index space (i, j, k)."""
        path = os.fspath(path)
        if not os.path.exists(path):
            raise FileNotFoundError("%s: no such file" % path)
        cons = {"V": _V, "T": _T}.get(str(construction).upper())
        if cons is None:
            raise ValueError("construction=%r: must be 'V' or 'T'" % (construction,))
        filt = {None: -1, "sublevel": 0, "superlevel": 1}.get(filtration, None)
        if filt is None:
            raise ValueError("filtration=%r: must be None, 'sublevel' or 'superlevel'" % (filtration,))
        b = float("nan") if band is None else float(band)
        raw = _morsegs.vdb_persistence(path, grid, cons, filt, b, bool(check))
        self = cls.__new__(cls)
        self._construction = cons
        self._shape = None
        self._report = None
        self._f32 = None
        self._grid = raw["grid"]
        self._raw = raw
        self._pairs = None
        self._min_persistence = None
        return self

    @classmethod
    def from_grid(cls, grid, **kwargs):
        """A pyopenvdb FloatGrid (python3-openvdb): written to a temporary .vdb with OpenVDB's
        writer and read back through from_vdb (same checks, same diagram as the CLI)."""
        try:
            import pyopenvdb
        except ImportError:
            raise ImportError("from_grid needs pyopenvdb (Debian: python3-openvdb)") from None
        if not isinstance(grid, pyopenvdb.FloatGrid):
            raise TypeError("from_grid: expected a pyopenvdb.FloatGrid, got %s" % type(grid).__name__)
        fd, tmp = tempfile.mkstemp(suffix=".vdb", prefix="morsegs-")
        os.close(fd)
        try:
            pyopenvdb.write(tmp, grids=[grid])
            return cls.from_vdb(tmp, grid=grid.name or None, **kwargs)
        finally:
            os.unlink(tmp)

    # ------------------------------------------------------------ GUDHI's API
    def dimension(self):
        """Dimension of the complex (of the input array; 3 for a .vdb)."""
        return 3 if self._grid is not None else len(self._shape)

    def num_simplices(self):
        """Number of cells of the complex (for a .vdb: of its bounding box)."""
        if self._grid is not None:
            return int(self._raw["stats"]["cells_total"])
        ext = 1 if self._construction == _T else -1
        return int(np.prod([2 * n + ext for n in self._shape], dtype=np.int64))

    def compute_persistence(self, homology_coeff_field=2, min_persistence=0):
        """Computes the diagram (once; later calls only change the min_persistence filter):
        every pair with death - birth > min_persistence, plus the essential classes."""
        m = _check_field(homology_coeff_field, min_persistence)
        if self._raw is None:
            self._raw = _morsegs.dense_persistence(self._f32, self._construction)
        raw = self._raw
        dim = raw["dim"]
        bd = raw["birth_death"].copy()
        vox = raw["voxels"]
        if self._report is not None:  # values in the input's precision, read at the voxels
            bd[:, 0] = self._report[vox[:, 0], vox[:, 1], vox[:, 2]]
            fin = np.isfinite(bd[:, 1])
            bd[fin, 1] = self._report[vox[fin, 3], vox[fin, 4], vox[fin, 5]]
        pers = np.abs(bd[:, 1] - bd[:, 0])
        keep = np.nonzero(pers > m)[0]
        # GUDHI's order: dimension descending, then persistence descending (essential first).
        order = keep[np.lexsort((bd[keep, 0], -pers[keep], -dim[keep]))]
        self._pairs = {"dim": dim[order], "birth_death": bd[order], "voxels": vox[order],
                       "positions": raw["positions"][order], "truncated": raw["truncated"][order].astype(bool)}
        self._min_persistence = m

    def persistence(self, homology_coeff_field=2, min_persistence=0):
        """[(dim, (birth, death))], dimension descending then persistence descending;
        death = inf for essential classes."""
        self.compute_persistence(homology_coeff_field, min_persistence)
        p = self._pairs
        return [(int(d), (float(b), float(e))) for d, (b, e) in zip(p["dim"], p["birth_death"])]

    def _computed(self):
        if self._pairs is None:  # GUDHI asserts here; computing with the defaults is kinder
            self.compute_persistence()
        return self._pairs

    def persistence_intervals_in_dimension(self, dimension):
        """(n, 2) float64 array of the (birth, death) of dimension `dimension`; (0, 2) if none."""
        p = self._computed()
        return np.array(p["birth_death"][p["dim"] == int(dimension)], dtype=np.float64).reshape(-1, 2)

    def betti_numbers(self):
        """[b0, ..., b_dim]: essential classes per dimension (1, 0, 0, ... for a box)."""
        p = self._computed()
        ess = np.isinf(p["birth_death"][:, 1])
        return [int(np.count_nonzero(ess & (p["dim"] == k))) for k in range(self.dimension() + 1)]

    def persistent_betti_numbers(self, from_value, to_value):
        """Per dimension, the classes with birth <= from_value and death > to_value."""
        p = self._computed()
        b, e = p["birth_death"][:, 0], p["birth_death"][:, 1]
        ok = (b <= float(from_value)) & (e > float(to_value))
        return [int(np.count_nonzero(ok & (p["dim"] == k))) for k in range(self.dimension() + 1)]

    def _flat_pairs(self, construction, name):
        if self._grid is not None:
            raise ValueError("%s: a .vdb band has no flat index; use persistence_locations()" % name)
        if self._construction != construction:
            raise ValueError("%s() only makes sense for a complex built from %s" %
                             (name, "top_dimensional_cells" if construction == _T else "vertices"))
        p = self._computed()
        nd = len(self._shape)
        vox = p["voxels"]
        ess = np.isinf(p["birth_death"][:, 1])
        birth = np.ravel_multi_index(tuple(vox[:, k] for k in range(nd)), self._shape, order="F")
        death = np.full(len(vox), -1, dtype=np.int64)
        death[~ess] = np.ravel_multi_index(tuple(vox[~ess, 3 + k] for k in range(nd)), self._shape, order="F")
        regular, essential = [], []
        dims = p["dim"]
        for h in range(int(dims[~ess].max()) + 1 if (~ess).any() else 0):
            sel = (~ess) & (dims == h)
            regular.append(np.stack([birth[sel], death[sel]], axis=1).astype(np.int64).reshape(-1, 2))
        for h in range(int(dims[ess].max()) + 1 if ess.any() else 0):
            essential.append(birth[ess & (dims == h)].astype(np.int64))
        return [regular, essential]

    def cofaces_of_persistence_pairs(self):
        """GUDHI's layout: [regular, essential]; regular[h] is an (n, 2) int64 array of
        (birth cube, death cube), essential[h] an (n,) array of birth cubes, for h up to the
        largest dimension present. Indices into the input flattened in Fortran order (GUDHI's):
        np.unravel_index(i, a.shape, order="F") gives the cube. T construction only."""
        return self._flat_pairs(_T, "cofaces_of_persistence_pairs")

    def vertices_of_persistence_pairs(self):
        """As cofaces_of_persistence_pairs, for the V construction: the vertex (the maximal
        one of each critical cell) whose value is the birth / death."""
        return self._flat_pairs(_V, "vertices_of_persistence_pairs")

    def persistence_locations(self, world=False):
        """(n, 9) float64 rows dim, birth, death, x1, y1, z1, x2, y2, z2 (CubicalRipser's layout),
        in persistence()'s order: (x1, y1, z1) is the voxel whose value is the birth, (x2, y2, z2)
        the one whose value is the death (-1 for essential classes). Dense input: array indices
        (z = 0 for 2D, y = z = 0 for 1D). .vdb: index space; world=True gives world coordinates
        (translation + voxel_size * index; NaN for the missing death of essential classes)."""
        p = self._computed()
        n = len(p["dim"])
        out = np.empty((n, 9), dtype=np.float64)
        out[:, 0] = p["dim"]
        out[:, 1:3] = p["birth_death"]
        out[:, 3:9] = p["voxels"]
        if world:
            if self._grid is not None:
                h, t = self._grid["voxel_size"], np.asarray(self._grid["translation"])
            else:
                h, t = 1.0, np.zeros(3)
            ess = np.isinf(out[:, 2])
            out[:, 3:6] = t + h * out[:, 3:6]
            out[:, 6:9] = t + h * out[:, 6:9]
            out[ess, 6:9] = np.nan
        return out

    def persistence_truncated(self):
        """Bool array aligned with persistence(): True where the band clamp set an end
        (.vdb bands; always False for dense arrays)."""
        return self._computed()["truncated"].copy()

    @property
    def stats(self):
        """The engine's statistics of the last computation (cells, critical cells, seconds...)."""
        if self._raw is None:
            self._computed()
        return dict(self._raw["stats"])

    @property
    def grid_info(self):
        """For from_vdb/from_grid: grid name, class, filtration, voxel size, background, translation."""
        return None if self._grid is None else dict(self._grid)

    def write_persistence_diagram(self, path):
        """Writes the diagram as computed (after min_persistence): GUDHI's text layout
        "dim birth death" per line (inf for essential), or, for a path ending in .json, the
        morsegs JSON with each end's voxel and position (as `morsegs persistence`)."""
        p = self._computed()
        path = os.fspath(path)
        meta = {"tool": "morsegs python", "construction": "T" if self._construction == _T else "V",
                "min_persistence": self._min_persistence}
        if self._grid is not None:
            meta.update({k: self._grid[k] for k in ("grid", "grid_class", "filtration", "voxel_size")})
        else:
            meta["shape"] = list(self._shape)
        _morsegs.write_diagram(path, np.ascontiguousarray(p["dim"], dtype=np.int64),
                               np.ascontiguousarray(p["birth_death"], dtype=np.float64),
                               np.ascontiguousarray(p["voxels"], dtype=np.int64),
                               np.ascontiguousarray(p["positions"], dtype=np.float64),
                               np.ascontiguousarray(p["truncated"], dtype=np.uint8),
                               path.lower().endswith(".json"), json.dumps(meta))

    def __repr__(self):
        if self._grid is not None:
            return "<morsegs.CubicalComplex of grid '%s' (%s, %s)>" % (
                self._grid["grid"], self._grid["grid_class"], "T" if self._construction == _T else "V")
        return "<morsegs.CubicalComplex %s, %s construction>" % (
            "x".join(str(n) for n in self._shape), "T" if self._construction == _T else "V")


# ---------------------------------------------------------------- distances

def _as_diagram(x, what):
    try:
        a = np.asarray(x)
    except (ValueError, TypeError) as e:
        raise ValueError("%s: not convertible to an (n, 2) array (%s)" % (what, e)) from None
    if a.dtype.kind not in "biuf":
        raise TypeError("%s: dtype %s is not a real number type" % (what, a.dtype))
    a = a.astype(np.float64)
    if a.size == 0:
        return np.zeros((0, 2))
    if a.ndim != 2 or a.shape[1] != 2:
        raise ValueError("%s: expected an (n, 2) array of (birth, death) points, got shape %s "
                         "(use persistence_intervals_in_dimension(d))" % (what, a.shape))
    if np.isnan(a).any():
        raise ValueError("%s: NaN in the diagram" % what)
    return np.ascontiguousarray(a)


def bottleneck_distance(diagram_1, diagram_2, e=None):
    """Bottleneck distance between two (n, 2) diagrams (L-inf ground metric), as
    gudhi.bottleneck_distance. Exact: e (GUDHI's allowed error) is accepted and not needed.
    Essential points (an infinite coordinate) are matched among themselves; different
    numbers of them give inf."""
    if e is not None and not float(e) >= 0:
        raise ValueError("e=%r: must be >= 0" % (e,))
    d, _ = _morsegs.diagram_distance(_as_diagram(diagram_1, "diagram_1"), _as_diagram(diagram_2, "diagram_2"))
    return d


def wasserstein_distance(X, Y, matching=False, order=1.0, internal_p=np.inf, keep_essential_parts=True):
    """Order-`order` Wasserstein distance with L_internal_p ground metric between two (n, 2)
    diagrams, as gudhi.wasserstein.wasserstein_distance. Exact (Hungarian) up to 2000 points per
    diagram pair; beyond, the least persistent points go to the diagonal and a RuntimeWarning
    gives the bound on the error. keep_essential_parts=False drops points with an infinite
    coordinate first. matching=True is not supported."""
    if matching:
        raise NotImplementedError("wasserstein_distance: matching=True is not supported")
    a, b = _as_diagram(X, "X"), _as_diagram(Y, "Y")
    if not keep_essential_parts:
        a = np.ascontiguousarray(a[np.isfinite(a).all(axis=1)])
        b = np.ascontiguousarray(b[np.isfinite(b).all(axis=1)])
    d, bound = _morsegs.diagram_distance(a, b, float(order), float(internal_p))
    if bound > 0:
        warnings.warn("wasserstein_distance: approximated (more than %d points in the two diagrams); |error| <= %g" % (2000, bound),
                      RuntimeWarning, stacklevel=2)
    return d
