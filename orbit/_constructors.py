"""The orbits users type most: circular and sun-synchronous, from an altitude.

:meth:`orbit.KeplerOrbit.circular`, :meth:`orbit.SecularJ2Orbit.circular` and
:meth:`orbit.SecularJ2Orbit.sun_synchronous` call these. Sun-synchronism is a property of the
J2 drift of the node, so the sun-synchronous orbit is a :class:`orbit.SecularJ2Orbit` (a
Kepler orbit's node does not move).

**Sun-synchronous inclination** (e = 0; Vallado 2013, Sect. 11.4): the secular J2 node rate
dΩ/dt = −(3/2) √μ J2 R² a^(−7/2) cos i equals the mean Sun's rate
(dΩ/dt)_ss = 2π / 365.2421897 d (one turn per tropical year), so::

    cos i = −(2/3) (dΩ/dt)_ss a^(7/2) / (J2 R² √μ)

**Local time of the ascending node** (LTAN): *mean* local solar time, UT1 + λ/15°, at the
longitude λ of the ascending node at the epoch — the convention of mission specifications
(e.g. "10:30 descending"). The node's longitude is Ω − ERA (the Earth rotation angle of UT1,
ERFA ``era00``: the GCRS right ascension of the Greenwich meridian, to the second-order terms
of the ~0.1° tilt of the pole since J2000, a few 1e-6 rad; polar motion neglected, 0.3″). So::

    Ω = ERA(epoch) + 15°/h · (LTAN − UT1 hours of the epoch)

Equivalently the mean Sun's right ascension is ERA − 15°/h (UT1 − 12 h) and
LTAN = 12 h + (Ω − α_mean☉)/15°/h. The *true* (apparent) Sun of :mod:`orbit.sun` differs
from the mean one by the equation of time, −14 to +16 min over a year.
"""

from __future__ import annotations

import math
import re
from typing import Any

from .errors import OrbitTypeError, OrbitValueError

__all__ = [
    "SUN_MEAN_NODE_RATE",
    "TROPICAL_YEAR_DAYS",
    "circular_radius",
    "local_time_hours",
    "local_time_of_node",
    "raan_from_local_time",
    "sun_synchronous_inclination",
]

#: Tropical year [days of 86400 s] (the mean Sun's period in right ascension).
TROPICAL_YEAR_DAYS = 365.2421897
#: The mean Sun's rate in right ascension [rad/s]: the node rate of a sun-synchronous orbit.
SUN_MEAN_NODE_RATE = 2.0 * math.pi / (TROPICAL_YEAR_DAYS * 86400.0)

_HHMM = re.compile(r"^\s*(\d{1,2}):(\d{2})(?::(\d{2}(?:\.\d*)?))?\s*$")


def circular_radius(altitude: Any, radius: float) -> float:
    """a = R + altitude [km]; refuses altitude <= 0 (inside or on the Earth's surface)."""
    from .kepler import _scalar

    h = _scalar(altitude, "altitude", "km")
    if not h > 0.0:
        raise OrbitValueError(
            f"altitude: must be > 0 km above the equatorial radius {radius} km, got {h!r} km "
            "(give the height above the surface, not the orbit radius a)"
        )
    return radius + h


def local_time_hours(value: Any, name: str = "local_time_of_node") -> float:
    """Hours in [0, 24) from ``"HH:MM"``, ``"HH:MM:SS"``, a number of hours or a Quantity."""
    if isinstance(value, str):
        m = _HHMM.match(value)
        if m is None:
            raise OrbitValueError(
                f"{name}: cannot read {value!r} as a local time; give 'HH:MM' or 'HH:MM:SS' "
                "(24-hour clock, e.g. '10:30' or '22:30') or hours as a number (10.5)"
            )
        hh, mm, ss = int(m.group(1)), int(m.group(2)), float(m.group(3) or 0.0)
        if not (hh < 24 and mm < 60 and ss < 60.0):
            raise OrbitValueError(
                f"{name}: {value!r} is not a time of day (hours 0-23, minutes and seconds "
                "0-59), e.g. '10:30'"
            )
        return hh + mm / 60.0 + ss / 3600.0
    from .kepler import _scalar

    if isinstance(value, bool):
        raise OrbitTypeError(f"{name}: expected 'HH:MM' or hours as a number, got {value!r}")
    hours = _scalar(value, name, "h")
    if not 0.0 <= hours < 24.0:
        raise OrbitValueError(
            f"{name}: {hours!r} h is not a time of day; give hours in [0, 24) (10.5 or '10:30')"
        )
    return hours


def _era_and_ut1_hours(epoch: Any) -> tuple[float, float]:
    """(ERA [rad], UT1 hours of the day) at ``epoch``, UT1 from the package's IERS policy."""
    import erfa

    from .timescales import offline_iers

    with offline_iers():
        ut1 = epoch.ut1
    jd1, jd2 = float(ut1.jd1), float(ut1.jd2)
    era = float(erfa.era00(jd1, jd2))
    day_fraction = ((jd1 - 0.5) % 1.0 + jd2 % 1.0) % 1.0  # days since 0h UT1
    return era, 24.0 * day_fraction


def raan_from_local_time(local_time: float, epoch: Any) -> float:
    """Ω [rad, in [0, 2π)] of the node whose mean local time is ``local_time`` hours at
    ``epoch`` (module docstring)."""
    era, ut1_h = _era_and_ut1_hours(epoch)
    return (era + math.radians(15.0 * (local_time - ut1_h))) % (2.0 * math.pi)


def local_time_of_node(raan: float, epoch: Any) -> float:
    """Mean local time [h, in [0, 24)] at the node of right ascension ``raan`` at ``epoch``."""
    era, ut1_h = _era_and_ut1_hours(epoch)
    return (ut1_h + math.degrees(raan - era) / 15.0) % 24.0


def sun_synchronous_inclination(a: float, mu: float, j2: float, radius: float) -> float:
    """The inclination [rad] of the circular orbit of radius ``a`` [km] whose J2 node rate is
    the mean Sun's; refuses a radius where cos i < −1 (the J2 drift is too slow)."""
    # in logarithms: a, mu or radius near the float range overflow the powers (fuzzing)
    log_c = (
        math.log(2.0 / 3.0 * SUN_MEAN_NODE_RATE)
        + 3.5 * math.log(a)
        - math.log(j2)
        - 2.0 * math.log(radius)
        - 0.5 * math.log(mu)
    )
    if log_c > 0.0:  # cos i < -1
        log_a_max = (math.log(a) * 3.5 - log_c) / 3.5
        a_max = math.exp(log_a_max) if log_a_max < 700.0 else math.inf
        raise OrbitValueError(
            f"altitude: no sun-synchronous circular orbit at {a - radius:.6g} km: the J2 node "
            f"drift there is too slow even for a polar retrograde orbit (cos i < -1); give an "
            f"altitude below {a_max - radius:.0f} km"
        )
    return math.acos(-math.exp(log_c))
