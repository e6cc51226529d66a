"""Write tests/data/heyoka_egm2008.npz: heyoka's EGM2008 potential and acceleration at 1 000
random points from 200 km above the reference radius to GEO, to degree and order 70 and 20.

heyoka (an independent implementation: its own expression system and recursion) runs in a
scratch environment, never a dependency; tests/test_gravity_field.py compares
``orbit.SphericalHarmonics`` with these values.

    python tools/heyoka_egm2008_reference.py tests/data/heyoka_egm2008.npz
"""

import sys

import heyoka as hy
import numpy as np

rng = np.random.default_rng(20261129)
n_pts = 1000
a = hy.model.get_egm2008_a()
radius = rng.uniform(a + 200e3, 42_164e3, n_pts)
d = rng.normal(size=(n_pts, 3))
d /= np.linalg.norm(d, axis=1)[:, None]
pos = radius[:, None] * d
pos[:4] = [[0, 0, a + 500e3], [0, 0, -(a + 500e3)], [a + 400e3, 0, 0], [0, 1e-3, a + 300e3]]
x, y, z = hy.make_vars("x", "y", "z")
out = {"position": pos, "degrees": np.array([70, 20])}
for n in (70, 20):
    pot = hy.model.egm2008_pot([x, y, z], n, n)
    acc = hy.model.egm2008_acc([x, y, z], n, n)
    f = hy.cfunc([pot, *acc], [x, y, z])
    vals = f(pos.T.copy())  # (4, n_pts)
    out[f"potential_{n}"] = vals[0]
    out[f"acceleration_{n}"] = vals[1:].T.copy()
out["heyoka"] = np.str_(hy.__version__)
np.savez_compressed(sys.argv[1], **out)
