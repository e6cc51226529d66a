"""Thruster burns commanded by the flight software: ``Burn(start, duration, thrusters)``.

An orbit manoeuvre as flight software schedules it (Basilisk's thrFiringSchedule, GMAT's
finite burn): the listed thrusters fire from ``start`` for ``duration`` seconds while the
software's modes keep controlling the attitude with the other actuators. At each tick inside
the window the burn's thrusters are commanded on for the whole period (the last tick: for the
part of the period left), beside whatever the allocation asks of them. With a spacecraft whose
orbit is propagated with its attitude (a mass on an :class:`orbit.NumericalOrbit`) the thrust
changes the orbit, and with ``Thruster(..., isp=...)`` the mass.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = ["Burn", "burn_table"]


@dataclass(frozen=True, init=False)
class Burn:
    """A finite burn of some of the spacecraft's thrusters.

    Parameters
    ----------
    start : float or Quantity
        When the burn starts (s, the run's time axis); it takes effect at the first tick at or
        after it.
    duration : float or Quantity
        How long it lasts (s, > 0).
    thrusters : int, str or sequence of them
        The thrusters that fire: indices into ``Spacecraft.thrusters`` or their names.
    """

    start: float
    duration: float
    thrusters: tuple[int | str, ...]

    def __init__(self, start: Any, duration: Any, thrusters: Any = 0):
        s = float(as_float_array(start, "start", unit="s").reshape(()))
        d = float(as_float_array(duration, "duration", unit="s").reshape(()))
        if not math.isfinite(s):
            raise AttitudeValueError(f"start: a finite time (s), got {s!r}")
        if not (math.isfinite(d) and d > 0.0):
            raise AttitudeValueError(f"duration: a positive number of seconds, got {d!r}")
        if isinstance(thrusters, (int, np.integer, str)):
            thrusters = (thrusters,)
        if not isinstance(thrusters, Sequence) or not thrusters:
            raise AttitudeTypeError(
                f"thrusters: an index or name, or a list of them, got {thrusters!r}"
            )
        for th in thrusters:
            if isinstance(th, bool) or not isinstance(th, (int, np.integer, str)):
                raise AttitudeTypeError(f"thrusters: indices or names, got {th!r}")
        object.__setattr__(self, "start", s)
        object.__setattr__(self, "duration", d)
        object.__setattr__(self, "thrusters", tuple(thrusters))


def burn_table(burns: Sequence[Burn], craft: Any) -> np.ndarray:
    """The burns as the tick reads them: [n, then (start, stop, thruster index) per thruster
    of each burn]."""
    names = craft.names()[2]
    rows = []
    for i, b in enumerate(burns):
        for th in b.thrusters:
            if isinstance(th, str):
                if th not in names:
                    raise AttitudeValueError(
                        f"burns[{i}]: no thruster named {th!r} (the spacecraft's: {names})"
                    )
                k = names.index(th)
            else:
                k = int(th)
                if not 0 <= k < len(names):
                    raise AttitudeValueError(
                        f"burns[{i}]: thruster {k} of a spacecraft with {len(names)} thrusters"
                    )
            rows.append((b.start, b.start + b.duration, float(k)))
    return np.concatenate([[float(len(rows))], np.ravel(rows)])
