"""The coupled orbit–attitude system integrated by the symplectic splittings (issue 41; private).

A rigid body of mass m and principal inertia I orbits a point mass μ; the orbit (r, p = m v) and
the attitude (q, Q) share the Hamiltonian

    H = |p|²/(2m) − μ m/|r| + ½ gᵀ I⁻¹ g + V2(q, r),
    V2 = −μ/(2|r|³) (tr I − 3 r̂ᵀ I r̂)      (r̂ in body axes; MacCullagh),

as in :mod:`attitude._coupled_taylor`. ``method="splitting"`` splits it Wisdom–Holman style
(Wisdom & Holman, Astron. J. 102, 1528 (1991)) into

* A = Kepler + T: the exact Kepler drift of (r, v) (universal variables,
  :mod:`orbit._kepler_drift`) beside the exact torque-free flow of (q, Q)
  (:mod:`attitude._core.exact`); the two act on disjoint variables and commute;
* B = V2: a kick, exact because V2 depends on the coordinates q, r only:
  Q ← Q + τ 2 q∘(0, τ_B), p ← p − τ ∇_r V2,

composed by the palindromic methods of ``"splitting"`` (Strang, Blanes & Moan's S₆ and S₁₀: orders
2, 4, 6). ``method="nosquish"`` is the same with the NO_SQUISH rotors in place of the exact free
flow. The sub-flows are :mod:`attitude._core.splitting`'s ``FREE_KEPLER``, ``ROTOR_KEPLER`` and
``MUTUAL``; its one stepper runs them. Each sub-flow is the exact flow of a rotation-invariant
Hamiltonian, so the total angular momentum r × p + R(q) g is conserved to round-off, and the
energy error stays bounded (backward error analysis: the method is symplectic and
time-reversible) and of order h^order (docs/integrators.md, "Orbit and attitude in one state:
the coupled splitting").

:func:`check_spacecraft` says which spacecraft these methods carry; :func:`run_splitting` and
:func:`run_nosquish` are the runners ``propagate`` picks for them (rows q, Q, r, v, m like
:func:`attitude._coupled_taylor.run_taylor`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from orbit import _rk

from . import _interrupt
from ._core import splitting as _ks
from ._methods import STEP_BUDGET, RunResult
from .errors import AttitudeValueError
from .splitting import check_step_budget, check_step_options

__all__ = ["METHODS", "check_spacecraft", "coupled_params", "run_nosquish", "run_splitting"]

#: The fixed-step methods that carry a coupled spacecraft.
METHODS = ("splitting", "nosquish")


def check_spacecraft(craft: Any, potential: Any, method: str, software: Any = None) -> None:
    """Raise :class:`AttitudeValueError` (naming the parameter and the fix) unless ``method``
    (``"splitting"`` or ``"nosquish"``) carries this coupled spacecraft: a rigid body without
    actuators or flight software, in the gravity gradient of its own orbit (the mutual
    potential to second order) and nothing else, around a point-mass Earth (``gravity=None``,
    no third bodies)."""
    from .potentials import GravityGradient

    orb = craft.orbit
    what = f"method={method!r} carries the orbit of a spacecraft with its attitude"
    if software is not None:
        raise AttitudeValueError(
            f"software: {what} without flight software only (it composes the exact flows of "
            "one Hamiltonian; the software's commands are no part of it): use method='dop853'"
        )
    if craft.has_actuators:
        nw, nm, nt = craft.counts
        raise AttitudeValueError(
            f"spacecraft: {what} for a rigid body without actuators only (this one has {nw} "
            f"wheel(s), {nm} magnetorquer(s), {nt} thruster(s), whose torques and forces derive "
            "from no potential): use method='dop853'"
        )
    if not isinstance(potential, GravityGradient):
        name = type(potential).__name__
        why = (
            "with no torque, nothing couples the two: give the orbit to a RigidBody instead"
            if name == "TorqueFree"
            else "drag, radiation and magnetic torques derive from no potential of the state"
        )
        raise AttitudeValueError(
            f"potential: {what} in its GravityGradient(orbit) alone (the mutual potential to "
            f"second order, whose flow is a kick); got {name} ({why}): use method='dop853'"
        )
    if orb.gravity is not None or orb.third_bodies:
        has = [repr(orb.gravity)] if orb.gravity is not None else []
        has += [f"the {b.body}" for b in orb.third_bodies]
        raise AttitudeValueError(
            f"orbit: {what} around a point-mass Earth only (its drift is the Kepler flow); "
            f"this NumericalOrbit has {' and '.join(has)}: give it gravity=None and no "
            "third_bodies, or use method='dop853'"
        )


def coupled_params(inertia: Any, mass: float, mu: float) -> np.ndarray:
    """The :data:`attitude._core.splitting.COUPLED` block: principal moments ``inertia``
    [kg m²], ``mu`` [m³/s²] and 1/``mass`` [1/kg]."""
    return _ks.COUPLED.pack(
        inertia=np.asarray(inertia, dtype=np.float64), mu=float(mu), inv_mass=1.0 / float(mass)
    )


def integrate(
    params: np.ndarray,
    tables: tuple[np.ndarray, np.ndarray, np.ndarray],
    y0: np.ndarray,
    t: np.ndarray,
    dt: float,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
) -> tuple[np.ndarray, int, np.ndarray]:
    """Run the coupled composition ``tables`` (kinds, coefs, toffs) from ``y0`` = (q, Q, r, v)
    (14; SI, space axes) at ``t[0]`` through the times ``t`` (m,), at most ``chunk`` output
    times (and :data:`~attitude._methods.STEP_BUDGET` steps) per compiled call, ``progress``
    called after each (the result does not depend on either).

    Returns
    -------
    y : ndarray, shape (k, 14)
        (q, Q, r, v) at ``t[:k]`` (k = m unless the state stopped being finite).
    status : int
        :data:`attitude._core.splitting.SUCCESS` or ``NONFINITE``.
    counters : ndarray
        Steps, kicks, free flows (:func:`attitude._core.splitting.composition_run`).
    """
    kinds, coefs, toffs = tables
    m = t.shape[0]
    size = _ks.COUPLED_STATE.SIZE
    y_out = np.empty((m, size))
    y_out[0] = y0
    state = np.empty(size)
    _ks.canonical_to_state(y0, state)
    state[_ks.COUPLED_STATE.R :] = y0[_ks.COUPLED_STATE.R :]
    counters = np.zeros(_ks.N_COUNTERS, dtype=np.int64)
    counters[4] = STEP_BUDGET  # steps per compiled call: Ctrl-C acts in between
    chunk = m if chunk is None else max(1, int(chunk))
    pos = 1
    status = _ks.SUCCESS
    while pos < m:
        stop = min(m, pos + chunk)
        status, k = _ks.coupled_composition(
            params, kinds, coefs, toffs, state, float(t[pos - 1]),
            np.ascontiguousarray(t[pos:stop]), dt, y_out[pos:stop], counters,
        )  # fmt: skip
        pos += int(k)
        _interrupt.check()
        if progress is not None:
            progress(pos, m, float(t[pos - 1]))
        if status not in (_ks.SUCCESS, _ks.PAUSED):
            break
    return y_out[:pos], int(status), counters


def _run(
    method: str,
    problem: Any,
    *,
    dt: Any = None,
    order: Any = 4,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    **_: Any,
) -> RunResult:
    sr = problem.spacecraft
    craft = sr.spacecraft
    check_spacecraft(craft, problem.potential, method, sr.software)
    dt, order = check_step_options(method, dt, order)
    t = np.ascontiguousarray(problem.t, dtype=np.float64)
    check_step_budget(t, dt, max_steps)
    params = coupled_params(craft.body.inertia, craft.mass, craft.orbit.mu * 1e9)
    tables = _ks.method_tables(method, order, coupled=True)
    size = _ks.COUPLED_STATE.SIZE  # (q, Q, r, v), then the mass in the spacecraft's rows
    y, status, counters = integrate(params, tables, problem.y0[:size], t, dt, progress, chunk)
    rows = np.zeros((y.shape[0], sr.n_state + sr.n_rec))
    rows[:, :size] = y
    rows[:, size] = craft.mass
    stats = {
        "n_steps": int(counters[0]),
        "n_torque": int(counters[1]),
        "n_free_flow": int(counters[2]),
        "dt": dt,
        "order": order,
    }
    code = _rk.SUCCESS if status == _ks.SUCCESS else _rk.NONFINITE
    t_stop = None if code == _rk.SUCCESS else float(t[y.shape[0] - 1])
    return RunResult(rows, code, _rk.STATUS_MESSAGES[code], stats, t_stop=t_stop)


def run_splitting(problem: Any, **options: Any) -> RunResult:
    """``method="splitting"`` for a coupled spacecraft (:func:`check_spacecraft`)."""
    return _run("splitting", problem, **options)


def run_nosquish(problem: Any, **options: Any) -> RunResult:
    """``method="nosquish"`` for a coupled spacecraft (:func:`check_spacecraft`)."""
    return _run("nosquish", problem, **options)
