"""orbit.sun: the Sun table against astropy called directly, the conical shadow function against
a quadrature of the visible solar disk and its closed-form limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from orbit import sun

EPOCH = "2024-03-20T12:00:00"


def test_sun_table_matches_astropy():
    tab = sun.SunTable(EPOCH, 0.0, 3 * 86400.0)
    t = np.random.default_rng(1).uniform(0.0, 3 * 86400.0, 200)
    ref = sun.sun_position(EPOCH, t)
    # astropy's own positions scatter by ~1e-5 km (1e-13 relative): that is the floor
    assert np.max(np.abs(tab.position(t) - ref)) < 5e-5
    assert np.all(np.abs(np.linalg.norm(ref, axis=-1) / 1.496e8 - 1) < 0.02)  # ~1 AU
    # velocity: the derivative of the interpolated positions
    h = 30.0
    fd = (tab.position(t + h) - tab.position(t - h)) / (2 * h)
    assert np.max(np.abs(tab.velocity(t) - fd)) < 1e-7  # km/s (|v| ~ 30 km/s)
    with pytest.raises(ValueError, match="outside the Sun table"):
        tab.position([-1e5])


def _visible_fraction(r, s, re=sun.R_EARTH, rs=sun.R_SUN, n=1200):
    """Fraction of the solar disk (seen from r) not hidden by the Earth's disk: quadrature on
    a polar grid of the Sun's apparent disk (small-angle tangent plane)."""
    u = s - r
    du = np.linalg.norm(u)
    a = math.asin(rs / du)
    b = math.asin(re / np.linalg.norm(r))
    c = math.atan2(np.linalg.norm(np.cross(-r, u)), float(-r @ u))
    # disk of radius a centred at 0; Earth disk of radius b centred at distance c
    rho = (np.arange(n) + 0.5) / n * a
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    R, P = np.meshgrid(rho, phi, indexing="ij")
    x, y = R * np.cos(P), R * np.sin(P)
    hidden = (x - c) ** 2 + y**2 < b * b
    w = R  # area element rho drho dphi
    return 1.0 - float(np.sum(w * hidden) / np.sum(w))


def test_shadow_function_limits_and_partial_phase():
    s = np.array([1.496e8, 0.0, 0.0])
    rr = 7000.0
    # full light (day side) and umbra (right behind the Earth)
    assert sun.shadow_function([rr, 0, 0], s) == 1.0
    assert sun.shadow_function([-rr, 0, 0], s) == 0.0
    nu, gp, gu = sun.shadow_function([-rr, 0, 0], s, margins=True)
    assert gp < 0 and gu < 0
    # sweep across the penumbra: compare with a quadrature of the disk
    b = math.asin(sun.R_EARTH / rr)
    for ang in np.linspace(math.pi / 2 - b - 0.006, math.pi / 2 - b + 0.006, 7):
        r = rr * np.array([-math.sin(ang), math.cos(ang), 0.0])
        nu = float(sun.shadow_function(r, s))
        assert nu == pytest.approx(_visible_fraction(r, s), abs=2e-3)
    # annular: far beyond the umbra's apex the Earth's disk lies inside the Sun's
    far = np.array([-2.5e6, 0.0, 0.0])
    a = math.asin(sun.R_SUN / np.linalg.norm(s - far))
    b = math.asin(sun.R_EARTH / 2.5e6)
    assert float(sun.shadow_function(far, s)) == pytest.approx(1 - b * b / (a * a), rel=1e-12)


def test_shadow_boundaries_are_the_tangent_cones():
    """g_penumbra = 0 exactly where the satellite lies on the internal tangent cone of the
    Earth and Sun spheres (Vallado, Fundamentals of Astrodynamics, Sect. 5.3: the penumbra cone
    half-angle sin α_p = (R_sun + R_earth)/d), g_umbra = 0 on the external one
    (sin α_u = (R_sun − R_earth)/d)."""
    d = 1.496e8
    s = np.array([d, 0.0, 0.0])
    for sign, k in ((1.0, 1), (-1.0, 2)):
        al = math.asin((sun.R_SUN + sign * sun.R_EARTH) / d)
        # apex on the Sun–Earth line: behind the Earth for the umbra, between them for the penumbra
        xa = sun.R_EARTH / math.sin(al)  # distance of the apex from the Earth's centre
        for xi in (2000.0, 5000.0, 9000.0):  # distance behind the Earth along the anti-Sun axis
            rho = (xi + xa) * math.tan(al) if sign > 0 else (xa - xi) * math.tan(al)
            r = np.array([-xi, rho, 0.0])
            g = sun.shadow_function(r, s, margins=True)[k]
            assert abs(float(g)) < 1e-11, (sign, xi, float(g))
