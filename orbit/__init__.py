"""orbit: Keplerian two-body motion for driving attitude potentials.

Our own Kepler solver (no poliastro/hapsira): anomalies, r(t), f(t), and the orbital-frame
quaternion p(t) of Arribas, Elipe & Palacios (2006), Sect. 6.2.
"""

from __future__ import annotations

from .errors import OrbitError, OrbitTypeError, OrbitValueError

__all__ = ["OrbitError", "OrbitTypeError", "OrbitValueError"]
