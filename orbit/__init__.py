"""orbit: the orbits that drive attitude potentials, with dates and frames.

Our own Kepler solver (no poliastro/hapsira): anomalies, r(t), f(t), and the orbital-frame
quaternion p(t) of Arribas, Elipe & Palacios (2006), Sect. 6.2. Orbit sources with one interface
(:class:`orbit.base.Orbit`): :class:`KeplerOrbit`, :class:`SecularJ2Orbit` (secular J2 drift),
:class:`EphemerisOrbit` (tables; from TLEs via sgp4, CCSDS OEM files, or other orbits). An
orbit may carry an ``epoch`` (astropy Time); its space frame is then the GCRS. Plain floats are
km, s, rad and km³/s²; astropy Quantities of any compatible unit are converted once, at the
boundary.

>>> import numpy as np, orbit
>>> o = orbit.KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12)
>>> r, f, p = o.radius(600.0), o.true_anomaly(600.0), o.frame_quaternion(600.0)
"""

from __future__ import annotations

from .base import Orbit
from .ephemeris import EphemerisOrbit
from .errors import OrbitError, OrbitTypeError, OrbitValueError
from .gravity_field import SphericalHarmonics
from .j2 import SecularJ2Orbit
from .kepler import (
    eccentric_from_true,
    hyperbolic_from_true,
    mean_from_eccentric,
    mean_from_hyperbolic,
    mean_from_true,
    mean_from_true_hyperbolic,
    solve_kepler,
    solve_kepler_hyperbolic,
    true_from_eccentric,
    true_from_hyperbolic,
    true_from_mean,
    true_from_mean_hyperbolic,
)
from .keplerorbit import KeplerOrbit, earth_mu
from .numerical import Impact, NumericalOrbit
from .third_body import ThirdBody
from .timescales import IERSRangeWarning

__all__ = [
    "EphemerisOrbit",
    "IERSRangeWarning",
    "Impact",
    "KeplerOrbit",
    "NumericalOrbit",
    "Orbit",
    "OrbitError",
    "OrbitTypeError",
    "OrbitValueError",
    "SecularJ2Orbit",
    "SphericalHarmonics",
    "ThirdBody",
    "earth_mu",
    "eccentric_from_true",
    "hyperbolic_from_true",
    "mean_from_eccentric",
    "mean_from_hyperbolic",
    "mean_from_true",
    "mean_from_true_hyperbolic",
    "solve_kepler",
    "solve_kepler_hyperbolic",
    "true_from_eccentric",
    "true_from_hyperbolic",
    "true_from_mean",
    "true_from_mean_hyperbolic",
]
