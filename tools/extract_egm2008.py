"""Write orbit/data/egm2008.npz: EGM2008's fully normalised coefficients to degree 150.

EGM2008 (Pavlis, Holmes, Kenyon & Factor 2012, J. Geophys. Res. 117, B04406; released by the US
National Geospatial-Intelligence Agency for public use), tide-free, as copied into heyoka
(``heyoka.model.get_egm2008_CS``, degree 150; heyoka is MPL-2.0, the coefficients are NGA's).
Run in a scratch environment with heyoka installed, never a dependency:

    python tools/extract_egm2008.py orbit/data/egm2008.npz

Also writes the model's GM and reference radius. tests/test_gravity_field.py checks the file
against published values of the model (C20, C22, S22, C30, ...).
"""

import sys

import heyoka as hy
import numpy as np

cs = np.asarray(hy.model.get_egm2008_CS())
n_max = 1
count = 0
while count < cs.shape[0]:
    n_max += 1
    count += n_max + 1
assert count == cs.shape[0]
C = np.zeros((n_max + 1, n_max + 1))
S = np.zeros((n_max + 1, n_max + 1))
C[0, 0] = 1.0
k = 0
for n in range(2, n_max + 1):
    for m in range(n + 1):
        C[n, m], S[n, m] = cs[k]
        k += 1
np.savez_compressed(
    sys.argv[1],
    C=C,
    S=S,
    mu=np.float64(hy.model.get_egm2008_mu()),
    radius=np.float64(hy.model.get_egm2008_a()),
    source=np.str_(f"EGM2008 tide-free (NGA), degree {n_max}, via heyoka {hy.__version__}"),
)
