"""Exceptions raised by the ``orbit`` package (all subclasses of ValueError or TypeError)."""

from __future__ import annotations

__all__ = [
    "BeyondHillSphereWarning",
    "OemVelocityWarning",
    "OrbitError",
    "OrbitTypeError",
    "OrbitValueError",
    "OrbitWarning",
    "PerigeeInsideEarthWarning",
    "TLEAgeWarning",
]


class OrbitError(Exception):
    """Base class of every exception raised on purpose by ``orbit``."""


class OrbitValueError(OrbitError, ValueError):
    """An orbit argument has a bad value (names the parameter and the fix)."""


class OrbitTypeError(OrbitError, TypeError):
    """An orbit argument has the wrong type or incompatible units."""


class OrbitWarning(UserWarning):
    """The orbit is valid but probably not what was meant."""


class PerigeeInsideEarthWarning(OrbitWarning):
    """An Earth orbit (mu = Earth's GM) whose perigee radius a (1 − e) is below the Earth's
    equatorial radius: the satellite would pass through the Earth."""


class BeyondHillSphereWarning(OrbitWarning):
    """An Earth orbit (mu = Earth's GM) whose perigee radius is beyond the Earth's Hill sphere
    (1.5e6 km), where the Sun, not the Earth, governs the motion: most often a semi-major axis
    given in metres where plain numbers are km."""


class TLEAgeWarning(OrbitWarning):
    """A two-line element set used far from its epoch: SGP4's error grows with the time from
    the epoch (about 1-3 km a day in low orbit), so beyond ``orbit.ephemeris.TLE_MAX_AGE`` days
    the positions are rough, and years away they are fiction."""


class OemVelocityWarning(OrbitWarning):
    """An OEM whose velocities are not the time derivative of its positions: interpolating
    with them moves the positions between states (``from_oem(velocities="positions")``
    interpolates the positions only)."""
