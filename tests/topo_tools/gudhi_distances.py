#!/usr/bin/env python3
"""Reference distances by GUDHI for the topo_tools tests.
usage: gudhi_distances.py A.txt B.txt  (lines "birth death", one dimension, no essentials)
prints: bottleneck W1 W2   (Wasserstein with internal_p = inf, GUDHI's default)
Exit 3 when gudhi (or POT for Wasserstein) cannot be imported, so the test can say why."""
import sys
try:
    import numpy as np
    import gudhi
except ImportError as e:
    print("gudhi missing: %s" % e, file=sys.stderr)
    sys.exit(3)

def load(path):
    a = np.loadtxt(path, ndmin=2)
    return a.reshape(-1, 2)

a, b = load(sys.argv[1]), load(sys.argv[2])
bn = gudhi.bottleneck_distance(a, b, 0.0)
try:
    from gudhi.wasserstein import wasserstein_distance
except ImportError as e:
    print("POT missing: %s" % e, file=sys.stderr)
    sys.exit(3)
w1 = wasserstein_distance(a, b, order=1.0, internal_p=np.inf)
w2 = wasserstein_distance(a, b, order=2.0, internal_p=np.inf)
w1e = wasserstein_distance(a, b, order=1.0, internal_p=2.0)
print("%.17g %.17g %.17g %.17g" % (bn, w1, w2, w1e))
