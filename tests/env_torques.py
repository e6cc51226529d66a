"""User torques reading the environment, for tests/test_torque_environment.py (a file of their
own: numba caches a function that lives in a source file, and the user module of a torque is
named after that file, so editing the tests does not recompile these)."""

import numpy as np

from attitude.potentials import EnvironmentIndex as E

#: The dipole of the magnetorquer torques [A m²], body axes.
DIPOLE = np.array([0.02, -0.03, 0.05])
#: Gain of the Sun-direction torque [N m] and of the eddy-current law [S m⁴].
SUN_GAIN = 1.0e-6
EDDY = 0.7


def dipole_torque(q, t, env):
    """τ = m × B_B, the field from env (MagneticDipole's torque written by hand)."""
    b = env[E.FIELD : E.FIELD + 3]
    m = DIPOLE
    return (m[1] * b[2] - m[2] * b[1], m[2] * b[0] - m[0] * b[2], m[0] * b[1] - m[1] * b[0])


def sun_torque(q, t, env):
    """A torque along the Sun's direction in body axes, scaled by the light: k ν ŝ_B."""
    k = SUN_GAIN * env[E.SHADOW]
    s = env[E.SUN : E.SUN + 3]
    return (k * s[0], k * s[1], k * s[2])


def position_torque(q, t, env):
    """The position r [km] as a 'torque' (reads R through the torque path)."""
    return (env[E.R], env[E.R + 1], env[E.R + 2])


def eddy_torque(q, omega, t, env):
    """(M (ω × B)) × B with M = EDDY 1: eddy-current damping in a field fixed in space."""
    b = env[E.FIELD : E.FIELD + 3]
    u = EDDY * np.cross(omega, b)
    return np.cross(u, b)
