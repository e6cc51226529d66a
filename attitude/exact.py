"""Exact torque-free rigid-body motion in canonical quaternion variables.

:func:`torque_free` evaluates the solution of Arribas, Elipe & Palacios (2006) eq. 7 with no
potential, ``q̇ = ½ q∘(0, ω)``, ``Q̇ = ½ Q∘(0, ω)``, ``ω = g / I``, ``g = ½ vec(q̃∘Q)``, in closed
form: the body angular momentum through Jacobi's elliptic functions and the rotation about the
(constant) space angular momentum through Legendre's elliptic integral of the third kind
(Celledoni, Fassò, Säfström & Zanna, SIAM J. Sci. Comput. 30, 2008), evaluated with Carlson's
RF and RJ. Any principal moments (in any order), both rotation regimes, the separatrix and
axisymmetric or spherical bodies are handled; the quantities that cancel near the separatrix
are formed in double-double arithmetic, so the result is exact to round-off there too. See
``docs/exact.md`` for the derivation and the measured accuracy.

The compiled kernels live in :mod:`attitude._core.exact`; ``free_flow`` there is the exact free
flow used by the splitting integrators.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import _interrupt
from ._core.exact import torque_free_kernel
from ._methods import SAMPLE_BUDGET, Problem, RunResult
from ._validation import as_float_array, as_quaternion
from .body import RigidBody
from .errors import AttitudeValueError
from .potentials import TorqueFree

__all__ = ["UNIT_NORM_TOL", "torque_free", "torque_free_states"]

#: Largest accepted relative deviation of ``|q0|`` from 1, and of ``q0·Q0`` from 0 (relative to
#: ``|q0| |Q0|``).
UNIT_NORM_TOL: float = 1e-6


def _inertia(inertia: Any) -> NDArray[np.float64]:
    if isinstance(inertia, RigidBody):
        return np.asarray(inertia.inertia, dtype=np.float64)
    return np.asarray(RigidBody(inertia).inertia, dtype=np.float64)


def torque_free(
    inertia: ArrayLike | RigidBody, q0: ArrayLike, Q0: ArrayLike, t: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact torque-free motion ``(q(t), Q(t))`` from the canonical state ``(q0, Q0)`` at t = 0.

    Parameters
    ----------
    inertia : array_like, Quantity or RigidBody, shape (3,)
        Principal moments ``(I1, I2, I3)`` about the body axes, in any order; positive,
        satisfying the triangle inequalities. A Quantity is converted to kg m² (SI).
    q0 : array_like, shape (4,)
        Initial attitude, unit quaternion (body → space), scalar first. Must be unit within
        :data:`UNIT_NORM_TOL`; it is *not* renormalised (``|q(t)| = |q0|``).
    Q0 : array_like or Quantity, shape (4,)
        Initial conjugate momenta, ``Q0 = 2 q0∘(0, g0)`` with ``g0`` the body angular momentum
        (Arribas et al. eq. 17); ``q0·Q0 = 0`` within :data:`UNIT_NORM_TOL` relative. A
        Quantity is converted to kg m² / s (SI).
    t : float or array_like, shape (n,)
        Times since the initial state (any order, any sign). A Quantity is converted to s.

    Returns
    -------
    q : ndarray, shape (n, 4), or (4,) for scalar ``t``
        Attitude at the times ``t``.
    Q : ndarray, shape (n, 4), or (4,) for scalar ``t``
        Conjugate momenta at the times ``t``; ``g(t) = ½ vec(q̃∘Q)``.

    Raises
    ------
    AttitudeValueError
        Bad shapes, non-finite values, non-physical inertia, ``q0`` not unit or ``Q0`` not
        tangent (``q0·Q0 ≠ 0``).

    Notes
    -----
    Both quaternions are right-multiplied by the same unit quaternion ``M(t)``, the exact flow
    of ``T = ⅛ Σ_{i=1..3} (q̃∘Q)_i² / I_i`` (eq. 6): the space angular momentum
    ``G = ½ vec(Q∘q̃)``, the kinetic energy, ``|q|`` and ``q·Q`` are conserved to round-off.
    The error grows like a few ulp per radian of rotation (``≈ 1e-13`` after ~500 rad);
    see ``docs/exact.md``.

    Examples
    --------
    >>> import numpy as np
    >>> from attitude.exact import torque_free
    >>> q0 = np.array([1.0, 0.0, 0.0, 0.0])
    >>> Q0 = 2 * np.array([0.0, 0.3, 0.2, 0.9])     # g0 = (0.3, 0.2, 0.9) with q0 = 1
    >>> q, Q = torque_free([1.0, 2.0, 3.0], q0, Q0, np.linspace(0.0, 10.0, 5))
    >>> q.shape, Q.shape
    ((5, 4), (5, 4))
    """
    inertia_arr = _inertia(inertia)
    q0a = as_quaternion(q0, "q0")
    Q0a = as_float_array(Q0, "Q0", trailing=4, unit="kg m2 / s")
    if q0a.shape != (4,):
        raise AttitudeValueError(f"q0: expected one quaternion of shape (4,), got {q0a.shape}")
    if Q0a.shape != (4,):
        raise AttitudeValueError(f"Q0: expected one quaternion of shape (4,), got {Q0a.shape}")
    ta = as_float_array(t, "t", unit="s")
    scalar = ta.ndim == 0
    if ta.ndim > 1:
        raise AttitudeValueError(f"t: expected a scalar or a 1-D array of times, got {ta.shape}")
    nq = float(np.linalg.norm(q0a))
    if abs(nq - 1.0) > UNIT_NORM_TOL:
        raise AttitudeValueError(
            f"q0: |q0| = {nq!r} is not 1 (off by {abs(nq - 1.0):.3g} > {UNIT_NORM_TOL:g}); pass "
            f"a unit quaternion (attitude.quaternion.normalize)"
        )
    mQ = float(np.max(np.abs(Q0a)))
    Qn = Q0a / mQ if mQ > 0.0 else Q0a  # scaled: no overflow in the norm for any |Q0|
    nQ = float(np.linalg.norm(Qn))
    qQ = float(np.dot(q0a, Qn))
    if abs(qQ) > UNIT_NORM_TOL * nq * nQ:
        raise AttitudeValueError(
            f"Q0: q0·Q0 = {qQ * mQ:.3g} is not 0 (relative {abs(qQ) / (nq * nQ):.3g} > "
            f"{UNIT_NORM_TOL:g}); the momenta must be tangent to the unit sphere, "
            f"Q0 = 2 q0∘(0, g0) (attitude.canonical.momenta_from_body_angular_momentum)"
        )
    tt = np.ascontiguousarray(ta.reshape(-1), dtype=np.float64)
    out_q = np.empty((tt.shape[0], 4))
    out_Q = np.empty((tt.shape[0], 4))
    I1, I2, I3 = (float(x) for x in inertia_arr)
    torque_free_kernel(I1, I2, I3, q0a, Q0a, tt, out_q, out_Q)
    if scalar:
        return out_q[0], out_Q[0]
    return out_q, out_Q


#: Alias of :func:`torque_free` (the name the propagator uses for a list of output times).
torque_free_states = torque_free


# --------------------------------------------------------------------------------------------
# propagate(..., method="exact")


def run_exact(
    problem: Problem,
    *,
    progress: Any = None,
    chunk: int | None = None,
    on_chunk: Any = None,
    **_: Any,
) -> RunResult:
    """Method runner ``"exact"`` of :func:`attitude.propagate`: the closed form at every time.

    Evaluated a chunk of output times at a time (bounded compiled calls: Ctrl-C acts in
    between); with ``on_chunk`` the samples are handed out as they are computed (streaming).
    """

    if not isinstance(problem.potential, TorqueFree):
        raise AttitudeValueError(
            f"method: 'exact' is the closed-form torque-free motion and cannot include the "
            f"{problem.potential.name} potential; use method='dop853' or 'splitting' (which "
            f"uses this exact free flow between potential kicks)"
        )
    I1, I2, I3 = (float(x) for x in problem.params[:3])
    t = problem.t
    m = t.shape[0]
    t0 = float(t[0])
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    streaming = on_chunk is not None
    y = np.empty((min(chunk, m) if streaming else m, 8))
    q0, Q0 = problem.y0[:4].copy(), problem.y0[4:].copy()
    out_q = np.empty((min(chunk, m), 4))
    out_Q = np.empty((min(chunk, m), 4))
    rows = y[:0]
    for i in range(0, m, chunk):
        j = min(m, i + chunk)
        # The solution is evaluated from the initial epoch t[0]: elapsed times t − t[0].
        dt = np.ascontiguousarray(np.asarray(t[i:j]) - t0)
        torque_free_kernel(I1, I2, I3, q0, Q0, dt, out_q[: j - i], out_Q[: j - i])
        rows = y[: j - i] if streaming else y[i:j]
        rows[:, :4] = out_q[: j - i]
        rows[:, 4:] = out_Q[: j - i]
        _interrupt.check()
        if streaming:
            on_chunk(i, rows)
        if progress is not None:
            progress(j, m, float(t[j - 1]))
    if streaming:  # keep only the last state (the samples went to on_chunk)
        return RunResult(rows[-1:].copy(), stats={"n_steps": 0}, first=m - 1)
    return RunResult(y, stats={"n_steps": 0})


run_exact.streams = True  # type: ignore[attr-defined]
