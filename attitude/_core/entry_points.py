"""Compiled entry points: every integrator and evaluation loop, for one torque model.

This module is written against five module globals, the model:

``torque(q, w, t, params) -> (τ1, τ2, τ3)``
    body-frame torque at the unit attitude ``q``, body angular velocity ``w`` (a 3-tuple) and
    time ``t``;
``potential(q, t, params) -> U``
    its potential energy (the sum over the terms that have one);
``term_torque(j, q, w, t, params)``, ``n_terms(params)``
    the torque of each term of a sum of models, for the per-model torque output;
``event(j, t, q, w, evd) -> g``
    event function j of the event data ``evd`` (:mod:`attitude._core.events`): the built-in
    ones here, plus the user's g(t, q, ω) in a user module.

Here they are the built-in models (:mod:`attitude._core.potentials`: one kind switch over
parameter vectors), so every function below is cached on disk with the package and a fresh
process integrates without compiling.

For a user model (``CustomPotential``, ``CustomTorque``) :mod:`attitude._user_kernels` writes a
copy of this file into the user cache directory with the block between the ``model`` markers
replaced by the user's kernels, one module per model, named after a hash of the user's source:
the same entry points, cached there, so the package's cache never holds a user's code and a
user model compiles once per change of its source file, not once per process.

Why whole entry points and not a function argument: numba cannot cache a function compiled
for a *function-typed argument* without recording the caller's function type in the cache
index (which then fails to load in any process where that function's module is missing). The
generic loops (``canonical_rhs_with``, ``composition_run``, ...) therefore take the model as an
argument but are never compiled on their own (``jit_generic``: inlined, never cached); they
are inlined here, where the model is a module global. The DOP853 driver, the largest, is not
inlined (numba's inliner deep-copies it, a second of a cold start): it reads its right-hand
side from a global, and ``rebind`` compiles a copy of it per right-hand side of this module.

Every import below is absolute, so the file also works as the template of a user module.

For the built-in models (``REFCOUNT = False``) the hot loops (DOP853 on eq. 7, its right-hand
side, the diagnostics, the ensemble member) are compiled without numba's reference counting
(``_nrt=False``, which also applies to the model kernels they call): nothing there allocates
or returns an array, and the atomic reference-count updates of their array views (rows of the
work array, slices of the state and of ``params``) took ~40 % of a DOP853 run.
"""

from __future__ import annotations

from attitude._core.actuators import SC
from attitude._core.coupled import COUPLED, live_environment
from attitude._core.diagnostics import samples_with
from attitude._core.dynamics import (
    canonical_rhs_with,
    diagnostics_with,
    term_torques_at_rates_with,
    term_torques_with,
)
from attitude._core.ensemble import member_run
from attitude._core.events import (
    builtin_event,
    composition_events_run,
    dop853_events_run,
    event_values_with,
    member_events_run,
)
from attitude._core.formulations import (
    euler_angles_rhs_with,
    euler_equations_rhs_with,
    schwab_rhs_with,
)
from attitude._core.fsw import fsw_boundary_inline  # noqa: F401 (bound by name)
from attitude._core.gyrostat import spacecraft_diagnostics_row, spacecraft_rhs_with
from attitude._core.holds import holds_run, schedule_boundary  # noqa: F401 (bound by name)
from attitude._core.potentials import (
    builtin_exerts_torque,
    builtin_n_terms,
    builtin_potential,
    builtin_term_torque,
    builtin_torque,
)
from attitude._core.spacecraft_events import (
    spacecraft_events_begin_with,
    spacecraft_events_room,  # noqa: F401 (bound by name)
    spacecraft_locate_with,
)
from attitude._core.splitting import apply_stage, composition_run
from attitude._core.taylor_gyrostat import gyrostat_step_inline, taylor_holds_run  # noqa: F401
from orbit._rk import dop853_run
from orbit._shared_jit import jit, rebind
from orbit._state_kernels import orbit_sample as _any_orbit_sample

# --- model: begin (replaced in user modules) ---
# The built-in models allocate nothing: their hot loops compile without reference counting
# (user modules keep it: a user's torque may allocate, e.g. the complex-step derivative).
REFCOUNT = False
torque = builtin_torque
potential = builtin_potential
term_torque = builtin_term_torque
n_terms = builtin_n_terms
event = builtin_event
# --- model: end ---


# Evaluation ----------------------------------------------------------------------------------


@jit
def evaluate(q, w, t, params, tau_out, u_out):
    """Torque ``tau_out`` (m, 3) and potential ``u_out`` (m,) at attitudes ``q`` (m, 4), body
    angular velocities ``w`` (m, 3) and times ``t`` (m,)."""
    for k in range(q.shape[0]):
        tau = torque(q[k], (w[k, 0], w[k, 1], w[k, 2]), t[k], params)
        tau_out[k, 0] = tau[0]
        tau_out[k, 1] = tau[1]
        tau_out[k, 2] = tau[2]
        u_out[k] = potential(q[k], t[k], params)


@jit(_nrt=REFCOUNT)
def diagnostics(t, y, params, out):
    """Diagnostics of canonical states ``y`` (m, 8) into ``out`` (m, 13): see ``dynamics``."""
    diagnostics_with(potential, t, y, params, out)


@jit
def term_torques(t, y, params, out):
    """Torque of every term (m, n_terms + 1, 3; the last row their sum) at canonical states."""
    term_torques_with(term_torque, n_terms(params), t, y, params, out)


#: The orbit of the model's Dataset variables, looked up once per sample by :func:`samples`
#: (``orbit._state_kernels.orbit_sample``; attitude._core.models binds the kernel of the
#: orbit's type, or none for a model without an orbit).
orbit_sample = _any_orbit_sample


@jit(_nrt=REFCOUNT)
def potential_at(q, t, params, orb):
    """The model's potential energy given the orbit sample ``orb`` (here unused: the model
    looks its orbit up itself; the gravity gradient alone reads it from ``orb``)."""
    return potential(q, t, params)


@jit(_nrt=REFCOUNT)
def term_torque_at(j, q, w, t, params, orb):
    """The torque of term ``j`` given the orbit sample ``orb`` (as :func:`potential_at`)."""
    return term_torque(j, q, w, t, params)


@jit(_nrt=REFCOUNT)
def samples(t, y, params, od, has_orbit, out, k0, k1):
    """Every per-sample variable of the result Dataset for the samples ``k0 .. k1 − 1``, in
    one pass, into the flat buffer ``out`` (layout in :mod:`attitude._core.diagnostics`;
    ``od`` the kernel data of the Dataset's orbit when ``has_orbit``)."""
    samples_with(
        potential_at, term_torque_at, orbit_sample, n_terms(params), t, y, params, od,
        has_orbit, out, k0, k1,
    )  # fmt: skip


# Canonical equations (Arribas et al. eq. 7) ----------------------------------------------------


@jit(_nrt=REFCOUNT)
def canonical_rhs(t, y, params, dydt):
    """Eq. 7 with the model's torque, written into ``dydt``."""
    canonical_rhs_with(torque, t, y, params, dydt)


#: DOP853 on eq. 7: :func:`orbit._rk.dop853_run` compiled with ``canonical_rhs`` as its
#: right-hand side (arguments ``params, y0, t0, t_out, y_out, work, tstate, counters, rtol,
#: atol, t_end, max_step, max_steps``; layouts in orbit._rk), without reference counting
#: for the built-in models (REFCOUNT).
dop853_canonical = rebind(
    dop853_run, globals(), "canonical", options={"_nrt": REFCOUNT}, RHS="canonical_rhs"
)


@jit
def composition(params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out, counters):
    """The splitting methods (:func:`attitude._core.splitting.composition_run`)."""
    return composition_run(
        apply_stage, torque, params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out,
        counters,
    )  # fmt: skip


@jit
def dop853_canonical_events(
    params, evd, evs, ev_count, rec_t, rec_k, rec_y, y0, t0, t_out, y_out, work, tstate,
    counters, rtol, atol, t_end, max_step, max_steps,
):  # fmt: skip
    """DOP853 on eq. 7 with events located on the dense output (:mod:`attitude._core.events`)."""
    return dop853_events_run(
        canonical_rhs, event, params, evd, evs, ev_count, rec_t, rec_k, rec_y, y0, t0, t_out,
        y_out, work, tstate, counters, rtol, atol, t_end, max_step, max_steps,
    )  # fmt: skip


@jit
def event_values(t, y, params, evd, out):
    """``out[k, j]``: event function j at the canonical states ``y[k]`` (m, 8) and times t."""
    event_values_with(event, t, y, params, evd, out)


@jit
def composition_events(
    params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out, counters,
    evd, evs, ev_count, rec_t, rec_k, rec_y,
):  # fmt: skip
    """The splitting methods with events (:func:`attitude._core.events.composition_events_run`)."""
    return composition_events_run(
        torque, event, params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out, counters,
        evd, evs, ev_count, rec_t, rec_k, rec_y,
    )  # fmt: skip


# The spacecraft with actuators (attitude.Spacecraft: a gyrostat in (q, Q, h)) --------------------


@jit(_nrt=REFCOUNT)
def spacecraft_rhs(t, y, P, dydt):
    """The gyrostat's eq. 7 with the model's torque and the actuators' (``P = (params, sc)``)."""
    spacecraft_rhs_with(torque, builtin_exerts_torque, t, y, P, dydt)


@jit(inline="always")
def spacecraft_events_begin(P, t, y, ev):
    """The event hooks of the hold driver with the model's events
    (:mod:`attitude._core.spacecraft_events`)."""
    spacecraft_events_begin_with(event, P, t, y, ev)


@jit(inline="always")
def spacecraft_locate(rhs, P, work, tstate, counters, ev):
    return spacecraft_locate_with(rhs, event, P, work, tstate, counters, ev)


_EVENT_HOOKS = dict(
    EV_BEGIN="spacecraft_events_begin", EV_ROOM="spacecraft_events_room",
    EV_LOCATE="spacecraft_locate",
)  # fmt: skip

#: DOP853 through held commands (:func:`attitude._core.holds.holds_run`) on the gyrostat, its
#: events as data (its last argument the event arrays, none for a run without events: one
#: compiled driver for both).
dop853_spacecraft = rebind(
    holds_run,
    globals(),
    "spacecraft",
    options={"_nrt": REFCOUNT, "nogil": True},
    RHS="spacecraft_rhs",
    BOUNDARY="schedule_boundary",
    **_EVENT_HOOKS,
)


#: The same, the commands from the flight software at its ticks (attitude._core.fsw).
dop853_spacecraft_fsw = rebind(
    holds_run,
    globals(),
    "spacecraft_fsw",
    options={"_nrt": REFCOUNT, "nogil": True},
    RHS="spacecraft_rhs",
    BOUNDARY="fsw_boundary_inline",
    **_EVENT_HOOKS,
)

#: The gyrostat's Taylor integration (:mod:`attitude._core.taylor_gyrostat`) with the flight
#: software as its command source (in a user module: with the user's compiled step).
taylor_spacecraft_fsw = rebind(
    taylor_holds_run,
    globals(),
    "fsw",
    options={"_nrt": REFCOUNT},
    BOUNDARY="fsw_boundary_inline",
    gyrostat_step="gyrostat_step_inline",
)

#: The same under an open-loop schedule.
taylor_spacecraft = rebind(
    taylor_holds_run,
    globals(),
    "spacecraft",
    options={"_nrt": REFCOUNT},
    BOUNDARY="schedule_boundary",
)


@jit(_nrt=REFCOUNT)
def spacecraft_diagnostics(t, y, params, sc, out):
    """Diagnostics of gyrostat states ``y`` (m, 8 + n_w) into ``out`` (m, 13)."""
    for k in range(y.shape[0]):
        U = potential(y[k, 0:4], t[k], params)
        spacecraft_diagnostics_row(y, k, U, params, sc, out)


@jit
def term_torques_at_rates(t, y, rates, params, out):
    """:func:`term_torques` at given body angular velocities ``rates`` (m, 3)."""
    term_torques_at_rates_with(term_torque, n_terms(params), t, y, rates, params, out)


@jit
def term_torques_in_live_environment(t, y, qQ, rates, params, sc, out):
    """:func:`term_torques_at_rates` of a coupled run's samples whose drag and radiation models
    read the environment at the integrated state: each sample's (``y`` its state row) is
    written into their live words before its torques."""
    co = int(sc[SC.COUPLED])
    iy = int(sc[co + COUPLED.IY])
    nt = n_terms(params)
    for k in range(qQ.shape[0]):
        live_environment(sc, co, params, t[k], y[k], iy)
        term_torques_at_rates_with(term_torque, nt, t[k : k + 1], qQ[k : k + 1],
                                   rates[k : k + 1], params, out[k : k + 1])  # fmt: skip


# Other formulations (attitude.formulations) ----------------------------------------------------


@jit
def euler_angles_rhs(t, y, params, dydt):
    """3-1-3 Euler-angle Hamiltonian (Arribas et al. eq. 10)."""
    euler_angles_rhs_with(torque, t, y, params, dydt)


#: DOP853 on the Euler-angle equations (orbit._rk.dop853_run with euler_angles_rhs).
dop853_euler_angles = rebind(dop853_run, globals(), "euler_angles", RHS="euler_angles_rhs")


@jit
def schwab_rhs(t, y, params, dydt):
    """Schwab's Euler-parameter equations (eqs. 19-25)."""
    schwab_rhs_with(torque, t, y, params, dydt)


#: DOP853 on Schwab's equations (orbit._rk.dop853_run with schwab_rhs).
dop853_schwab = rebind(dop853_run, globals(), "schwab", RHS="schwab_rhs")


@jit
def euler_equations_rhs(t, y, params, dydt):
    """Euler's equations with the quaternion kinematics."""
    euler_equations_rhs_with(torque, t, y, params, dydt)


#: DOP853 on Euler's equations (orbit._rk.dop853_run with euler_equations_rhs).
dop853_euler_equations = rebind(dop853_run, globals(), "euler_equations", RHS="euler_equations_rhs")


# Ensembles (attitude.ensemble; array layout in attitude._core.ensemble) ------------------------


@jit(nogil=True, _nrt=REFCOUNT)
def ensemble_member(
    i, params, y0, t, y_out, diag, work, tstate, counters, status, n_done,
    rtol, atol, max_step, max_steps, budget,
):  # fmt: skip
    """Member ``i`` (fresh, or on from its pause) for ``budget`` steps: the body both drivers
    call."""
    member_run(
        dop853_canonical, diagnostics, i, params, y0, t, y_out, diag, work, tstate, counters,
        status, n_done, rtol, atol, max_step, max_steps, budget,
    )  # fmt: skip


@jit(nogil=True, _nrt=REFCOUNT)
def ensemble_serial(
    params, y0, t, y_out, diag, work, tstate, counters, status, n_done,
    rtol, atol, max_step, max_steps, budget,
):  # fmt: skip
    """All members one after the other, GIL released (what a Dask worker thread runs)."""
    for i in range(y0.shape[0]):
        ensemble_member(
            i, params, y0, t, y_out, diag, work, tstate, counters, status, n_done,
            rtol, atol, max_step, max_steps, budget,
        )  # fmt: skip


@jit(nogil=True)
def ensemble_events_member(
    i, params, evd, evs, y0, t, y_out, diag, work, tstate, counters, status, n_done,
    rtol, atol, max_step, max_steps, budget,
):  # fmt: skip
    """Member ``i`` with events (first time and count of each in ``evs[i]``)."""
    member_events_run(
        dop853_canonical_events, diagnostics, i, params, evd, evs, y0, t, y_out, diag, work,
        tstate, counters, status, n_done, rtol, atol, max_step, max_steps, budget,
    )  # fmt: skip


@jit(nogil=True)
def ensemble_events_serial(
    params, evd, evs, y0, t, y_out, diag, work, tstate, counters, status, n_done,
    rtol, atol, max_step, max_steps, budget,
):  # fmt: skip
    """All members with events, one after the other, GIL released."""
    for i in range(y0.shape[0]):
        ensemble_events_member(
            i, params, evd, evs, y0, t, y_out, diag, work, tstate, counters, status, n_done,
            rtol, atol, max_step, max_steps, budget,
        )  # fmt: skip
