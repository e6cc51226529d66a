"""Compiled flight-software steps of the tests (a file of their own: numba caches a function
that lives in a source file, and the user module of a step is named after that file)."""

import numpy as np
from numba import njit

from attitude.software import MeasurementIndex as M

#: scenarioAttitudeFeedbackRW's inertia and the HR16 wheels' axial inertia (50 N m s at 6000 rpm)
INERTIA = np.diag([900.0, 800.0, 600.0])
JS = 50.0 / (6000.0 * 2.0 * np.pi / 60.0)


@njit(cache=True)
def mrp_feedback(t, m):
    """Basilisk's mrpFeedback (K = 3.5, P = 30, no integral term) for three wheels on the body
    axes: u = −G⁺(−L_r) = L_r."""
    w = m[M.OMEGA : M.OMEGA + 3]
    wr = m[M.OMEGA_REF : M.OMEGA_REF + 3]
    h = JS * (w + m[M.WHEEL_SPEEDS : M.WHEEL_SPEEDS + 3])
    lr = 3.5 * m[M.SIGMA_ERROR : M.SIGMA_ERROR + 3] + 30.0 * m[M.OMEGA_ERROR : M.OMEGA_ERROR + 3]
    return lr - np.cross(wr, INERTIA @ w + h) + INERTIA @ np.cross(w, wr)


@njit(cache=True)
def fails_in_time(t, m):
    """Three zero commands; from t = 2 s a NaN among them, from t = 3 s five commands instead
    of three. (One step for both failures: every compiled step compiles the closed-loop drivers
    again in a module of its own.)"""
    if t >= 3.0:
        return np.zeros(5)
    out = np.zeros(3)
    if t >= 2.0:
        out[1] = np.nan
    return out


@njit(cache=True)
def rate_damping_or_wheel_loop(t, m):
    """Without wheels, three body-torque components: −2 ω (N m s); with one wheel, that wheel on
    its tachometer: u = −0.02 (Ω − 10 rad/s) N m. (One step for both spacecraft: every compiled
    step compiles the closed-loop drivers again in a module of its own.)"""
    if m.shape[0] == M.WHEEL_SPEEDS:  # no wheel speeds and momenta after the fixed part
        return -2.0 * m[M.OMEGA : M.OMEGA + 3]
    return np.array([-0.02 * (m[M.WHEEL_SPEEDS] - 10.0)])
