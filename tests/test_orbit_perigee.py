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
from orbit.errors import OrbitWarning, PerigeeInsideEarthWarning

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
