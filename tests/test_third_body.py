"""orbit.ThirdBody (orbit/third_body.py) and its kernel (orbit/_gravity_field_kernels.py).

Truth: the defining difference μ [(s − r)/|s − r|³ − s/|s|³] in 50-digit arithmetic (mpmath);
the tidal (quadrupole) limit for |r| ≪ |s|; the Sun's and the Moon's known distances; the
apparent Sun of orbit.sun (astropy's get_body) within aberration and light time.
"""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u

from orbit import OrbitTypeError, OrbitValueError, ThirdBody
from orbit import _gravity_field_kernels as kg
from orbit.sun import sun_position

EPOCH = "2020-02-22T02:00:00"


def _exact(mu, s, r):
    import mpmath as mp

    mp.mp.dps = 50
    s = [mp.mpf(float(x)) for x in s]
    r = [mp.mpf(float(x)) for x in r]
    d = [a - b for a, b in zip(s, r, strict=True)]
    nd = mp.sqrt(sum(x * x for x in d)) ** 3
    ns = mp.sqrt(sum(x * x for x in s)) ** 3
    return np.array([float(mp.mpf(mu) * (d[i] / nd - s[i] / ns)) for i in range(3)])


@pytest.mark.parametrize(("mu", "dist"), [(1.3271244e20, 1.496e11), (4.902800118e12, 3.84e8)])
def test_battin_form_against_50_digits(mu, dist):
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(200):
        s = rng.normal(size=3)
        s *= dist / np.linalg.norm(s)
        r = rng.normal(size=3)
        r *= rng.uniform(6.6e6, 4.3e7) / np.linalg.norm(r)
        exact = _exact(mu, s, r)
        got = np.array(kg.third_body(mu, *s, *r))
        worst = max(worst, np.linalg.norm(got - exact) / np.linalg.norm(exact))
    assert worst < 1e-14


def test_tidal_limit_and_distances():
    sun, moon = ThirdBody("sun"), ThirdBody("moon")
    t = np.linspace(0.0, 30 * 86400.0, 31)
    ds = np.linalg.norm(sun.position(EPOCH, t), axis=-1)
    dm = np.linalg.norm(moon.position(EPOCH, t), axis=-1)
    assert np.all((1.47e11 < ds) & (ds < 1.53e11))
    assert np.all((3.56e8 < dm) & (dm < 4.07e8)) and dm.max() - dm.min() > 2e7  # a month
    r = np.array([7.0e6, -2.0e6, 1.0e6])
    s = sun.position(EPOCH, 0.0)
    n = s / np.linalg.norm(s)
    tidal = sun.mu / np.linalg.norm(s) ** 3 * (3 * np.dot(n, r) * n - r)
    a = sun.acceleration(r, EPOCH, 0.0)
    assert np.linalg.norm(a - tidal) / np.linalg.norm(tidal) < 2e-4  # (|r|/|s| = 5e-5)


def test_geometric_sun_near_the_apparent_one():
    t = np.array([0.0, 1e6])
    geo = ThirdBody("sun").position(EPOCH, t)
    app = sun_position(EPOCH, t) * 1e3
    cos = np.sum(geo * app, axis=-1) / np.linalg.norm(geo, axis=-1) / np.linalg.norm(app, axis=-1)
    ang = np.arccos(np.clip(cos, -1, 1))
    assert np.all(ang < 1.5e-4) and np.all(ang > 1e-5)  # aberration ~20″ apart, not the same


def test_shapes_broadcast_and_units():
    moon = ThirdBody("moon")
    r = np.array([[7e6, 0, 0], [0, 7e6, 0]])
    a = moon.acceleration(r, EPOCH, np.array([0.0, 600.0]))
    assert a.shape == (2, 3)
    assert np.array_equal(moon.acceleration(r[1], EPOCH, 600.0), a[1])
    assert np.array_equal(moon.acceleration(r / 1e3 * u.km, EPOCH, np.array([0.0, 600.0])), a)
    assert moon.acceleration(r[0], EPOCH, np.zeros(4)).shape == (4, 3)
    assert ThirdBody("Moon", mu=1.0).mu == 1.0


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: ThirdBody("mars"), "body: 'sun' or 'moon'"),
        (lambda: ThirdBody("sun", mu=-1.0), "mu: a positive"),
        (lambda: ThirdBody("sun").acceleration(np.zeros(2), EPOCH, 0.0), r"r_gcrs: .*\(..., 3\)"),
        (lambda: ThirdBody("sun").acceleration([7e6, 0, 0] * u.s, EPOCH, 0.0), "cannot be conv"),
        (
            lambda: ThirdBody("sun").acceleration(np.ones((2, 3)) * 7e6, EPOCH, np.zeros(3)),
            "does not broadcast",
        ),
        (lambda: ThirdBody("moon").position(EPOCH, np.nan), "t: must be finite"),
    ],
)
def test_bad_input(call, match):
    with pytest.raises((OrbitValueError, OrbitTypeError), match=match):
        call()
