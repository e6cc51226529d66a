"""orbit.SphericalHarmonics (orbit/gravity_field.py, orbit/_gravity_field_kernels.py).

Truth:
- heyoka's EGM2008 (an independent implementation: its own expression system and recursion)
  at 1 000 random points from 200 km to GEO and at both poles, to degree and order 70 and 20,
  kept as test data (tools/heyoka_egm2008_reference.py); and heyoka itself when installed;
- the published EGM2008 coefficients (NGA's EGM2008_to2190_TideFree file);
- closed forms: the point mass, and the J2 field of an oblate Earth;
- the potential's gradient by central differences against the acceleration.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from astropy import units as u

from orbit import OrbitTypeError, OrbitValueError, SphericalHarmonics

DATA = Path(__file__).resolve().parent / "data" / "heyoka_egm2008.npz"


@pytest.fixture(scope="module")
def ref():
    with np.load(DATA) as d:
        return {k: d[k] for k in d.files}


@pytest.mark.parametrize("degree", [70, 20])
def test_against_heyoka_egm2008(ref, degree):
    field = SphericalHarmonics(degree)
    pos = ref["position"]
    g = field.acceleration(pos)
    g_ref = ref[f"acceleration_{degree}"]
    rel = np.linalg.norm(g - g_ref, axis=1) / np.linalg.norm(g_ref, axis=1)
    assert rel.max() < 1e-12
    U = field.potential(pos)
    assert np.max(np.abs(-U - ref[f"potential_{degree}"]) / ref[f"potential_{degree}"]) < 1e-12
    # the sample reaches from 200 km to GEO and holds both poles (Pines: no singularity there)
    r = np.linalg.norm(pos, axis=1)
    assert r.min() < field.radius + 250e3 and r.max() > 4.1e7
    assert np.allclose(pos[0, :2], 0.0) and np.allclose(pos[1, :2], 0.0)


def test_against_heyoka_directly():
    hy = pytest.importorskip("heyoka")
    x, y, z = hy.make_vars("x", "y", "z")
    f = hy.cfunc(hy.model.egm2008_acc([x, y, z], 30, 30), [x, y, z])
    pos = np.random.default_rng(7).normal(size=(50, 3))
    pos *= (7.0e6 / np.linalg.norm(pos, axis=1))[:, None]
    g_ref = f(pos.T.copy()).T
    g = SphericalHarmonics(30).acceleration(pos)
    assert np.max(np.linalg.norm(g - g_ref, axis=1) / np.linalg.norm(g_ref, axis=1)) < 1e-12


def test_published_coefficients():
    f = SphericalHarmonics(150)
    # EGM2008_to2190_TideFree (NGA), as published
    assert f.C[2, 0] == -0.484165143790815e-03
    assert f.C[2, 2] == 0.243938357328313e-05
    assert f.S[2, 2] == -0.140027370385934e-05
    assert f.C[3, 0] == 0.957161207093473e-06
    assert f.C[0, 0] == 1.0 and f.C[1, 0] == f.C[1, 1] == f.S[1, 1] == 0.0
    assert f.mu == 3.986004415e14 and f.radius == 6378136.3
    assert f.C.shape == (151, 151) and np.count_nonzero(f.C[150]) > 100


def test_point_mass_and_j2_closed_forms():
    rng = np.random.default_rng(3)
    pos = rng.normal(size=(200, 3))
    pos *= (rng.uniform(6.6e6, 4.3e7, 200) / np.linalg.norm(pos, axis=1))[:, None]
    f0 = SphericalHarmonics(0)
    r = np.linalg.norm(pos, axis=1)
    point = -f0.mu * pos / r[:, None] ** 3
    # a few roundings apart (Pines' path: direction cosines, then the sums): 4 ulps
    assert np.max(np.linalg.norm(f0.acceleration(pos) - point, axis=1) / (f0.mu / r**2)) < 9e-16
    assert np.max(np.abs(f0.potential(pos) / (-f0.mu / r) - 1)) < 9e-16

    f2 = SphericalHarmonics(2, 0)  # J2 alone: J2 = −√5 C̄20
    J2 = f2.j2
    assert J2 == pytest.approx(1.0826261738522e-3, rel=1e-13)  # EGM2008's, as published
    assert f0.j2 == SphericalHarmonics(1).j2 == 0.0  # no oblateness below degree 2
    x, y, z = pos.T
    k = 1.5 * J2 * f2.mu * f2.radius**2 / r**5
    zr = 5 * z**2 / r**2
    j2 = np.stack([x * (zr - 1), y * (zr - 1), z * (zr - 3)], axis=1) * k[:, None]
    g = f2.acceleration(pos)
    assert np.max(np.linalg.norm(g - (point + j2), axis=1) / np.linalg.norm(j2, axis=1)) < 1e-9
    U2 = -f2.mu / r * (1 - J2 * (f2.radius / r) ** 2 * (1.5 * z**2 / r**2 - 0.5))
    assert np.max(np.abs(f2.potential(pos) / U2 - 1)) < 1e-14


def test_gradient_of_potential_is_minus_acceleration():
    f = SphericalHarmonics(40)
    rng = np.random.default_rng(11)
    pos = rng.normal(size=(40, 3))
    pos *= (rng.uniform(6.7e6, 1e7, 40) / np.linalg.norm(pos, axis=1))[:, None]
    h = 2.0  # m: truncation ~h² U''' and round-off ~ε U / h, both ≪ 1e-7 of g
    grad = np.stack(
        [(f.potential(pos + h * e) - f.potential(pos - h * e)) / (2 * h) for e in np.eye(3)],
        axis=1,
    )
    g = f.acceleration(pos)
    assert np.max(np.linalg.norm(grad + g, axis=1) / np.linalg.norm(g, axis=1)) < 1e-7


def test_order_and_shapes_and_units():
    f = SphericalHarmonics(10, 3)
    assert np.all(f.C[:, 4:] == 0) and np.all(f.S[:, 4:] == 0) and f.C[10, 3] != 0
    pos = np.array([[7e6, 1e5, 2e6], [1e6, -7e6, 3e5]])
    g = f.acceleration(pos)
    assert g.shape == (2, 3) and f.potential(pos).shape == (2,)
    assert f.acceleration(pos[0]).shape == (3,) and f.potential(pos[0]).shape == ()
    assert np.array_equal(f.acceleration((pos / 1e3) * u.km), g)
    assert np.array_equal(f.acceleration(pos.reshape(2, 1, 3)), g.reshape(2, 1, 3))
    with pytest.raises(ValueError):  # read-only coefficients
        f.C[2, 0] = 0.0


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((151,), {}, "degree: 0 to 150"),
        ((-1,), {}, "degree: 0 to 150"),
        ((2.5,), {}, "degree: a whole number"),
        ((True,), {}, "degree: a whole number"),
        ((10, 11), {}, "order: 0 to the degree 10"),
        ((10,), {"model": "EGM96"}, "model: the shipped model is 'EGM2008'"),
    ],
)
def test_bad_construction(args, kwargs, match):
    with pytest.raises(OrbitValueError, match=match):
        SphericalHarmonics(*args, **kwargs)


@pytest.mark.parametrize(
    ("r", "match"),
    [
        (np.array([6.3e6, 0.0, 0.0]), "inside the Earth"),
        (np.array([7e6, 0.0]), r"shape \(..., 3\)"),
        (np.array([np.nan, 0.0, 7e6]), "must be finite"),
        (np.array([7e6, 0.0, 0.0]) * u.s, "cannot be converted to m"),
    ],
)
def test_bad_positions(r, match):
    with pytest.raises((OrbitValueError, OrbitTypeError), match=f"r_itrs: .*{match}"):
        SphericalHarmonics(4).acceleration(r)
