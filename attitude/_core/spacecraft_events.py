"""Events of a spacecraft run: the gyrostat through held commands, its orbit given or in the state.

The hooks of :func:`attitude._core.holds.holds_run` (``EV_BEGIN``, ``EV_ROOM``, ``EV_LOCATE``),
written against the event function ``event(j, t, q, ω, evd)`` of the entry points
(:mod:`attitude._core.events`: the built-in ones, or a user module's). The event arrays travel
as one tuple ``ev = (evd, evs, ev_count, rec_t, rec_k, rec_y, scr)`` (layouts in
:mod:`attitude._core.events`; ``scr`` (7, max(n, n_events, 6)) the locator's scratch, allocated
by the caller: the hold driver compiles without reference counting). Events are data: a run
without events passes ``evd`` with n = 0 (nothing is evaluated, not even the dense output) to
the same compiled driver.

At a state y = (q, Q, h[, r, v, m]) an event sees the attitude q and the gyrostat's body rates
ω = M (g − ℓ) (:func:`attitude._core.actuators.state_rate`), and, when the orbit is in the
state, its orbit: the event data's copies of the orbit (eclipse, the Sun's direction, the
orbit's frames) are live orbits written from y before g is evaluated
(:func:`attitude._core.coupled.coupled_events`). Location is that of the open-loop DOP853
driver (:func:`attitude._core.events.locate_in_step`): g sampled on each step's dense output,
sign changes refined by Brent's method; no step straddles a hold boundary, where the state is
continuous and only the commands jump.
"""

from __future__ import annotations

import numpy as np

from orbit._rk import WORK
from orbit._shared_jit import jit_generic

from .actuators import SC, state_rate
from .coupled import COUPLED, coupled_events
from .events import EV, EVS, locate_in_step, reset_state


def no_events() -> np.ndarray:
    """The event data of a run without events (n = 0, one sample a step): what the drivers
    get in its place."""
    evd = np.zeros(EV.SIZE)
    evd[EV.NSUB] = 1.0
    return evd


@jit_generic
def spacecraft_event_at(event, j, t, y, P, evd):
    """g_j at the spacecraft state ``y`` (``P = (params, sc)``)."""
    sc = P[1]
    co = int(sc[SC.COUPLED])
    if co >= 0 and sc[co + COUPLED.N_EV] > 0.0:
        coupled_events(sc, co, evd, t, y)
    _, om = state_rate(sc, y)
    return event(j, t, y[0:4], om, evd)


@jit_generic
def spacecraft_events_begin_with(event, P, t, y, ev):
    """Reset the event state and take g at the run's start."""
    evd, evs, ev_count = ev[0], ev[1], ev[2]
    reset_state(evs, ev_count)
    for j in range(int(evd[EV.N])):
        evs[j, EVS.G] = spacecraft_event_at(event, j, t, y, P, evd)


@jit_generic
def spacecraft_events_room(ev):
    """Whether the record buffers hold every occurrence one more step can bring."""
    evd, ev_count, rec_t = ev[0], ev[2], ev[3]
    cap = rec_t.shape[0]
    return cap == 0 or cap - ev_count[0] >= int(evd[EV.N]) * int(evd[EV.NSUB])


@jit_generic
def spacecraft_locate_with(rhs, event, P, work, tstate, counters, ev):
    """The events of the step just accepted: ``(stopped, t_stop, state at t_stop)``."""
    evd, evs, ev_count, rec_t, rec_k, rec_y, scr = ev
    if evd[EV.N] == 0.0:  # a run without events: not even the dense output
        return False, tstate[0], work[WORK.Y]
    stopped, t_stop = locate_in_step(
        rhs, spacecraft_event_at, event, P, evd, evs, ev_count, rec_t, rec_k, rec_y, work,
        tstate, counters, scr,
    )  # fmt: skip
    return stopped, t_stop, scr[0]
