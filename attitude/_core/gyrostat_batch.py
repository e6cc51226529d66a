"""The Taylor method on LANES spacecraft with wheels at once (structure of arrays, SIMD).

:mod:`attitude._core.taylor_gyrostat` integrates one gyrostat through held commands; here a
*batch* of LANES members (:data:`attitude._core.lanes.LANES`, the lane count of
:mod:`attitude._core.taylor_batch`) shares one coefficient table ``cf[k, column, lane]``, so the
automatic-differentiation recurrences of the gyrostat (the Cauchy products, ω = M (g − ℓ), the
wheels' momenta and the built-in torque's series) run as SIMD instructions over the members
(:func:`gyrostat_coefficients_lanes`, the lane-wise mirror of
:func:`attitude._core.taylor_gyrostat.gyrostat_coefficients`, statement for statement:
multiply–adds as explicit fused operations, :mod:`attitude._core.fma`, nothing contracted or
reassociated).

Everything else is per member, by the single run's own kernels on the member's own rows of the
arrays of :mod:`attitude._core.spacecraft_ensemble`: the hold boundaries (the open-loop schedule
or the flight software's ticks, :data:`BOUNDARY`), the output samples and their records, the
first row of a step and its friction pieces (:func:`attitude._core.taylor_gyrostat.
step_prepare`) and the step from the table (:func:`attitude._core.taylor_gyrostat.
step_complete`: the order, the radius, a friction kink, the new state). Between the two halves
of a step the lane's orders 0..p of the state's blocks (q, g, h and Ω) are copied from the
batch table into the member's own table, where the second half reads them. So every lane keeps
its own time, holds, ticks and step sizes, and stops the recurrences at its own order (the
order follows the hold: the lanes' recurrences run until every lane has the order it needs); a
member computes, operation for operation, what it computes alone with
``propagate(spacecraft, ..., method="taylor")``, and its results are bit for bit those of its
single run (tests/test_ensemble_closed_loop.py).

Lanes hold no state between steps: a lane takes any member that needs a step, and a member
paused at its step budget, or at full tick records, goes on in whatever lane is free when it is
called again. A lane without a member idles (its recurrences run on stale numbers, unused).
"""

from __future__ import annotations

import math

import numpy as np

from orbit import _state_kernels as _SK
from orbit._layout import Field, layout
from orbit._rk import SUCCESS, TOO_MANY_STEPS
from orbit._shared_jit import jit, jit_generic, rebind, slp_vectorized

from . import lanes as V
from .actuators import (
    SC,
    WHEEL,
)
from .ensemble import NOT_STARTED, RUNNING, member_begin
from .fsw import fsw_boundary  # noqa: F401 (bound by name)
from .holds import (
    BOUNDARY_DONE,
    BOUNDARY_NEEDS_COMMANDS,
    HS,
    NEEDS_COMMANDS,
    RECORDS_FULL,
    record,
    schedule_boundary,
)
from .lanes import LANES
from .potentials import (
    HEAVY_TOP,
    KIND_GRAVITY_GRADIENT,
    KIND_HEAVY_TOP,
    MODEL,
)
from .spacecraft_ensemble import (  # noqa: F401 (fsw_ctl bound by name)
    RECORDS_WAIT,
    fsw_ctl,
    member_stop,
    schedule_ctl,
)
from .taylor import (
    COL,
    RECIPROCALS,
    WORK_ROWS,
    Y,
    set_order,
)
from .taylor_batch import _torque_series_lanes
from .taylor_gyrostat import (
    CH,
    ORDER_MARGIN,
    PIECE_FREE,
    PMIN,
    ROUNDOFF,
    TS,
    _block3,
    _block4,
    _blockh,
    _piece_coefficients,
    dense_state,
    order_enough,
    order_from_tolerance,
    step_complete,
    step_prepare,
)

__all__ = ["LANES", "fsw_group_run", "new_workspaces", "schedule_group_run"]

# Per-lane constants of the recurrences (rows of ``cst``, one column per lane).
GCONST = layout(
    "per-lane constants",
    m=Field(9, "", "M = Ĩ⁻¹ (row-major)", (3, 3)),
    n=Field(1, "", "n = |q|²"),
    w=Field(1, "N", "heavy top: weight"),
    cm=Field(3, "m", "heavy top: centre of mass"),
    mu=Field(1, "km3/s2", "gravity gradient: μ"),
    d=Field(3, "", "gravity gradient: I3 − I2, I1 − I3, I2 − I1"),
    tau=Field(3, "N m", "the thrusters' held torque"),
    wheel=Field(0, "", "per wheel: GWHEEL"),
)
GWHEEL = layout(
    "per-lane wheel constants",
    axis=3,
    invj=Field(1, "", "1/J"),
    c1=Field(1, "", "friction slope c₁"),
    c0=Field(1, "", "friction offset c₀"),
    u=Field(1, "N m", "motor torque"),
)
# Per-lane numbers of the step's order control (columns of ``lf``).
LF = layout(
    "order control",
    d=Field(1, "", "the longest step d"),
    tq=Field(1, "", "ORDER_MARGIN rtol S_q"),
    tg=Field(1, "", "ORDER_MARGIN rtol S_g"),
    th=Field(1, "", "ORDER_MARGIN rtol S_h"),
    dk=Field(1, "", "d^k"),
    n=Field(1, "", "n of the step"),
    c=Field(1, "", "c of the step"),
    ro=Field(3, "", "ROUNDOFF S_b (q, g, h)"),
    t=Field(6, "", "the blocks' terms at the last two orders (q, g, h: t_{k−1}, t_{k−2} each)"),
)
# Per-lane integers (columns of ``lint``).
GLANE = layout(
    "lane state",
    member=Field(1, "", "the member in the lane (−1: none)"),
    k=Field(1, "", "its next output sample"),
    limit=Field(1, "", "its step limit in this call"),
    stop=Field(1, "", "the order its recurrences stop at (−1: not yet)"),
    step=Field(1, "", "1: it takes a step in this round"),
)


def n_constants(nw: int) -> int:
    """Rows of ``cst`` for ``nw`` wheels."""
    return GCONST.WHEEL + GWHEEL.SIZE * nw


def new_workspaces(groups: int, nw: int) -> tuple[np.ndarray, ...]:
    """The arrays of ``groups`` batch integrators: ``(cf, cst, lf, lint)``, one row each (made
    by the caller: the group runs without numba's reference counting)."""
    return (
        np.zeros((groups, WORK_ROWS, COL.SIZE + 2 * nw, LANES)),
        np.zeros((groups, GCONST.WHEEL + GWHEEL.SIZE * nw, LANES)),
        np.zeros((groups, LANES, LF.SIZE)),
        np.zeros((groups, LANES, GLANE.SIZE), dtype=np.int64),
    )


# ------------------------------------------------------------------------------------------------
# the recurrences on lane tuples
# ------------------------------------------------------------------------------------------------


@jit(inline="always")
def _lane_block3(cf, k, c0, lane):
    """:func:`attitude._core.taylor_gyrostat._block3` of ``lane`` (the same expression)."""
    return max(abs(cf[k, c0, lane]), max(abs(cf[k, c0 + 1, lane]), abs(cf[k, c0 + 2, lane])))


@jit(inline="always")
def _lane_block4(cf, k, c0, lane):
    """:func:`attitude._core.taylor_gyrostat._block4` of ``lane``."""
    return max(
        max(abs(cf[k, c0, lane]), abs(cf[k, c0 + 1, lane])),
        max(abs(cf[k, c0 + 2, lane]), abs(cf[k, c0 + 3, lane])),
    )


@jit(inline="always")
def _lane_blockh(cf, k, nw, lane):
    """:func:`attitude._core.taylor_gyrostat._blockh` of ``lane``."""
    m = 0.0
    for j in range(nw):
        a = abs(cf[k, CH + j, lane])
        if a > m:
            m = a
    return m


@slp_vectorized
@jit
def gyrostat_coefficients_lanes(cf, p, kind, nw, cst, lf, lint):
    """Rows 1.. of the table of every lane taking a step (``lint[:, GLANE.STEP]``) from its row 0:
    the recurrences of :func:`attitude._core.taylor_gyrostat.gyrostat_coefficients`, statement
    for statement, on lane tuples. Each lane stops at its own order (that function's test, on
    its own numbers): its order in ``lint[:, GLANE.STOP]``, its rows 0..order (ω and Ω also at
    that order) as that function fills them; the recurrences run until every lane is done."""
    Z = V.ZERO
    m00 = V.load_row(cst, GCONST.M)
    m01 = V.load_row(cst, GCONST.M + 1)
    m02 = V.load_row(cst, GCONST.M + 2)
    m10 = V.load_row(cst, GCONST.M + 3)
    m11 = V.load_row(cst, GCONST.M + 4)
    m12 = V.load_row(cst, GCONST.M + 5)
    m20 = V.load_row(cst, GCONST.M + 6)
    m21 = V.load_row(cst, GCONST.M + 7)
    m22 = V.load_row(cst, GCONST.M + 8)
    n = V.load_row(cst, GCONST.N)
    mW = V.neg(V.load_row(cst, GCONST.W))
    cx = V.load_row(cst, GCONST.CM)
    cy = V.load_row(cst, GCONST.CM + 1)
    cz = V.load_row(cst, GCONST.CM + 2)
    mu = V.load_row(cst, GCONST.MU)
    mu3 = V.smul(3.0, mu)
    mmu = V.neg(mu)
    D0 = V.load_row(cst, GCONST.D)
    D1 = V.load_row(cst, GCONST.D + 1)
    D2 = V.load_row(cst, GCONST.D + 2)
    tau0 = V.load_row(cst, GCONST.TAU)
    tau1 = V.load_row(cst, GCONST.TAU + 1)
    tau2 = V.load_row(cst, GCONST.TAU + 2)
    for lane in range(LANES):
        lint[lane, GLANE.STOP] = -1 if lint[lane, GLANE.STEP] != 0 else 0
        lf[lane, LF.DK] = 1.0
    CO = CH + nw
    k = 0
    while True:
        # ℓ[k], ω[k] = M (g[k] − ℓ[k]), Ω_j[k]
        l0 = l1 = l2 = Z
        for j in range(nw):
            h = V.load(cf, k, CH + j)
            r = GCONST.WHEEL + GWHEEL.SIZE * j
            l0 = V.fma(h, V.load_row(cst, r), l0)
            l1 = V.fma(h, V.load_row(cst, r + 1), l1)
            l2 = V.fma(h, V.load_row(cst, r + 2), l2)
        e0 = V.sub(V.load(cf, k, COL.G), l0)
        e1 = V.sub(V.load(cf, k, COL.G + 1), l1)
        e2 = V.sub(V.load(cf, k, COL.G + 2), l2)
        w0 = V.fma(m02, e2, V.fma(m01, e1, V.mul(m00, e0)))
        w1 = V.fma(m12, e2, V.fma(m11, e1, V.mul(m10, e0)))
        w2 = V.fma(m22, e2, V.fma(m21, e1, V.mul(m20, e0)))
        V.store(cf, k, COL.W, w0)
        V.store(cf, k, COL.W + 1, w1)
        V.store(cf, k, COL.W + 2, w2)
        for j in range(nw):
            r = GCONST.WHEEL + GWHEEL.SIZE * j
            aw = V.fma(
                V.load_row(cst, r + 2),
                w2,
                V.fma(V.load_row(cst, r + 1), w1, V.mul(V.load_row(cst, r), w0)),
            )
            V.store(
                cf,
                k,
                CO + j,
                V.fma(V.load(cf, k, CH + j), V.load_row(cst, r + GWHEEL.INVJ), V.neg(aw)),
            )
        if k == p:
            break
        done = True
        for lane in range(LANES):
            if lint[lane, GLANE.STOP] < 0:
                done = False
        if done:
            break
        # Cauchy products over j = k..0 (ω[k] last), the cross product in two chains
        b00 = b10 = b20 = b30 = Z
        b01 = b11 = b21 = b31 = Z
        b02 = b12 = b22 = b32 = Z
        p0 = p1 = p2 = Z
        r0 = r1 = r2 = Z
        for i in range(k + 1):
            j = k - i
            q0 = V.load(cf, j, 0)
            q1 = V.load(cf, j, 1)
            q2 = V.load(cf, j, 2)
            q3 = V.load(cf, j, 3)
            o0 = V.load(cf, i, COL.W)
            o1 = V.load(cf, i, COL.W + 1)
            o2 = V.load(cf, i, COL.W + 2)
            g0 = V.load(cf, j, COL.G)
            g1 = V.load(cf, j, COL.G + 1)
            g2 = V.load(cf, j, COL.G + 2)
            b00 = V.fma(V.neg(q1), o0, b00)
            b10 = V.fma(q0, o0, b10)
            b20 = V.fma(q3, o0, b20)
            b30 = V.fma(V.neg(q2), o0, b30)
            b01 = V.fma(V.neg(q2), o1, b01)
            b11 = V.fma(V.neg(q3), o1, b11)
            b21 = V.fma(q0, o1, b21)
            b31 = V.fma(q1, o1, b31)
            b02 = V.fma(V.neg(q3), o2, b02)
            b12 = V.fma(q2, o2, b12)
            b22 = V.fma(V.neg(q1), o2, b22)
            b32 = V.fma(q0, o2, b32)
            p0 = V.fma(g1, o2, p0)
            r0 = V.fma(g2, o1, r0)
            p1 = V.fma(g2, o0, p1)
            r1 = V.fma(g0, o2, r1)
            p2 = V.fma(g0, o1, p2)
            r2 = V.fma(g1, o0, r2)
        p0 = V.sub(p0, r0)
        p1 = V.sub(p1, r1)
        p2 = V.sub(p2, r2)
        inv = RECIPROCALS[k]
        hh = 0.5 * inv
        V.store(cf, k + 1, 0, V.smul(hh, V.add(V.add(b00, b01), b02)))
        V.store(cf, k + 1, 1, V.smul(hh, V.add(V.add(b10, b11), b12)))
        V.store(cf, k + 1, 2, V.smul(hh, V.add(V.add(b20, b21), b22)))
        V.store(cf, k + 1, 3, V.smul(hh, V.add(V.add(b30, b31), b32)))
        t0, t1, t2 = _torque_series_lanes(cf, k, kind, mW, cx, cy, cz, mu3, mmu, D0, D1, D2)
        if k == 0:
            t0 = V.add(t0, tau0)
            t1 = V.add(t1, tau1)
            t2 = V.add(t2, tau2)
        V.store(cf, k + 1, COL.G, V.smul(inv, V.fma(n, t0, p0)))
        V.store(cf, k + 1, COL.G + 1, V.smul(inv, V.fma(n, t1, p1)))
        V.store(cf, k + 1, COL.G + 2, V.smul(inv, V.fma(n, t2, p2)))
        for j in range(nw):
            r = GCONST.WHEEL + GWHEEL.SIZE * j
            v = V.mul(V.neg(V.load_row(cst, r + GWHEEL.C1)), V.load(cf, k, CO + j))
            if k == 0:
                v = V.add(v, V.sub(V.load_row(cst, r + GWHEEL.U), V.load_row(cst, r + GWHEEL.C0)))
            V.store(cf, k + 1, CH + j, V.smul(inv, v))
        k += 1
        # each lane's own test: the last two terms over its d below its tolerances
        for lane in range(LANES):
            if lint[lane, GLANE.STOP] >= 0:
                continue
            dk = lf[lane, LF.DK] * lf[lane, LF.D]
            lf[lane, LF.DK] = dk
            tq = _lane_block4(cf, k, 0, lane) * dk
            tg = _lane_block3(cf, k, COL.G, lane) * dk
            th = _lane_blockh(cf, k, nw, lane) * dk
            ok = (
                order_enough(tq, lf[lane, LF.T], lf[lane, LF.T + 1], lf[lane, LF.TQ],
                             lf[lane, LF.RO])
                and order_enough(tg, lf[lane, LF.T + 2], lf[lane, LF.T + 3], lf[lane, LF.TG],
                                 lf[lane, LF.RO + 1])
                and order_enough(th, lf[lane, LF.T + 4], lf[lane, LF.T + 5], lf[lane, LF.TH],
                                 lf[lane, LF.RO + 2])
            )  # fmt: skip
            if ok and k >= PMIN:
                lint[lane, GLANE.STOP] = k
            for b, t in enumerate((tq, tg, th)):
                lf[lane, LF.T + 2 * b + 1] = lf[lane, LF.T + 2 * b]
                lf[lane, LF.T + 2 * b] = t
    for lane in range(LANES):
        if lint[lane, GLANE.STOP] < 0:
            lint[lane, GLANE.STOP] = p


# ------------------------------------------------------------------------------------------------
# one lane: load a member's step, copy its table back
# ------------------------------------------------------------------------------------------------


@jit(inline="always")
def _load_lane(cf, cst, lf, lint, lane, params, sc, work, tstate, n, c, d, rtol, atol, nw):
    """Put the step of a member (its ``params`` row, spacecraft block ``sc``, table ``work``
    after :func:`~attitude._core.taylor_gyrostat.step_prepare`) into ``lane``."""
    for col in range(4):
        cf[0, col, lane] = work[0, col]
    for j in range(3):
        cf[0, COL.G + j, lane] = work[0, COL.G + j]
        cf[0, COL.A + j, lane] = work[0, COL.A + j]
        cf[0, COL.V + j, lane] = work[0, COL.V + j]
    for j in range(nw):
        cf[0, CH + j, lane] = work[0, CH + j]
    for r in range(9):
        cst[GCONST.M + r, lane] = sc[SC.MINV + r]
    cst[GCONST.N, lane] = n
    kind = int(params[MODEL.KIND])
    if kind == KIND_HEAVY_TOP:
        cst[GCONST.W, lane] = params[MODEL.KIND + HEAVY_TOP.WEIGHT]
        cst[GCONST.CM, lane] = params[MODEL.KIND + HEAVY_TOP.CM]
        cst[GCONST.CM + 1, lane] = params[MODEL.KIND + HEAVY_TOP.CM + 1]
        cst[GCONST.CM + 2, lane] = params[MODEL.KIND + HEAVY_TOP.CM + 2]
    elif kind == KIND_GRAVITY_GRADIENT:
        cst[GCONST.MU, lane] = params[MODEL.DATA + _SK.MU]
        cst[GCONST.D, lane] = params[2] - params[1]
        cst[GCONST.D + 1, lane] = params[0] - params[2]
        cst[GCONST.D + 2, lane] = params[1] - params[0]
    for j in range(3):
        cst[GCONST.TAU + j, lane] = sc[SC.TAU + j] + sc[SC.IDEAL + j]  # thrusters' + ideal control
    for j in range(nw):
        b = SC.WHEELS + j * WHEEL.SIZE
        r = GCONST.WHEEL + GWHEEL.SIZE * j
        cst[r, lane] = sc[b + WHEEL.AXIS]
        cst[r + 1, lane] = sc[b + WHEEL.AXIS + 1]
        cst[r + 2, lane] = sc[b + WHEEL.AXIS + 2]
        cst[r + GWHEEL.INVJ, lane] = sc[b + WHEEL.INVJ]
        c1, c0 = _piece_coefficients(sc, b, int(tstate[TS.SIZE + j]))
        cst[r + GWHEEL.C1, lane] = c1
        cst[r + GWHEEL.C0, lane] = c0
        cst[r + GWHEEL.U, lane] = sc[b + WHEEL.U]
    # the tolerances of gyrostat_coefficients' order test, from row 0
    floor = atol / rtol
    sq = max(_block4(work, 0, 0), floor)
    sg = max(_block3(work, 0, COL.G), floor)
    sh = max(_blockh(work, 0, nw), floor)
    lf[lane, LF.TQ] = ORDER_MARGIN * rtol * sq
    lf[lane, LF.TG] = ORDER_MARGIN * rtol * sg
    lf[lane, LF.TH] = ORDER_MARGIN * rtol * sh
    for b, sb in enumerate((sq, sg, sh)):
        lf[lane, LF.RO + b] = ROUNDOFF * sb
        lf[lane, LF.T + 2 * b] = sb  # the scale S_b before order 1 (as gyrostat_coefficients)
        lf[lane, LF.T + 2 * b + 1] = sb
    lf[lane, LF.D] = d
    lf[lane, LF.N] = n
    lf[lane, LF.C] = c
    lint[lane, GLANE.STEP] = 1


@jit(inline="always")
def _unload_lane(cf, lane, pu, work, nw):
    """The lane's orders 0..pu of q, g, h and Ω into the member's table (what
    :func:`~attitude._core.taylor_gyrostat.step_complete` reads)."""
    CO = CH + nw
    for k in range(pu + 1):
        for col in range(4):
            work[k, col] = cf[k, col, lane]
        for j in range(3):
            work[k, COL.G + j] = cf[k, COL.G + j, lane]
        for j in range(nw):
            work[k, CH + j] = cf[k, CH + j, lane]
            work[k, CO + j] = cf[k, CO + j, lane]


# ------------------------------------------------------------------------------------------------
# one group of members through one batch integrator
# ------------------------------------------------------------------------------------------------

#: The command source of a member (as :data:`attitude._core.holds.BOUNDARY`) and its ``ctl``
#: tuple from the source arrays (:mod:`attitude._core.spacecraft_ensemble`): the open-loop
#: schedule here; :data:`fsw_group` rebinds both to the flight software's.
BOUNDARY = schedule_boundary
CTL = schedule_ctl

#: Results of :func:`_advance`.
_NEEDS_STEP = -100


@jit_generic
def _advance(boundary, k, limit, n, params, sc, t, y_out, work, tstate, counters, ctl):
    """A member up to its next step (:func:`~attitude._core.taylor_gyrostat.taylor_holds_run`
    between two steps): its output samples from ``k`` on, its boundary (``boundary``, the
    command source). Returns (``_NEEDS_STEP`` or a final or pausing status, the next output
    sample)."""
    hs = ctl[0]
    m = t.shape[0]
    y = work[Y]
    nw = n - 8
    t_end = t[m - 1]
    P = (params, sc)
    while True:
        while k < m:
            to = t[k]
            tt = tstate[0]
            if to == tt:
                if hs[HS.PENDING] != 0.0:
                    break
                for j in range(n):
                    y_out[k, j] = y[j]
            elif counters[4] == 1 and to >= tstate[2] and tt > to:
                dense_state(work, tstate, to - tstate[2], y_out[k], nw)
            else:
                break
            record(sc, y_out[k], n)
            k += 1
        if hs[HS.PENDING] != 0.0:
            bs = boundary(P, y, tstate[0], t_end, ctl)
            if bs == BOUNDARY_NEEDS_COMMANDS:
                return NEEDS_COMMANDS, k
            if bs != BOUNDARY_DONE:
                return RECORDS_FULL, k
            hs[HS.PENDING] = 0.0
            continue
        if k == m:
            return SUCCESS, k
        if counters[0] >= limit:
            return TOO_MANY_STEPS, k
        return _NEEDS_STEP, k


@jit(inline="always")
def gyrostat_group(params, sc, sc_at, y0, t, y_out, work, tstate, counters, src, status,
                   n_done, rtol, atol, max_step, max_steps, budget, start, stop, cf, cst, lf,
                   lint):  # fmt: skip
    """Members ``start..stop-1`` through one batch integrator of LANES lanes (the workspace
    ``cf, cst, lf, lint``: a row of :func:`new_workspaces`), each for at most ``budget``
    steps. Inlined into the group runners (no reference counting: the views of the members'
    rows cost nothing there)."""
    m = t.shape[0]
    t_end = t[m - 1]
    n = y0.shape[1]
    nw = n - 8
    p = order_from_tolerance(rtol)
    kind = int(params[start, MODEL.KIND])
    for lane in range(LANES):
        lint[lane, GLANE.MEMBER] = -1
        lint[lane, GLANE.STEP] = 0
    nxt = start
    while True:
        stepping = 0
        for lane in range(LANES):
            lint[lane, GLANE.STEP] = 0
            while True:  # until the lane holds a member that takes a step (or none is left)
                i = lint[lane, GLANE.MEMBER]
                if i < 0:
                    if nxt >= stop:
                        break
                    i = nxt
                    nxt += 1
                    fresh = status[i] == NOT_STARTED
                    if status[i] == RECORDS_WAIT:  # given more rows
                        status[i] = RUNNING
                    runs, k0, limit = member_begin(
                        i, status, n_done, work, tstate, counters, max_steps, budget
                    )
                    if not runs:
                        continue
                    if fresh:  # taylor_holds_run's start
                        hs = CTL(i, src)[0]
                        w = work[i]
                        for j in range(n):
                            w[Y, j] = y0[i, j]
                        ts = tstate[i]
                        ts[0] = t[0]
                        ts[1] = 0.0
                        ts[2] = t[0]
                        set_order(ts, p)
                        for j in range(nw):
                            ts[TS.SIZE + j] = PIECE_FREE
                        hs[HS.NEXT] = 0.0
                        hs[HS.PENDING] = 1.0
                        hs[HS.HOLD_END] = math.nan
                        counters[i, 3] = 1
                        counters[i, 4] = 0
                    lint[lane, GLANE.MEMBER] = i
                    lint[lane, GLANE.K] = k0
                    lint[lane, GLANE.LIMIT] = limit
                ctl = CTL(i, src)
                blk = sc[sc_at[i] : sc_at[i + 1]]
                st, k = _advance(BOUNDARY, lint[lane, GLANE.K], lint[lane, GLANE.LIMIT], n,
                                 params[i], blk, t, y_out[i], work[i], tstate[i], counters[i],
                                 ctl)  # fmt: skip
                lint[lane, GLANE.K] = k
                if st == _NEEDS_STEP:
                    st, nn, cc, d = step_prepare(params[i], blk, work[i], tstate[i],
                                                 ctl[0][HS.SEG_END], max_step)  # fmt: skip
                    if st == SUCCESS:
                        _load_lane(cf, cst, lf, lint, lane, params[i], blk, work[i], tstate[i],
                                   nn, cc, d, rtol, atol, nw)  # fmt: skip
                        stepping += 1
                        break
                member_stop(i, st, k, lint[lane, GLANE.LIMIT], max_steps, y_out, status, n_done)
                lint[lane, GLANE.MEMBER] = -1
        if stepping == 0:
            return
        gyrostat_coefficients_lanes(cf, p, kind, nw, cst, lf, lint)
        for lane in range(LANES):
            if lint[lane, GLANE.STEP] == 0:
                continue
            i = lint[lane, GLANE.MEMBER]
            pu = lint[lane, GLANE.STOP]
            w = work[i]
            _unload_lane(cf, lane, pu, w, nw)
            counters[i, 1] += pu
            blk = sc[sc_at[i] : sc_at[i + 1]]
            hs = CTL(i, src)[0]
            seg_end = hs[HS.SEG_END]
            st = step_complete(blk, w, tstate[i], counters[i], rtol, atol, seg_end, max_step, pu,
                               lf[lane, LF.N], lf[lane, LF.C], lf[lane, LF.D])  # fmt: skip
            if st != SUCCESS:
                member_stop(i, st, lint[lane, GLANE.K], lint[lane, GLANE.LIMIT], max_steps, y_out,
                            status, n_done)  # fmt: skip
                lint[lane, GLANE.MEMBER] = -1
                continue
            if tstate[i, 0] == seg_end and seg_end < t_end:
                hs[HS.PENDING] = 1.0


#: The same group driver with the flight software as the members' command source.
fsw_group = rebind(gyrostat_group, globals(), "fsw", BOUNDARY="fsw_boundary", CTL="fsw_ctl")


# No reference counting (numba's _nrt=False): every array is made by the caller, and each
# member's rows are views taken at every step and boundary. One group a call, the groups on
# Python threads (attitude.ensemble._chunks; the GIL released): inlined into a prange loop, the
# group lost its writes to the hold state (numba's parfor passes; every member stopped at t0).
@jit(nogil=True, _nrt=False)
def schedule_group_run(params, sc, sc_at, y0, t, y_out, work, tstate, counters, src, status,
                       n_done, rtol, atol, max_step, max_steps, budget, group, cf, cst, lf, lint,
                       g):  # fmt: skip
    """Group ``g`` of the members under open-loop schedules: members ``g * group`` on, through
    the batch integrator of the workspaces ``cf[g], cst[g], lf[g], lint[g]``
    (:func:`new_workspaces`)."""
    c = y0.shape[0]
    start = g * group
    gyrostat_group(params, sc, sc_at, y0, t, y_out, work, tstate, counters, src, status, n_done,
                   rtol, atol, max_step, max_steps, budget, start, min(c, start + group), cf[g],
                   cst[g], lf[g], lint[g])  # fmt: skip


@jit(nogil=True, _nrt=False)
def fsw_group_run(params, sc, sc_at, y0, t, y_out, work, tstate, counters, src, status, n_done,
                  rtol, atol, max_step, max_steps, budget, group, cf, cst, lf, lint,
                  g):  # fmt: skip
    """Group ``g`` of the members under their flight software (as :func:`schedule_group_run`)."""
    c = y0.shape[0]
    start = g * group
    fsw_group(params, sc, sc_at, y0, t, y_out, work, tstate, counters, src, status, n_done,
              rtol, atol, max_step, max_steps, budget, start, min(c, start + group), cf[g],
              cst[g], lf[g], lint[g])  # fmt: skip
