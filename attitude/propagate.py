"""``propagate``: the one entry point of attitude propagation.

Physics (the body and a :mod:`~attitude.potentials` model), numerics (a method name and its
options) and output (an xarray Dataset, :mod:`attitude.results`) are separate pieces passed to
one function, as in ``scipy.integrate.solve_ivp``.

Methods
-------
``"dop853"``
    Adaptive 8th-order Dormand–Prince with error control and 7th-order dense output at the
    requested times; right-hand side and step loop in one compiled function (cached on disk).
``"scipy:<name>"``
    The same right-hand side through ``scipy.integrate.solve_ivp(method=<name>)`` (e.g.
    ``"scipy:DOP853"``, ``"scipy:Radau"``): a reference path, not a fast one.

Further methods (``"exact"``, ``"nosquish"``, ``"splitting"``, ``"taylor"``) register themselves in
:data:`METHODS` from their own modules.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from ._core import dynamics as _dyn
from ._core import rk as _rk
from ._validation import as_float_array, as_times
from .body import RigidBody
from .canonical import project_state
from .errors import AttitudeTypeError, AttitudeValueError, PropagationError
from .potentials import Potential, as_potential
from .results import build_dataset

__all__ = ["METHODS", "Problem", "RunResult", "propagate"]

#: Relative defect of the initial state above which a projection warns.
PROJECTION_WARN = 1e-12


@dataclass
class Problem:
    """A validated propagation problem in plain floats (what the method runners receive)."""

    body: RigidBody
    potential: Potential
    params: np.ndarray  # compiled-kernel parameters (inertia, kind, potential numbers)
    y0: np.ndarray  # (8,) projected initial state
    t: np.ndarray  # (m,) output times; t[0] is the initial epoch
    kernels: Any  # None for built-in potentials, else (torque, potential) compiled functions

    @property
    def rhs(self) -> Callable:
        """Compiled canonical right-hand side rhs(t, y, params, dydt)."""
        if self.kernels is None:
            return _dyn.canonical_rhs_builtin
        return _dyn.user_rhs(_dyn.canonical_rhs_with, self.kernels[0])


@dataclass
class RunResult:
    """What a method runner returns."""

    y: np.ndarray  # (n_done, 8)
    status: int = _rk.SUCCESS
    message: str = "success"
    stats: dict[str, Any] = field(default_factory=dict)
    first: int = 0  # index in problem.t of y[0] (> 0 when earlier samples were streamed out)
    t_stop: float | None = None  # time the integration reached when it failed


# --------------------------------------------------------------------------------------------
# Method runners
# --------------------------------------------------------------------------------------------


def _run_dop853(
    problem: Problem,
    *,
    rtol: float,
    atol: float,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    on_chunk: Callable[[int, np.ndarray], None] | None = None,
    **_: Any,
) -> RunResult:
    t = problem.t
    m = t.shape[0]
    chunk = m if chunk is None else max(1, int(chunk))
    # Streaming (on_chunk): one chunk-sized buffer, handed out and reused, so memory is
    # bounded whatever the number of output samples.
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, 8))
    work, tstate, counters = _rk.new_state(8)
    done = 0
    status = _rk.SUCCESS
    while done < m:
        stop = min(m, done + chunk)
        t_chunk = t[done:stop]
        y_chunk = y_out[: stop - done] if on_chunk is not None else y_out[done:stop]
        if problem.kernels is None:
            status, k = _dyn.dop853_canonical_builtin(
                problem.params,
                problem.y0,
                t[0],
                t_chunk,
                y_chunk,
                work,
                tstate,
                counters,
                rtol,
                atol,
                t[-1],
                max_step,
                max_steps,
            )
        else:
            status, k = _rk.dop853_run(
                problem.rhs,
                problem.params,
                problem.y0,
                t[0],
                t_chunk,
                y_chunk,
                work,
                tstate,
                counters,
                rtol,
                atol,
                t[-1],
                max_step,
                max_steps,
            )
        if on_chunk is not None and k:
            on_chunk(done, y_chunk[: int(k)])
        done += int(k)
        if progress is not None:
            progress(done, m, float(tstate[0]))
        if status != _rk.SUCCESS:
            break
    stats = {
        "rtol": rtol,
        "atol": atol,
        "n_steps": int(counters[0]),
        "n_rhs": int(counters[1]),
        "n_rejected": int(counters[2]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    if on_chunk is not None:  # keep only the last state (the samples went to on_chunk)
        last = max(done - 1, 0)
        y_last = y_chunk[: int(k)][-1:].copy()
        return RunResult(y_last, int(status), msg, stats, first=last, t_stop=t_stop)
    return RunResult(y_out[:done], int(status), msg, stats, t_stop=t_stop)


_run_dop853.streams = True  # type: ignore[attr-defined]


def _run_scipy(
    problem: Problem, *, solver: str, rtol: float, atol: float, max_step=math.inf, **_: Any
) -> RunResult:
    from scipy.integrate import solve_ivp

    rhs = problem.rhs
    params = problem.params

    def fun(tt, yy):
        out = np.empty(8)
        rhs(tt, np.ascontiguousarray(yy), params, out)
        return out

    t = problem.t
    if t.shape[0] == 1:
        return RunResult(problem.y0[None, :].copy(), stats={"rtol": rtol, "atol": atol, "n_rhs": 0})
    sol = solve_ivp(
        fun,
        (t[0], t[-1]),
        problem.y0,
        method=solver,
        t_eval=t,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
    )
    y = sol.y.T.copy()
    stats = {"rtol": rtol, "atol": atol, "n_rhs": int(sol.nfev)}
    ok = sol.status == 0 and np.all(np.isfinite(y))
    if ok:
        return RunResult(y, stats=stats)
    good = np.all(np.isfinite(y), axis=1)
    n = int(np.argmin(good)) if not np.all(good) else y.shape[0]
    return RunResult(y[:n], _rk.NONFINITE, f"scipy {solver}: {sol.message}", stats)


#: Registered methods: name -> runner(problem, **options) -> RunResult.
METHODS: dict[str, Callable[..., RunResult]] = {"dop853": _run_dop853}

_SCIPY_SOLVERS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")


def _lookup_method(method: str) -> tuple[Callable[..., RunResult], dict[str, Any]]:
    if not isinstance(method, str):
        raise AttitudeTypeError(f"method: expected a string, got {type(method).__name__}")
    if method.startswith("scipy:"):
        solver = method.split(":", 1)[1]
        if solver not in _SCIPY_SOLVERS:
            raise AttitudeValueError(
                f"method: unknown scipy solver {solver!r}; use one of "
                + ", ".join(f"'scipy:{s}'" for s in _SCIPY_SOLVERS)
            )
        return _run_scipy, {"solver": solver}
    _load_plugins()
    if method not in METHODS:
        known = [*sorted(METHODS), "scipy:<solver>"]
        raise AttitudeValueError(f"method: unknown method {method!r}; known: {', '.join(known)}")
    return METHODS[method], {}


_PLUGINS_LOADED: list[bool] = []


def _load_plugins() -> None:
    # Methods living in their own modules register themselves on import (once per process).
    if _PLUGINS_LOADED:
        return
    import importlib

    for mod in ("attitude.splitting", "attitude.exact", "attitude.taylor"):
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:  # not built yet in this checkout
            if exc.name != mod:
                raise
    _PLUGINS_LOADED.append(True)


def _as_body(body: Any) -> RigidBody:
    if isinstance(body, RigidBody):
        return body
    return RigidBody(body)


def _positive(x: Any, name: str) -> float:
    v = float(as_float_array(x, name))
    if not v > 0:
        raise AttitudeValueError(f"{name}: must be a positive number, got {v}")
    return v


def propagate(
    body: RigidBody | Any,
    q0: Any,
    Q0: Any,
    t: Any,
    potential: Potential | None = None,
    method: str = "dop853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    dt: float | None = None,
    order: int = 4,
    *,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    formulation: str = "canonical",
    on_chunk: Callable[[xr.Dataset], None] | None = None,
) -> xr.Dataset:
    """Propagate the attitude of a rigid body in canonical quaternion variables.

    Integrates Hamilton's equations in (q, Q) (Arribas, Elipe & Palacios 2006, eq. 7) with the
    potential's torque entering as the generalised force 2 q∘(0, τ_B) (Schwab eq. 25).

    Parameters
    ----------
    body : RigidBody or array_like, shape (3,)
        The body (principal moments of inertia).
    q0 : array_like, shape (4,)
        Initial attitude quaternion (body → space, scalar first).
    Q0 : array_like, shape (4,)
        Initial conjugate momenta, Q0 = 2 q0∘(0, g0). A state within 1e-6 (relative) of
        |q| = 1, q·Q = 0 is projected onto it (the correction is recorded in the attrs; a
        warning above 1e-12); anything further off is rejected.
    t : array_like, shape (m,)
        Output times, strictly monotonic; ``t[0]`` is the initial epoch. Decreasing times
        integrate backwards.
    potential : Potential, optional
        ``TorqueFree()`` (default), ``HeavyTop``, ``GravityGradient``, ``CustomPotential``,
        ``CustomTorque``.
    method : str
        ``"dop853"`` (default), ``"scipy:<solver>"``, and where available ``"exact"``,
        ``"nosquish"``, ``"splitting"``, ``"taylor"`` (built-in potentials).
    rtol, atol : float
        Tolerances of the adaptive methods (per-component, on the 8 state variables).
    dt : float, optional
        Step of the fixed-step methods.
    order : int
        Order of the composition methods (2, 4 or 6).
    max_step : float
        Largest step of the adaptive methods.
    max_steps : int
        Give up after this many steps.
    progress : callable, optional
        ``progress(n_done, n_total, t_reached)`` called after each chunk of output times.
    chunk : int, optional
        Output samples per compiled call (with ``progress``); results do not depend on it.
    formulation : str
        Equations integrated: ``"canonical"`` (default, eq. 7 in (q, Q)) or another of
        :data:`attitude.formulations.FORMULATIONS` (``"euler_angles"``, ``"schwab"``,
        ``"euler_equations"``). Every formulation returns the same Dataset schema.
    on_chunk : callable, optional
        Streaming: ``on_chunk(ds_chunk)`` receives, in time order, Datasets of consecutive
        output samples (``chunk`` of them, default 4096; the last one may be shorter, also
        when the run fails midway). With the canonical ``"dop853"`` runner the samples are
        not kept, so memory stays bounded (see :func:`attitude.io.write_streaming`); the
        returned Dataset then holds only the last sample (with the complete attrs).

    Returns
    -------
    xarray.Dataset
        Dimension ``time``; variables ``q``, ``Q``, ``omega``, ``g``, ``G``, ``energy``,
        ``potential_energy``, ``norm_error``, ``qQ`` (and ``r``, ``f``, ``p`` with an orbit);
        attrs record the method, tolerances, statistics, body and potential. See
        docs/results.md.

    Raises
    ------
    AttitudeValueError, AttitudeTypeError
        Bad input, before any work.
    PropagationError
        The integration failed midway; ``.partial`` holds the samples computed so far.
    """
    body = _as_body(body)
    pot = as_potential(potential).bind(body)
    runner, extra = _lookup_method(method)
    form = None
    if formulation != "canonical":
        from .formulations import get_formulation

        form = get_formulation(formulation, method)
    q0a = as_float_array(q0, "q0", trailing=4, ndim=1)
    # Q has units of angular momentum: a Quantity is accepted when the body has units.
    Q0a = as_float_array(
        Q0, "Q0", trailing=4, ndim=1, unit=None if body.units is None else "kg km2 / s"
    )
    tt = as_times(t, "t")
    rtol = _positive(rtol, "rtol")
    atol = _positive(atol, "atol")
    if rtol < 1e-15:
        raise AttitudeValueError(
            f"rtol: {rtol:g} is below what double precision can deliver; use >= 1e-15"
        )
    if dt is not None:
        dt = _positive(dt, "dt")
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool):
        raise AttitudeTypeError(f"order: expected an integer (2, 4 or 6), got {order!r}")
    if not (isinstance(max_step, (int, float)) and max_step == math.inf):
        max_step = _positive(max_step, "max_step")
    if not isinstance(max_steps, (int, np.integer)) or max_steps <= 0:
        raise AttitudeValueError(f"max_steps: expected a positive integer, got {max_steps!r}")
    if progress is not None and not callable(progress):
        raise AttitudeTypeError("progress: expected a callable progress(n_done, n_total, t)")
    if on_chunk is not None and not callable(on_chunk):
        raise AttitudeTypeError("on_chunk: expected a callable on_chunk(ds_chunk)")

    q0p, Q0p, correction = project_state(q0a, Q0a)
    if correction > PROJECTION_WARN:
        warnings.warn(
            f"initial state projected onto |q| = 1, q·Q = 0 (correction {correction:.2g})",
            stacklevel=2,
        )
    problem = Problem(
        body=body,
        potential=pot,
        params=pot._params(body.inertia),
        y0=np.concatenate([q0p, Q0p]),
        t=tt,
        kernels=pot._kernels(),
    )
    options = dict(
        rtol=rtol,
        atol=atol,
        dt=dt,
        order=int(order),
        max_step=max_step,
        max_steps=int(max_steps),
        progress=progress,
        chunk=chunk,
        **extra,
    )
    streaming = on_chunk is not None and form is None and getattr(runner, "streams", False)
    if on_chunk is not None:
        options["chunk"] = chunk = 4096 if chunk is None else chunk
    if streaming:
        chunk_attrs = {"method": method, "formulation": formulation}

        def emit(first: int, y: np.ndarray) -> None:
            on_chunk(finish_dataset(problem, y, chunk_attrs, first=first))

        result = runner(problem, **options, on_chunk=emit)
    elif form is None:
        result = runner(problem, **options)
    else:
        # The formulation converts the canonical initial state to its own variables, integrates
        # its equations with the same method, and converts the samples back to (q, Q).
        result = form.run(problem, method=method, runner=runner, **options)

    attrs: dict[str, Any] = {
        "method": method,
        "formulation": formulation,
        "initial_projection": float(correction),
        **{k: (np.int64(v) if isinstance(v, int) else v) for k, v in result.stats.items()},
    }
    ds = finish_dataset(problem, result.y, attrs, first=result.first)
    if on_chunk is not None and not streaming:  # hand the finished samples out in chunks
        for i in range(0, ds.sizes["time"], int(chunk)):
            on_chunk(ds.isel(time=slice(i, i + int(chunk))))
    if result.status != _rk.SUCCESS:
        n = result.first + result.y.shape[0]
        t_fail = result.t_stop
        if t_fail is None:
            t_fail = float(tt[n - 1]) if n else float(tt[0])
        raise PropagationError(
            f"propagation stopped at t = {t_fail!r}: {result.message} "
            f"({n} of {tt.shape[0]} output samples computed; "
            + ("they went to on_chunk)" if streaming else "they are in .partial)"),
            time=t_fail,
            partial=ds,
        )
    return ds


def finish_dataset(
    problem: Problem, y: np.ndarray, attrs: dict[str, Any], first: int = 0
) -> xr.Dataset:
    """Diagnostics and Dataset for the states ``y`` at ``problem.t[first : first + len(y)]``."""
    n = y.shape[0]
    t = problem.t[first : first + n]
    diag = np.empty((n, 13))
    if n:
        if problem.kernels is None:
            _dyn.diagnostics_builtin(t, y, problem.params, diag)
        else:
            _dyn.user_diagnostics(problem.kernels[1])(t, y, problem.params, diag)
    if not problem.potential.has_potential:
        attrs = {**attrs, "energy_note": "potential unknown: energy is the kinetic energy only"}
    return build_dataset(t, y, diag, problem.body, problem.potential, attrs)
