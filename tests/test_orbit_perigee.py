"""An Earth orbit whose perigee is inside the Earth warns (issue 16).

Truth: the perigee radius a (1 − e) computed here from the elements, the WGS 84 equatorial
radius 6378.137 km; orbits about another body (another mu) and orbits clear of the Earth do not
warn; the warning is a ``UserWarning`` of :mod:`orbit.errors`.
"""

from __future__ import annotations

import re
import warnings

import pytest
from astropy import units as u

import orbit
from orbit.errors import BeyondHillSphereWarning, OrbitWarning, PerigeeInsideEarthWarning

R_EARTH = 6378.137


def _altitude(w) -> float:
    return float(re.match(r"perigee altitude (-?[0-9.]+) km", str(w.message)).group(1))


@pytest.mark.parametrize(
    ("make", "a", "e"),
    [
        (lambda: orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.1, 0.2), 7000.0, 0.2),  # the paper's
        (lambda: orbit.SecularJ2Orbit(7000.0, 0.2, 0.5, 0.1, 0.2), 7000.0, 0.2),
        (lambda: orbit.KeplerOrbit(7.0e6 * u.m, 0.2, 0.5, 0.1, 0.2), 7000.0, 0.2),
        (lambda: orbit.KeplerOrbit(6000.0, 0.0, 0.5, 0.1, 0.2), 6000.0, 0.0),
        (lambda: orbit.KeplerOrbit(-7000.0, 1.5, 0.5, 0.1, 0.2), -7000.0, 1.5),  # hyperbola
        (
            lambda: orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.1, 0.2, mu=398600.4418),  # WGS 84 GM
            7000.0,
            0.2,
        ),
    ],
)
def test_perigee_inside_the_earth_warns(make, a, e):
    with pytest.warns(PerigeeInsideEarthWarning) as rec:
        make()
    assert len(rec) == 1
    w = rec[0]
    assert issubclass(w.category, OrbitWarning) and issubclass(w.category, UserWarning)
    assert _altitude(w) == pytest.approx(a * (1 - e) - R_EARTH, abs=0.06)
    assert "inside the Earth" in str(w.message)


@pytest.mark.parametrize(
    "make",
    [
        lambda: orbit.KeplerOrbit(8000.0, 0.2, 0.5, 0.1, 0.2),  # perigee 6400 km
        lambda: orbit.KeplerOrbit(7000.0, 0.0, 0.5, 0.1, 0.2),
        lambda: orbit.KeplerOrbit(-7000.0, 1.95, 0.5, 0.1, 0.2),  # perigee 6650 km
        lambda: orbit.KeplerOrbit(2000.0, 0.1, 0.5, 0.1, 0.2, mu=4902.8),  # about the Moon
        lambda: orbit.SecularJ2Orbit(7000.0, 0.001, 1.7, 0.1, 0.2),
    ],
)
def test_orbits_clear_of_the_earth_do_not_warn(make):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        make()


@pytest.mark.parametrize(
    ("make", "rp"),
    [
        (lambda: orbit.KeplerOrbit(7.0e6, 0.01, 1.0, 0.0, 0.0), 6.93e6),  # metres taken as km
        (lambda: orbit.SecularJ2Orbit(7.0e6, 0.0, 1.0, 0.0, 0.0), 7.0e6),
        (lambda: orbit.KeplerOrbit(-2.0e6, 2.0, 1.0, 0.0, 0.0), 2.0e6),  # hyperbola
    ],
)
def test_an_earth_orbit_beyond_the_hill_sphere_warns(make, rp):
    """a = 7.0e6 (an Orekit user's metres) is 7e6 km, beyond the Earth's Hill sphere,
    1 au (m⊕/3M☉)^(1/3) = 1.5e6 km: a warning naming the perigee radius and the unit."""
    with pytest.warns(BeyondHillSphereWarning) as rec:
        make()
    assert len(rec) == 1 and issubclass(rec[0].category, OrbitWarning)
    msg = str(rec[0].message)
    got = float(re.match(r"perigee radius a \(1 - e\) = (\S+) km", msg).group(1))
    assert got == pytest.approx(rp, rel=1e-3) and "Plain numbers are km" in msg
    hill = 1.495978707e8 * (3.986004418e14 / (3.0 * 1.32712440018e20)) ** (1.0 / 3.0)
    assert hill == pytest.approx(orbit.keplerorbit.EARTH_HILL_RADIUS, rel=0.01)
    with warnings.catch_warnings():  # the same numbers as metres, about the Moon: no warning
        warnings.simplefilter("error")
        orbit.KeplerOrbit(7.0e6 * u.m, 0.01, 1.0, 0.0, 0.0)
        orbit.KeplerOrbit(4.0e5, 0.05, 1.0, 0.0, 0.0)  # beyond the Moon, inside the Hill sphere
        orbit.KeplerOrbit(7.0e6, 0.01, 1.0, 0.0, 0.0, mu=1.32712440018e11)  # about the Sun
