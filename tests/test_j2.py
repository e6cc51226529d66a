"""SecularJ2Orbit: rates against the textbook formulas and against sgp4, the sun-synchronous
check, geometry of the drifting ellipse measured from positions, velocity = dr/dt."""

from __future__ import annotations

import math

import numpy as np
import pytest

from orbit import EphemerisOrbit, KeplerOrbit, OrbitValueError, SecularJ2Orbit
from orbit.j2 import EARTH_J2, EARTH_RADIUS

MU = 398600.4418
DAY = 86400.0
SSO_RATE = 2 * math.pi / (365.2422 * DAY)  # one revolution of the node per tropical year


def textbook_rates(a, e, i, mu=MU, j2=EARTH_J2, R=EARTH_RADIUS):
    """Vallado (2013) ch. 9 / Montenbruck & Gill (2000) ch. 3, written in the (R/a) form:
    Ω̇ = −3/2 n J2 (R/a)² cos i /(1−e²)², ω̇ = 3/4 n J2 (R/a)² (4 − 5 sin² i)/(1−e²)²,
    Ṁ = n + 3/4 n J2 (R/a)² (2 − 3 sin² i)/(1−e²)^(3/2)."""
    n = math.sqrt(mu / a**3)
    f = j2 * (R / a) ** 2
    s2 = math.sin(i) ** 2
    return (
        -1.5 * n * f * math.cos(i) / (1 - e * e) ** 2,
        0.75 * n * f * (4 - 5 * s2) / (1 - e * e) ** 2,
        n + 0.75 * n * f * (2 - 3 * s2) / (1 - e * e) ** 1.5,
    )


@pytest.mark.parametrize(
    "a,e,i",
    [(7000.0, 0.001, 1.7), (6878.0, 0.0, 0.9), (26560.0, 0.01, 0.96), (24000.0, 0.7, 1.1)],
)
def test_rates_match_the_textbook(a, e, i):
    o = SecularJ2Orbit(a, e, i, 0.3, 0.4, mu=MU)
    ref = textbook_rates(a, e, i)
    assert o.raan_rate == pytest.approx(ref[0], rel=1e-13)
    assert o.argp_rate == pytest.approx(ref[1], rel=1e-13)
    assert o.mean_motion == pytest.approx(ref[2], rel=1e-13)
    assert o.keplerian_mean_motion == pytest.approx(math.sqrt(MU / a**3), rel=1e-15)


def test_rates_agree_with_sgp4_secular_rates():
    """sgp4 adds J2² and J4 secular terms: ours (J2 only) agree to their size, ~0.3 %."""
    from sgp4.api import Satrec

    l1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
    l2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"
    s = Satrec.twoline2rv(l1, l2)
    o = SecularJ2Orbit(
        s.a * s.radiusearthkm,
        s.ecco,
        s.inclo,
        s.nodeo,
        s.argpo,
        M0=s.mo,
        mu=s.mu,
        j2=s.j2,
        radius=s.radiusearthkm,
    )
    assert o.raan_rate * 60 == pytest.approx(s.nodedot, rel=5e-3)  # rad/min
    assert o.argp_rate * 60 == pytest.approx(s.argpdot, rel=5e-3)
    assert o.mean_motion * 60 == pytest.approx(s.mdot, rel=1e-5)


def node_crossings(o, t_end, dt=30.0):
    """Times and right ascensions of the ascending-node crossings, from positions only."""
    t = np.arange(0.0, t_end, dt)
    z = o.position(t)[:, 2]
    idx = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    out_t, out_ra = [], []
    for k in idx:  # bisection on z(t) = 0
        lo, hi = t[k], t[k + 1]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if o.position(mid)[2] < 0:
                lo = mid
            else:
                hi = mid
        r = o.position(0.5 * (lo + hi))
        out_t.append(0.5 * (lo + hi))
        out_ra.append(math.atan2(r[1], r[0]))
    return np.array(out_t), np.unwrap(np.array(out_ra))


def test_sun_synchronous_nodal_rate():
    """Inclination solved from Ω̇ = 360°/365.2422 d with the textbook formula (here, not in the
    package); the node measured from the positions must then turn at that rate."""
    a, e = 7078.137, 0.001  # 700 km
    n = math.sqrt(MU / a**3)
    cos_i = -SSO_RATE / (1.5 * n * EARTH_J2 * (EARTH_RADIUS / (a * (1 - e * e))) ** 2)
    inc = math.acos(cos_i)
    assert math.degrees(inc) == pytest.approx(98.19, abs=0.01)  # the familiar 700 km SSO value
    o = SecularJ2Orbit(a, e, inc, 1.0, 0.5, mu=MU, epoch="2024-03-20T12:00:00")
    assert o.raan_rate == pytest.approx(SSO_RATE, rel=1e-12)
    tn, ra = node_crossings(o, 5 * DAY)
    slope = np.polyfit(tn, ra, 1)[0]
    assert slope == pytest.approx(SSO_RATE, rel=1e-6)  # 0.9856°/day from the geometry
    assert math.degrees(slope) * DAY == pytest.approx(360 / 365.2422, rel=1e-6)
    # the nodal period between crossings: 2π/(n̄ + ω̇)
    # (e = 0.001: the crossings wobble with the moving periapsis at the 1e-6 level)
    assert np.mean(np.diff(tn)) == pytest.approx(o.nodal_period, rel=1e-5)


def test_velocity_is_the_derivative_of_position():
    o = SecularJ2Orbit(7000.0, 0.05, 1.1, 0.3, 0.2, mu=MU)
    t = np.linspace(0.0, DAY, 37)
    h = 2.0  # truncation ~6e-12 km/s, rounding of M ~ 100 rad: ~1e-10 km/s
    fd = (
        -o.position(t + 2 * h)
        + 8 * o.position(t + h)
        - 8 * o.position(t - h)
        + o.position(t - 2 * h)
    ) / (12 * h)
    np.testing.assert_allclose(o.velocity(t), fd, rtol=0, atol=3e-10)


def test_zero_j2_is_the_kepler_orbit_and_sampling_works():
    kw = dict(mu=MU, epoch="2024-03-20T12:00:00")
    j0 = SecularJ2Orbit(7000.0, 0.2, 0.5, 0.785, 0.26, f0=0.1, j2=0.0, **kw)
    kep = KeplerOrbit(7000.0, 0.2, 0.5, 0.785, 0.26, f0=0.1, **kw)
    t = np.linspace(-3000.0, 60000.0, 501)
    np.testing.assert_allclose(j0.position(t), kep.position(t), rtol=0, atol=1e-9)
    np.testing.assert_allclose(j0.velocity(t), kep.velocity(t), rtol=0, atol=1e-12)
    np.testing.assert_allclose(j0.true_anomaly(t), kep.true_anomaly(t), rtol=0, atol=1e-12)
    j = SecularJ2Orbit(7000.0, 0.01, 1.7, 0.3, 0.2, **kw)
    eph = EphemerisOrbit.from_orbit(j, 0.0, DAY, 60.0)
    tt = np.linspace(0.0, DAY, 3001)
    assert np.max(np.linalg.norm(eph.position(tt) - j.position(tt), axis=-1)) < 1e-9
    # the angles drift linearly
    assert j.raan_at(DAY) == pytest.approx(0.3 + j.raan_rate * DAY, rel=1e-15)
    assert j.argp_at(DAY) == pytest.approx(0.2 + j.argp_rate * DAY, rel=1e-15)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(e=1.5, a=-7000.0), r"^e: SecularJ2Orbit is for closed orbits"),
        (dict(j2=-1e-3), r"^j2: must be a number in \[0, 0.1\]"),
        (dict(radius=0.0), r"^radius: equatorial radius must be > 0"),
        (dict(e=-0.1), r"^e:"),
        (dict(epoch="not a date"), r"^epoch:"),
    ],
)
def test_errors(kw, match):
    args = dict(a=7000.0, e=0.01, inc=1.0, raan=0.0, argp=0.0)
    args.update(kw)
    with pytest.raises(OrbitValueError, match=match):
        SecularJ2Orbit(**args)


def test_energy_semi_major_axis_is_constant_where_the_osculating_one_swings():
    """An orbit in EGM2008's J2 alone (NumericalOrbit, degree 2, order 0): the semi-major axis
    of the energy in the point mass and J2 moves by 0.09 km over two orbits (GCRS z is the
    pole to 0.3°, the rest of the term's ~10 km), where the osculating two-body one swings by
    ~20 km; with J2 = 0 it is the two-body a."""
    import orbit
    from orbit.j2 import energy_semi_major_axis

    field = orbit.SphericalHarmonics(2, 0)
    kep = KeplerOrbit(6878.137, 0.001, 1.7, 0.5, 0.3, epoch="2026-03-20T00:00:00")
    r0, v0 = kep.position(np.array([0.0]))[0], kep.velocity(np.array([0.0]))[0]
    o = orbit.NumericalOrbit(r0, v0, "2026-03-20T00:00:00", gravity=field)
    ds = o.propagate(np.linspace(0.0, 2 * 5700.0, 1141))
    r = ds["position"].values * 1e-3
    v = ds["velocity"].values * 1e-3
    mu, R = field.mu * 1e-9, field.radius * 1e-3
    a = energy_semi_major_axis(r, v, mu, field.j2, R)
    a2 = energy_semi_major_axis(r, v, mu, 0.0)
    rn = np.linalg.norm(r, axis=1)
    np.testing.assert_allclose(a2, 1.0 / (2.0 / rn - np.sum(v * v, axis=1) / mu), rtol=1e-14)
    assert np.ptp(a) < 0.1 and np.ptp(a2) > 15.0
