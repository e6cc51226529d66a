"""Exceptions raised by the ``orbit`` package (all subclasses of ValueError or TypeError)."""

from __future__ import annotations

__all__ = [
    "OemVelocityWarning",
    "OrbitError",
    "OrbitTypeError",
    "OrbitValueError",
    "OrbitWarning",
    "PerigeeInsideEarthWarning",
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


class OemVelocityWarning(OrbitWarning):
    """An OEM whose velocities are not the time derivative of its positions: interpolating
    with them moves the positions between states (``from_oem(velocities="positions")``
    interpolates the positions only)."""
