"""KeplerOrbit.circular, SecularJ2Orbit.circular and SecularJ2Orbit.sun_synchronous (issue 39):
the inclination against the closed form and published values, the node rate against the mean
Sun's, the local time of the node against astropy's Earth-fixed longitude and against the
apparent Sun of orbit.sun (the difference is the equation of time), and the refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u

import orbit
from orbit.errors import OrbitTypeError, OrbitValueError
from orbit.frames import gcrs_to_itrs
from orbit.j2 import EARTH_J2, EARTH_RADIUS
from orbit.sun import sun_position

DAY = 86400.0
MEAN_SUN_RATE = 2 * math.pi / (365.2421897 * DAY)


def test_circular_kepler_elements_and_units():
    o = orbit.KeplerOrbit.circular(500.0, math.radians(51.6), raan=0.3, arg_lat=1.0)
    assert (o.a, o.e, o.inc, o.raan, o.argp) == (
        EARTH_RADIUS + 500.0,
        0.0,
        math.radians(51.6),
        0.3,
        0.0,
    )
    # circular: |r| = a everywhere and the argument of latitude at t0 is arg_lat
    t = np.linspace(0.0, o.period, 7)
    np.testing.assert_allclose(o.radius(t), EARTH_RADIUS + 500.0, rtol=1e-14)
    r = o.position(0.0)
    node = np.array([math.cos(0.3), math.sin(0.3), 0.0])
    assert math.acos(r @ node / np.linalg.norm(r)) == pytest.approx(1.0, abs=1e-12)
    q = orbit.KeplerOrbit.circular(500 * u.km, 51.6 * u.deg, arg_lat=1.0 * u.rad)
    assert (q.a, q.inc) == (o.a, o.inc)
    j = orbit.SecularJ2Orbit.circular(500.0, 0.9, 0.3, 1.0, epoch="2024-01-01")
    assert (j.a, j.e, j.inc, j.raan) == (o.a, 0.0, 0.9, 0.3)
    assert j.M0 == pytest.approx(1.0, abs=1e-15)  # e = 0: M = f = u (ω = 0)


@pytest.mark.parametrize("alt", [0.0, -10.0])
def test_circular_refuses_altitude_at_or_below_surface(alt):
    with pytest.raises(OrbitValueError, match="altitude: must be > 0 km"):
        orbit.KeplerOrbit.circular(alt, 0.5)
    with pytest.raises(OrbitValueError, match="altitude"):
        orbit.SecularJ2Orbit.circular(alt, 0.5)


@pytest.mark.parametrize(
    "alt, inc_deg",  # the familiar values: 500 km 97.4°, 700 km 98.19°, 800 km 98.6°
    [(500.0, 97.40), (700.0, 98.19), (800.0, 98.60)],
)
def test_sun_synchronous_inclination_and_node_rate(alt, inc_deg):
    o = orbit.SecularJ2Orbit.sun_synchronous(alt, "10:30", "2024-03-20T12:00:00")
    assert math.degrees(o.inc) == pytest.approx(inc_deg, abs=0.01)
    # the closed form Ω̇ = −(3/2) √μ J2 R² a^(−7/2) cos i written here, not the package's
    a, mu = EARTH_RADIUS + alt, orbit.earth_mu()
    rate = -1.5 * math.sqrt(mu) * EARTH_J2 * EARTH_RADIUS**2 * a**-3.5 * math.cos(o.inc)
    assert rate == pytest.approx(MEAN_SUN_RATE, rel=1e-13)
    assert o.raan_rate == pytest.approx(MEAN_SUN_RATE, rel=1e-13)
    assert (o.a, o.e) == (a, 0.0)


def _lmt_from_astropy(o):
    """Mean local time UTC + λ/15 at the longitude of the node, from astropy's GCRS → ITRS."""
    n = 7000.0 * np.array([[math.cos(o.raan), math.sin(o.raan), 0.0]])
    x, y, _ = gcrs_to_itrs(o.epoch, n)[0]
    utc_h = (o.epoch.utc.mjd % 1.0) * 24.0
    return (utc_h + math.degrees(math.atan2(y, x)) / 15.0) % 24.0


def _equation_of_time_min(day_of_year, hour):
    """Spencer (1971) equation of time [min], apparent − mean solar time (±0.6 min)."""
    g = 2 * math.pi / 365 * (day_of_year - 1 + (hour - 12) / 24)
    return 229.18 * (
        0.000075
        + 0.001868 * math.cos(g)
        - 0.032077 * math.sin(g)
        - 0.014615 * math.cos(2 * g)
        - 0.040849 * math.sin(2 * g)
    )


@pytest.mark.parametrize(
    "epoch, ltan",
    [
        ("2024-02-11T03:00:00", "10:30"),  # equation of time −14 min
        ("2024-05-14T12:00:00", 22.5),  # +3.7 min; a 10:30 descending-node orbit
        ("2026-07-26T18:30:00", "06:00"),  # −6.5 min; dawn-dusk
        ("2026-11-03T06:00:00", 13.75 * u.hour),  # +16.4 min
    ],
)
def test_local_time_of_node_recovered(epoch, ltan):
    o = orbit.SecularJ2Orbit.sun_synchronous(800.0, ltan, epoch)
    want = orbit._constructors.local_time_hours(ltan)
    assert o.local_time_of_node() == pytest.approx(want, abs=1e-9)
    # independent: the node's Earth-fixed longitude from astropy (UT1 − UTC < 0.9 s)
    assert _lmt_from_astropy(o) == pytest.approx(want, abs=1.0 / 3600.0)
    # the apparent Sun of orbit.sun: true local time = mean local time + equation of time
    s = sun_position(o.epoch, 0.0)
    true_lt = (12.0 + math.degrees(o.raan - math.atan2(s[1], s[0])) / 15.0) % 24.0
    doy = o.epoch.utc.datetime.timetuple().tm_yday
    hour = (o.epoch.utc.mjd % 1.0) * 24.0
    eot = _equation_of_time_min(doy, hour)
    assert (true_lt - want) * 60.0 == pytest.approx(eot, abs=1.0)
    # sun-synchronous: a month later the node is at the same local time (to 3 s a year:
    # the model's pole does not precess, module docstring of orbit._constructors)
    assert o.local_time_of_node(30 * DAY) == pytest.approx(want, abs=0.5 / 3600.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"altitude": 0.0}, "altitude: must be > 0"),
        ({"altitude": 6000.0}, r"altitude: no sun-synchronous .* below 59\d\d km"),
        ({"local_time_of_node": "10h30"}, "local_time_of_node: cannot read '10h30'"),
        ({"local_time_of_node": "24:00"}, "local_time_of_node: '24:00' is not a time of day"),
        ({"local_time_of_node": -1.0}, r"local_time_of_node: -1.0 h is not a time of day"),
        ({"epoch": None}, "epoch: a time is needed"),
        ({"j2": 0.0}, "j2: a sun-synchronous orbit needs"),
    ],
)
def test_sun_synchronous_refusals(kwargs, match):
    args = {"altitude": 800.0, "local_time_of_node": "10:30", "epoch": "2024-01-01"} | kwargs
    with pytest.raises(OrbitValueError, match=match):
        orbit.SecularJ2Orbit.sun_synchronous(**args)


def test_sun_synchronous_highest_altitude_is_polar_retrograde():
    """Just below the limit the orbit exists with i near 180°; the limit is cos i = −1."""
    o = orbit.SecularJ2Orbit.sun_synchronous(5973.0, 6.0, "2024-01-01")
    assert -1.0 < math.cos(o.inc) < -0.999  # 178.4°
    with pytest.raises(OrbitTypeError, match="local_time_of_node"):
        orbit.SecularJ2Orbit.sun_synchronous(800.0, True, "2024-01-01")


def test_local_time_needs_epoch():
    with pytest.raises(OrbitValueError, match="epoch"):
        orbit.SecularJ2Orbit.circular(700.0, 1.7).local_time_of_node()


def test_sun_synchronous_refuses_what_fuzzing_found():
    """Values near the float range overflowed a**3.5 (OverflowError), a negative radius took the
    logarithm of a negative number: each an OrbitValueError naming the parameter."""
    import pytest

    from orbit import SecularJ2Orbit
    from orbit.errors import OrbitValueError

    ep = "2024-03-20T12:00:00"
    with pytest.raises(OrbitValueError, match="altitude: no sun-synchronous"):
        SecularJ2Orbit.sun_synchronous(1e308, "10:30", ep, mu=1e308)
    with pytest.raises(OrbitValueError, match="radius: "):
        SecularJ2Orbit.sun_synchronous(700.0, "10:30", ep, radius=-1.2e21)
    with pytest.raises(OrbitValueError, match="radius: "):
        SecularJ2Orbit.circular(700.0, 1.0, radius=0.0)
