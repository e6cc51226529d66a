"""The coupled orbit–attitude system integrated by the Taylor method (issue 41; private).

A rigid body of mass m and principal inertia I orbits a point mass (μ); the orbit (r, p = m v)
and the attitude (q, Q) share the Hamiltonian

    H = |p|²/(2m) − μ m/|r| + V2(q, r) + ½ gᵀ I⁻¹ g,
    V2 = −μ/(2|r|³) (tr I − 3 r̂ᵀ I r̂)      (r in body axes; MacCullagh),

so the gravity-gradient torque (Arribas et al. eq. 20) acts back on the orbit through
F = −∇_r V2. The total energy H and the total angular momentum r × p + R(q) g are conserved.
The series and their derivation are in :mod:`attitude._core.taylor` (module docstring,
"Coupled orbit–attitude mode"), the stepping in :mod:`attitude._core.taylor_coupled`.

:func:`run_coupled_taylor` is the runner, in SI units; :func:`coupled_invariants` evaluates
H and the total angular momentum along its output.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from orbit import _rk

from ._core import taylor as _kt
from ._core import taylor_coupled as _kc
from ._core.potentials import KIND_GRAVITY_GRADIENT_COUPLED, MODEL
from ._methods import dop853_call
from ._validation import as_float_array, as_times
from .canonical import body_angular_momentum, project_state
from .errors import AttitudeValueError, PropagationError
from .quaternion import conjugate, rotate

__all__ = ["coupled_invariants", "coupled_params", "run_coupled_taylor"]

#: Earth's gravitational parameter [m³/s²] (WGS 84).
MU_EARTH = 3.986004418e14


def coupled_params(inertia: Any, mass: float, mu: float) -> np.ndarray:
    """The model parameters of the coupled mode (block :data:`attitude._core.taylor.COUPLED`).

    ``mass = inf`` gives 1/m = 0: no back-reaction (a Kepler orbit integrated in body axes).
    """
    inertia = as_float_array(inertia, "inertia", trailing=3, ndim=1)
    if not np.all(np.isfinite(inertia) & (inertia > 0.0)):
        raise AttitudeValueError(
            f"inertia: principal moments must be finite and > 0, got {inertia}"
        )
    mass = float(mass)
    mu = float(mu)
    if not mass > 0.0:
        raise AttitudeValueError(f"mass: must be > 0 kg (inf: no back-reaction), got {mass!r}")
    if not (math.isfinite(mu) and mu > 0.0):
        raise AttitudeValueError(f"mu: must be a finite number > 0 m³/s², got {mu!r}")
    params = np.zeros(MODEL.KIND + _kt.COUPLED.SIZE)
    params[:3] = inertia
    _kt.COUPLED.pack_into(
        params, MODEL.KIND, kind=KIND_GRAVITY_GRADIENT_COUPLED, type=-1.0, mu=mu,
        inv_mass=1.0 / mass,
    )  # fmt: skip
    return params


def run_coupled_taylor(
    inertia: Any,
    mass: float,
    mu: float,
    q0: Any,
    Q0: Any,
    r0: Any,
    v0: Any,
    t: Any,
    *,
    rtol: float = 1e-13,
    atol: float = 1e-16,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
) -> dict[str, Any]:
    """Integrate the coupled orbit–attitude system with the Taylor method.

    Parameters
    ----------
    inertia : array_like, shape (3,)
        Principal moments of inertia [kg m²].
    mass : float
        Mass of the body [kg]; ``math.inf`` switches the back-reaction on the orbit off.
    mu : float
        Gravitational parameter of the central body [m³/s²] (Earth: :data:`MU_EARTH`).
    q0, Q0 : array_like, shape (4,)
        Initial attitude quaternion (body → space, scalar first) and conjugate momenta
        [kg m²/s]; projected onto |q| = 1, q·Q = 0 as by ``propagate``.
    r0, v0 : array_like, shape (3,)
        Initial position [m] and velocity [m/s] of the centre of mass, space axes.
    t : array_like, shape (n,)
        Output times [s], strictly increasing; the run starts at ``t[0]``.
    rtol, atol : float
        Tolerances of Jorba & Zou's order and step (per block: q, Q, r, v; relative control
        above ``atol/rtol``, so the default is relative for every block).
    max_step : float
        Largest step [s].
    max_steps : int
        Largest number of steps.

    Returns
    -------
    dict
        ``q``, ``Q`` (n, 4); ``r`` [m], ``v`` [m/s] (n, 3) in space axes; ``r_body``,
        ``v_body`` (n, 3) the same in body axes (the integrated variables); ``g`` (n, 3) the body
        angular momentum [kg m²/s]; ``t`` (n,); ``n_steps``, ``order``.

    Raises
    ------
    AttitudeValueError
        Bad input.
    PropagationError
        The integration stopped early (non-finite state, step too small, too many steps).

    Examples
    --------
    >>> import numpy as np
    >>> out = run_coupled_taylor(
    ...     [1e9, 1e9, 2e7], 1e5, MU_EARTH, [1, 0, 0, 0], [0, 0, 0, 2e6],
    ...     [7e6, 0, 0], [0, 7546.05, 0], np.linspace(0.0, 600.0, 7))
    >>> out["r"].shape
    (7, 3)
    """
    params = coupled_params(inertia, mass, mu)
    tt = np.ascontiguousarray(as_times(t, "t"), dtype=np.float64)
    q, Q, _ = project_state(
        as_float_array(q0, "q0", trailing=4, ndim=1), as_float_array(Q0, "Q0", trailing=4, ndim=1)
    )
    r = as_float_array(r0, "r0", trailing=3, ndim=1)
    v = as_float_array(v0, "v0", trailing=3, ndim=1)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(v)) and np.any(r != 0.0)):
        raise AttitudeValueError(f"r0, v0: need a finite, non-zero position, got {r}, {v}")
    if not (rtol > 0.0 and atol > 0.0):
        raise AttitudeValueError(f"rtol, atol: must be > 0, got {rtol!r}, {atol!r}")
    y_out, status, k, t_reached, n_steps, order = _integrate(
        params, q, Q, r, v, tt, rtol, atol, max_step, max_steps
    )
    if status != _rk.SUCCESS:
        raise PropagationError(
            f"coupled taylor run stopped at t = {t_reached!r}: {_rk.STATUS_MESSAGES[status]} "
            f"({k} of {tt.shape[0]} output times)",
            time=t_reached,
        )
    return _space_axes(tt, y_out) | {"n_steps": n_steps, "order": order}


def _integrate(params, q, Q, r, v, tt, rtol, atol, max_step, max_steps):
    """The compiled run: (rows of XSTATE, status, rows done, time reached, steps, order)."""
    y0 = _kt.XSTATE.pack(q=q, p=Q, r=rotate(conjugate(q), r), v=rotate(conjugate(q), v))
    m = tt.shape[0]
    y_out = np.empty((m, _kt.XSTATE.SIZE))
    work, tstate, counters = _kc.new_state()
    status, k = dop853_call(
        _kc.coupled_run, params, y0, float(tt[0]), tt, y_out, work, tstate, counters,
        float(rtol), float(atol), float(tt[-1]), float(max_step), int(max_steps),
    )  # fmt: skip
    return y_out[:k], int(status), int(k), float(tstate[0]), int(counters[0]), int(tstate[3])


def _space_axes(tt: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    st = _kt.XSTATE.read(y)
    qo, Qo, rb, vb = st["q"], st["p"], st["r"], st["v"]
    return {
        "t": tt[: y.shape[0]],
        "q": qo,
        "Q": Qo,
        "r": rotate(qo, rb),
        "v": rotate(qo, vb),
        "r_body": rb,
        "v_body": vb,
        "g": body_angular_momentum(qo, Qo),
    }


def check_spacecraft(craft: Any, potential: Any, software: Any = None) -> None:
    """Raise :class:`AttitudeValueError` (naming ``method``) unless ``method="taylor"`` carries
    this coupled spacecraft: no actuators or software, the gravity gradient of its own orbit
    (the mutual potential to second order), a point-mass Earth without third bodies (the
    series of eq. 7 with the orbit in body axes, :mod:`attitude._core.taylor`)."""
    from .potentials import GravityGradient

    orb = craft.orbit
    why = None
    if craft.has_actuators or software is not None:
        why = "actuators or flight software"
    elif not isinstance(potential, GravityGradient):
        why = f"the model {type(potential).__name__}"
    elif orb.gravity is not None or orb.third_bodies:
        why = "a gravity field or third bodies on the orbit"
    if why is not None:
        raise AttitudeValueError(
            f"method: 'taylor' carries the orbit of a spacecraft propagated with its attitude "
            f"around a point-mass Earth in its gravity gradient; not with {why}: "
            "use method='dop853'"
        )


def run_taylor(
    problem: Any,
    *,
    rtol: float,
    atol: float,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    **_: Any,
) -> Any:
    """``method="taylor"`` for a spacecraft carrying its orbit (:func:`check_spacecraft`): the
    rows (q, Q, r, v, m) and empty command records of the spacecraft runners."""
    from ._methods import RunResult

    sr = problem.spacecraft
    craft = sr.spacecraft
    check_spacecraft(craft, problem.potential, sr.software)
    params = coupled_params(craft.body.inertia, craft.mass, craft.orbit.mu * 1e9)
    y0 = problem.y0
    tt = np.ascontiguousarray(problem.t, dtype=np.float64)
    y, status, k, t_reached, n_steps, order = _integrate(
        params, y0[:4], y0[4:8], y0[8:11], y0[11:14], tt, rtol, atol, max_step, max_steps
    )
    sp = _space_axes(tt, y)
    rows = np.zeros((k, sr.n_state + sr.n_rec))
    rows[:, 0:4] = sp["q"]
    rows[:, 4:8] = sp["Q"]
    rows[:, 8:11] = sp["r"]
    rows[:, 11:14] = sp["v"]
    rows[:, 14] = craft.mass
    stats = {"rtol": rtol, "atol": atol, "order": order, "n_steps": n_steps}
    msg = _rk.STATUS_MESSAGES.get(status, "stopped")
    return RunResult(rows, status, msg, stats, t_stop=None if status == _rk.SUCCESS else t_reached)


def coupled_invariants(out: dict[str, Any], inertia: Any, mass: float, mu: float) -> dict:
    """The total energy H [J] and angular momentum [kg m²/s] along a :func:`run_coupled_taylor`
    output, and their orbital and rotational parts.

    Returns
    -------
    dict
        ``energy`` (n,), ``L`` (n, 3) total, space axes; ``L_orbit`` = m r × v and ``L_spin`` =
        R(q) g (n, 3); ``E_orbit`` = ½ m |v|² − μ m/|r|, ``E_spin`` = ½ gᵀ I⁻¹ g and ``V2`` (n,).
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    q = out["q"]
    rb = out["r_body"]
    vb = out["v_body"]
    g = out["g"]
    rr = np.sqrt(np.sum(rb * rb, axis=-1))
    # V2 = −μ/(2|r|³) (tr I − 3 r̂ᵀ I r̂)
    v2 = -0.5 * mu / rr**3 * (inertia.sum() - 3.0 * np.sum(inertia * rb * rb, axis=-1) / rr**2)
    e_orbit = 0.5 * mass * np.sum(vb * vb, axis=-1) - mu * mass / rr
    e_spin = 0.5 * np.sum(g * g / inertia, axis=-1)
    l_orbit = mass * np.cross(out["r"], out["v"])
    l_spin = rotate(q, g)
    return {
        "energy": e_orbit + v2 + e_spin,
        "E_orbit": e_orbit,
        "E_spin": e_spin,
        "V2": v2,
        "L": l_orbit + l_spin,
        "L_orbit": l_orbit,
        "L_spin": l_spin,
    }
