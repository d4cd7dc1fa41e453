"""morsegs.sklearn.CubicalPersistence: GUDHI's gudhi.sklearn CubicalPersistence transformer
over morsegs. scikit-learn is imported lazily: with it installed the class is a BaseEstimator
and TransformerMixin (pipelines, get_params/set_params, clone); without it, the same class
with fit / transform / fit_transform / get_params / set_params written out."""
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import CubicalComplex

try:  # lazily: only when this submodule is imported
    from sklearn.base import BaseEstimator, TransformerMixin
    _BASES = (BaseEstimator, TransformerMixin)
except ImportError:
    _BASES = (object,)


class CubicalPersistence(*_BASES):
    """Persistence diagrams of a batch of arrays (images, volumes).

    homology_dimensions: an int d (transform returns one (n, 2) array per input) or a list of
    ints (a list of arrays per input). newshape: reshape each input first (e.g. flat images).
    input_type: "top_dimensional_cells" (T, GUDHI's) or "vertices" (V). homology_coeff_field:
    2 only. min_persistence: >= 0. n_jobs: threads (the engine releases the GIL, so threads run
    in parallel; None or 1: serial, -1: one per core)."""

    def __init__(self, homology_dimensions, newshape=None, input_type="top_dimensional_cells",
                 homology_coeff_field=2, min_persistence=0.0, n_jobs=None):
        self.homology_dimensions = homology_dimensions
        self.newshape = newshape
        self.input_type = input_type
        self.homology_coeff_field = homology_coeff_field
        self.min_persistence = min_persistence
        self.n_jobs = n_jobs

    if _BASES == (object,):
        def get_params(self, deep=True):
            return {k: getattr(self, k) for k in ("homology_dimensions", "newshape", "input_type",
                                                  "homology_coeff_field", "min_persistence", "n_jobs")}

        def set_params(self, **params):
            for k, v in params.items():
                if k not in self.get_params():
                    raise ValueError("CubicalPersistence: unknown parameter %r" % k)
                setattr(self, k, v)
            return self

        def fit_transform(self, X, y=None):
            return self.fit(X, y).transform(X)

    def fit(self, X, Y=None):
        """Nothing to learn (sklearn's API)."""
        if self.input_type not in ("top_dimensional_cells", "vertices"):
            raise ValueError("input_type=%r: must be 'top_dimensional_cells' or 'vertices'" % (self.input_type,))
        return self

    def _one(self, x):
        a = np.asarray(x)
        if self.newshape is not None:
            a = a.reshape(self.newshape)
        cc = CubicalComplex(**{self.input_type: a})
        cc.compute_persistence(homology_coeff_field=self.homology_coeff_field, min_persistence=self.min_persistence)
        if isinstance(self.homology_dimensions, (int, np.integer)):
            return cc.persistence_intervals_in_dimension(int(self.homology_dimensions))
        return [cc.persistence_intervals_in_dimension(int(d)) for d in self.homology_dimensions]

    def transform(self, X):
        """One diagram (or list of diagrams, per homology_dimensions) per element of X."""
        self.fit(X)
        jobs = self.n_jobs
        if jobs is None or jobs == 1:
            return [self._one(x) for x in X]
        import os
        workers = (os.cpu_count() or 1) if jobs < 0 else int(jobs)
        with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
            return list(pool.map(self._one, X))
