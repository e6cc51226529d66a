"""The Taylor method for the spacecraft with actuators (the gyrostat), restarted at every hold.

The gyrostat's equations (:mod:`attitude._core.gyrostat`) stay polynomial for a held command:

    q̇ = ½ q∘(0, ω),   ġ = g × ω + n τ,   ḣ_k = u_k − (c₁ Ω_k + c₀),   ω = M (g − ℓ)

with ℓ = Σ h_k a_k, Ω_k = h_k/J_k − a_k·ω, the wheel friction piecewise affine in Ω
(Basilisk's Coulomb + viscous law: c₁ = the limit-cycle slope below ω_lc, else c₁ = c_v,
c₀ = ±f_c), and τ the built-in torque's series (heavy top, gravity gradient:
:func:`attitude._core.taylor.torque_series`) plus the thrusters' held torque. So their Taylor
coefficients follow from automatic-differentiation recurrences, as for the rigid body
(:mod:`attitude._core.taylor`); Q is not expanded but rebuilt from q and g, Q = q∘(c, 2g)/n
(the relation :mod:`attitude._core.taylor` uses; with |q|² of the q it is rebuilt with, so
g and q·Q = c carry over from step to step to round-off).

Two additions to Jorba & Zou's scheme:

* **Order from the hold.** Held commands force steps no longer than the time to the next
  boundary d (0.1 s at a 10 Hz tick, often far below the radius of convergence). The
  recurrences run order by order and stop at the first order k >= 2 whose last term
  ‖x_k‖ d^k is below 0.1 rtol S_b in every block b (q, g, h; S_b as in Jorba & Zou), with
  either the term before it too (Jorba & Zou's two terms) or the terms falling over the last
  three orders and the next one, estimated from their ratios, below the round-off of S_b
  (:func:`order_enough`): the step is then d, at the order it needs (2 to 5 at a 10 Hz tick
  instead of the 13 of rtol = 1e-10). Otherwise the order reaches p = ⌈−½ ln rtol + 1⌉ and
  the step is Jorba & Zou's (min with d). The second way saves an order where the terms
  fall fast: the sensor day's noisy holds (terms ~1e-7, 5e-9, 2e-12, 2e-15, 1e-18 of |q| = 1)
  stop at order 4, not 5 (the fifth term is below the round-off of the sum), 5 % of the
  day's time. Two terms alone guard a series whose odd terms vanish (a start from rest: q's
  terms 1, 0, αd²/4, 0, …); the falling terms' test does too, as a zero term is not
  followed by a smaller one (the next order compares the zero with the larger term after it).
* **Friction kinks.** The friction law has kinks at Ω = ±ω_lc. Each wheel's piece is fixed at
  the step's start; if Ω leaves it before the step's end, the step is cut at the crossing
  (bisection on the step's polynomial of Ω) and the next step starts in the next piece. So a
  kink is resolved to round-off, not smoothed by a step that straddles it.

Layout: ``work`` (WORK_ROWS, COL.SIZE + 2 n_w): rows 0..p the coefficients (columns of
:mod:`attitude._core.taylor`, then h_k at CH + k and Ω_k at CH + n_w + k), row Y the state
(q, Q, h). ``tstate`` (TS.SIZE + n_w,): ``[t, h_last, t_old, p, step factor, p_used, n, c, g (3),
has g]`` then each wheel's friction piece for the next step (−1: from Ω at its start). The
steps carry g from one to the next (TS.G) instead of recomputing it from the rebuilt Q.
"""

from __future__ import annotations

import math

from orbit import _state_kernels as _SK
from orbit._layout import Field, layout
from orbit._rk import NONFINITE, STEP_TOO_SMALL, SUCCESS, TOO_MANY_STEPS
from orbit._shared_jit import inline_copy, jit

from .actuators import (
    SC,
    WHEEL,
)
from .fma import fma as F
from .holds import (
    BOUNDARY_DONE,
    BOUNDARY_NEEDS_COMMANDS,
    HS,
    NEEDS_COMMANDS,
    record,
    schedule_boundary,
)
from .potentials import (
    HEAVY_TOP,
    KIND_GRAVITY_GRADIENT,
    KIND_HEAVY_TOP,
    MODEL,
)
from .taylor import (
    COL,
    RECIPROCALS,
    Y,
    _initial_row,
    order_from_tolerance,
    set_order,
    step_end,
    torque_series,
)

CH = COL.SIZE  # first wheel momentum column
TS = layout(
    "gyrostat Taylor state",
    t=Field(1, "s"),
    h_last=Field(1, "s"),
    t_old=Field(1, "s"),
    p=Field(1, "", "order"),
    factor=Field(1, "", "step factor"),
    p_used=1,
    n=1,
    c=1,
    g=Field(3, "", "g at the end of the last step: the next step starts from it"),
    has_g=Field(1, "", "1 once G holds it"),
    hlin=Field(1, "", "1: no wheel has friction, the wheels' h are linear in the step"),
    pieces=Field(0, "", "then one friction piece per wheel"),
)

PIECE_FREE = -1  # decide from Ω at the step's start
PIECE_INSIDE = 0  # |Ω| < ω_lc: f = slope Ω
PIECE_POS = 1  # Ω >= ω_lc: f = f_c + c_v Ω
PIECE_NEG = 2  # Ω <= −ω_lc: f = −f_c + c_v Ω

#: Fraction of rtol S_b the last term (and the one before, or the next one's estimate below
#: ROUNDOFF S_b) must stay below to stop the order early (:func:`order_enough`).
ORDER_MARGIN = 0.1
#: 2⁻⁵⁶: half an ulp of 1 (the next term's estimate below ROUNDOFF S_b changes nothing the
#: block's round-off does not).
ROUNDOFF = 2.0**-56
#: Lowest order of a step.
PMIN = 2


def work_columns(n_w: int) -> int:
    """Columns of the work array for ``n_w`` wheels."""
    return max(COL.SIZE + 2 * n_w, 8 + n_w)


@jit(inline="always")
def _piece_of(om, lc):
    if om >= lc:
        return PIECE_POS
    if om <= -lc:
        return PIECE_NEG
    return PIECE_INSIDE


@jit(inline="always")
def _piece_coefficients(sc, b, piece):
    """(c₁, c₀) of the friction force c₁ Ω + c₀ in a piece (the torque on the wheel is minus
    it)."""
    if sc[b + WHEEL.FRICTION] == 0.0:
        return 0.0, 0.0
    if piece == PIECE_INSIDE:
        return sc[b + WHEEL.SLOPE_C], 0.0
    if piece == PIECE_POS:
        return sc[b + WHEEL.CV], sc[b + WHEEL.FC]
    return sc[b + WHEEL.CV], -sc[b + WHEEL.FC]


@jit(inline="always")
def has_friction(sc, nw):
    """True if a wheel has friction (else the wheels' h are linear in a step: TS.HLIN)."""
    for j in range(nw):
        if sc[SC.WHEELS + j * WHEEL.SIZE + WHEEL.FRICTION] != 0.0:
            return True
    return False


@jit(inline="always")
def order_enough(t, t1, t0, tol, ro):
    """True if a block's series may stop at order k: its terms ‖x_j‖ d^j at k, k − 1, k − 2
    are ``t, t1, t0``; the last one below ``tol`` (ORDER_MARGIN rtol S_b) and either the one
    before too (Jorba & Zou's two terms) or the terms falling over the last three with the next
    one, estimated from either of the last two ratios (t²/t1, t t1/t0), below ``ro``
    (ROUNDOFF S_b): a truncation below the round-off of the block's scale."""
    if t > tol:
        return False
    if t1 <= tol:
        return True
    return t <= t1 and t1 <= t0 and t * t <= ro * t1 and t * t1 <= ro * t0


@jit(inline="always")
def _block3(cf, k, c0):
    return max(abs(cf[k, c0]), max(abs(cf[k, c0 + 1]), abs(cf[k, c0 + 2])))


@jit(inline="always")
def _block4(cf, k, c0):
    return max(max(abs(cf[k, c0]), abs(cf[k, c0 + 1])), max(abs(cf[k, c0 + 2]), abs(cf[k, c0 + 3])))


@jit(inline="always")
def _blockh(cf, k, nw):
    m = 0.0
    for j in range(nw):
        a = abs(cf[k, CH + j])
        if a > m:
            m = a
    return m


@jit(inline="always")
def _ratio(s, x, j):
    if x > 0.0:
        return (s / x) ** (1.0 / j)
    return math.inf


@jit
def gyrostat_coefficients(cf, p, params, sc, n, pieces, d, rtol, atol, nw):
    """Rows 1.. of the coefficient table from row 0 (q, g, h and the torque's auxiliary
    series), order by order up to ``p``; stops early at the first order k >= PMIN whose terms
    over the distance ``d`` are :func:`order_enough` in every block (q, g, h).

    Returns the order reached (the rows 0..order of q, g, h are filled; with friction ω and
    Ω also at that order, for the kink check).

    Per order the work is one chain of dependent operations (g[k], h[k] → ω[k] → q[k+1],
    g[k+1]), so it is written to keep that chain short: the Cauchy products add the newest
    ω[k] last (their other terms run while ω[k] is computed), the cross product runs as two
    chains, 1/(k+1) is a table entry, not a division. Without friction the wheels' Ω enters
    nothing (h[k+1] = u/(k+1) at k = 0, else 0) and is not computed, nor ℓ[k] = 0 for k >= 2
    (the same numbers as computing them, but for the sign of a zero), nor are the rows
    h[k >= 2] = 0 written (:data:`TS.HLIN`: the table's readers take h as linear). Together
    with the register-held wheel chains of :func:`dense_state`: 372 → 294 ns a hold on the
    open-loop run of a sensor day's 72 000 noisy holds (order 5), measured."""
    kind = int(params[MODEL.KIND])
    W = cx = cy = cz = 0.0
    mu = D0 = D1 = D2 = 0.0
    if kind == KIND_HEAVY_TOP:
        W = params[MODEL.KIND + HEAVY_TOP.WEIGHT]
        cx = params[MODEL.KIND + HEAVY_TOP.CM]
        cy = params[MODEL.KIND + HEAVY_TOP.CM + 1]
        cz = params[MODEL.KIND + HEAVY_TOP.CM + 2]
    elif kind == KIND_GRAVITY_GRADIENT:
        mu = params[MODEL.DATA + _SK.MU]
        D0 = params[2] - params[1]
        D1 = params[0] - params[2]
        D2 = params[1] - params[0]
    m00 = sc[3]
    m01 = sc[4]
    m02 = sc[5]
    m10 = sc[6]
    m11 = sc[7]
    m12 = sc[8]
    m20 = sc[9]
    m21 = sc[10]
    m22 = sc[11]
    floor = atol / rtol
    sq = max(_block4(cf, 0, 0), floor)
    sg = max(_block3(cf, 0, COL.G), floor)
    sh = max(_blockh(cf, 0, nw), floor)
    tol_q = ORDER_MARGIN * rtol * sq
    tol_g = ORDER_MARGIN * rtol * sg
    tol_h = ORDER_MARGIN * rtol * sh
    dk = 1.0  # d^k
    ro_q = ROUNDOFF * sq
    ro_g = ROUNDOFF * sg
    ro_h = ROUNDOFF * sh
    tq0 = tq1 = sq  # the blocks' terms at the last two orders (the scale S_b before order 1)
    tg0 = tg1 = sg
    th0 = th1 = sh
    CO = CH + nw
    # Without friction the wheels' Ω enters no recurrence (h[k+1] = (u − c₀ − c₁ Ω[k])/(k+1)
    # with c₁ = 0) and no step check (the kinks are friction's): its orders above 0 (row 0 is
    # step_prepare's) are not computed; and h[k] = 0 from k = 2 on, so ℓ[k] = 0 there.
    friction = has_friction(sc, nw)
    k = 0
    while True:
        # ℓ[k], ω[k] = M (g[k] − ℓ[k]), Ω_j[k]
        if k >= 2 and not friction:
            e0 = cf[k, COL.G]
            e1 = cf[k, COL.G + 1]
            e2 = cf[k, COL.G + 2]
        else:
            l0 = l1 = l2 = 0.0
            for j in range(nw):
                b = SC.WHEELS + j * WHEEL.SIZE
                h = cf[k, CH + j]
                l0 = F(h, sc[b + WHEEL.AXIS], l0)
                l1 = F(h, sc[b + WHEEL.AXIS + 1], l1)
                l2 = F(h, sc[b + WHEEL.AXIS + 2], l2)
            e0 = cf[k, COL.G] - l0
            e1 = cf[k, COL.G + 1] - l1
            e2 = cf[k, COL.G + 2] - l2
        w0 = F(m02, e2, F(m01, e1, m00 * e0))
        w1 = F(m12, e2, F(m11, e1, m10 * e0))
        w2 = F(m22, e2, F(m21, e1, m20 * e0))
        cf[k, COL.W] = w0
        cf[k, COL.W + 1] = w1
        cf[k, COL.W + 2] = w2
        if friction and k > 0:
            for j in range(nw):
                b = SC.WHEELS + j * WHEEL.SIZE
                aw = F(
                    sc[b + WHEEL.AXIS + 2],
                    w2,
                    F(sc[b + WHEEL.AXIS + 1], w1, sc[b + WHEEL.AXIS] * w0),
                )
                cf[k, CO + j] = F(cf[k, CH + j], sc[b + WHEEL.INVJ], -aw)
        if k == p:
            return k
        # Cauchy products over j = k..0: B_lm = Σ (q[j]∘e_m)_l ω_m[k−j], P = Σ g[j] × ω[k−j]
        # (ω[k], the newest, last: the chains run on the known orders while ω[k] is computed;
        # the cross product in two chains, a × b = Σ a_i b_j − Σ a_j b_i)
        b00 = b10 = b20 = b30 = 0.0
        b01 = b11 = b21 = b31 = 0.0
        b02 = b12 = b22 = b32 = 0.0
        p0 = p1 = p2 = 0.0
        r0 = r1 = r2 = 0.0
        for i in range(k + 1):
            j = k - i
            q0 = cf[j, 0]
            q1 = cf[j, 1]
            q2 = cf[j, 2]
            q3 = cf[j, 3]
            o0 = cf[i, COL.W]
            o1 = cf[i, COL.W + 1]
            o2 = cf[i, COL.W + 2]
            g0 = cf[j, COL.G]
            g1 = cf[j, COL.G + 1]
            g2 = cf[j, COL.G + 2]
            b00 = F(-q1, o0, b00)
            b10 = F(q0, o0, b10)
            b20 = F(q3, o0, b20)
            b30 = F(-q2, o0, b30)
            b01 = F(-q2, o1, b01)
            b11 = F(-q3, o1, b11)
            b21 = F(q0, o1, b21)
            b31 = F(q1, o1, b31)
            b02 = F(-q3, o2, b02)
            b12 = F(q2, o2, b12)
            b22 = F(-q1, o2, b22)
            b32 = F(q0, o2, b32)
            p0 = F(g1, o2, p0)
            r0 = F(g2, o1, r0)
            p1 = F(g2, o0, p1)
            r1 = F(g0, o2, r1)
            p2 = F(g0, o1, p2)
            r2 = F(g1, o0, r2)
        p0 -= r0
        p1 -= r1
        p2 -= r2
        inv = RECIPROCALS[k]
        hh = 0.5 * inv
        cf[k + 1, 0] = hh * (b00 + b01 + b02)
        cf[k + 1, 1] = hh * (b10 + b11 + b12)
        cf[k + 1, 2] = hh * (b20 + b21 + b22)
        cf[k + 1, 3] = hh * (b30 + b31 + b32)
        t0, t1, t2 = torque_series(cf, k, kind, W, cx, cy, cz, mu, D0, D1, D2)
        if k == 0:  # the held torques: thrusters' and the ideal control torque (as in
            t0 += sc[SC.TAU] + sc[SC.IDEAL]  # actuators.actuator_torque)
            t1 += sc[SC.TAU + 1] + sc[SC.IDEAL + 1]
            t2 += sc[SC.TAU + 2] + sc[SC.IDEAL + 2]
        cf[k + 1, COL.G] = F(n, t0, p0) * inv
        cf[k + 1, COL.G + 1] = F(n, t1, p1) * inv
        cf[k + 1, COL.G + 2] = F(n, t2, p2) * inv
        if friction:
            for j in range(nw):
                b = SC.WHEELS + j * WHEEL.SIZE
                c1, c0 = _piece_coefficients(sc, b, int(pieces[j]))
                r = -c1 * cf[k, CO + j]
                if k == 0:
                    r += sc[b + WHEEL.U] - c0
                cf[k + 1, CH + j] = r * inv
        elif k == 0:  # h[1] = u; the rows h[k >= 2] = 0 are not written (TS.HLIN)
            for j in range(nw):
                cf[1, CH + j] = sc[SC.WHEELS + j * WHEEL.SIZE + WHEEL.U] * inv
        k += 1
        dk *= d
        tq = _block4(cf, k, 0) * dk
        tg = _block3(cf, k, COL.G) * dk
        th = 0.0 if k >= 2 and not friction else _blockh(cf, k, nw) * dk  # (h linear)
        ok = (
            order_enough(tq, tq1, tq0, tol_q, ro_q)
            and order_enough(tg, tg1, tg0, tol_g, ro_g)
            and order_enough(th, th1, th0, tol_h, ro_h)
        )
        tq0, tq1 = tq1, tq
        tg0, tg1 = tg1, tg
        th0, th1 = th1, th
        if ok and k >= PMIN:
            if not friction:
                return k
            # ω, Ω at the final order too (for the kink check on Ω's polynomial)
            p = k
            continue


@jit
def _jz_radius(cf, p, rtol, atol, nw):
    """Jorba & Zou's ρ over the blocks q, g, h from the orders p − 1 and p."""
    floor = atol / rtol
    sq = max(_block4(cf, 0, 0), floor)
    sg = max(_block3(cf, 0, COL.G), floor)
    sh = max(_blockh(cf, 0, nw), floor)
    rho = math.inf
    for j in (p - 1, p):
        rho = min(rho, _ratio(sq, _block4(cf, j, 0), j))
        rho = min(rho, _ratio(sg, _block3(cf, j, COL.G), j))
        if nw > 0:
            rho = min(rho, _ratio(sh, _blockh(cf, j, nw), j))
    return rho


@jit(inline="always")
def _horner(cf, p, col, tau):
    a = cf[p, col]
    for k in range(p - 1, -1, -1):
        a = F(a, tau, cf[k, col])
    return a


@jit
def dense_state(work, tstate, tau, out, nw):
    """The state (q, Q, h) at ``tau`` = t − t_old of the last step into ``out``:
    q, g, h from their polynomials, Q = q∘(c, 2g)/|q|². Returns g (3).

    The polynomials are evaluated by Horner's rule all at once, order by order (the same
    operations per column as one column at a time, so the same bits): the columns' chains of
    dependent multiply–adds then overlap instead of running one after the other. Returning g
    spares the step's end evaluating it again: 68 → 20 ns at order 5 with three wheels
    (measured, the two together)."""
    p = int(tstate[TS.P_USED])
    c = tstate[TS.C]
    q0 = work[p, 0]
    q1 = work[p, 1]
    q2 = work[p, 2]
    q3 = work[p, 3]
    h0 = work[p, COL.G]
    h1 = work[p, COL.G + 1]
    h2 = work[p, COL.G + 2]
    for i in range(p):
        k = p - 1 - i
        q0 = F(q0, tau, work[k, 0])
        q1 = F(q1, tau, work[k, 1])
        q2 = F(q2, tau, work[k, 2])
        q3 = F(q3, tau, work[k, 3])
        h0 = F(h0, tau, work[k, COL.G])
        h1 = F(h1, tau, work[k, COL.G + 1])
        h2 = F(h2, tau, work[k, COL.G + 2])
    # the wheels one at a time, each chain in a register (the wheels' chains still overlap:
    # no dependence between them; through ``out`` each order waited on the last one's store)
    if tstate[TS.HLIN] != 0.0:  # h = h[0] + h[1] τ: Horner's rule on the zero rows, the same bits
        for j in range(nw):
            out[8 + j] = F(work[1, CH + j], tau, work[0, CH + j])
    else:
        for j in range(nw):
            a = work[p, CH + j]
            for i in range(p):
                a = F(a, tau, work[p - 1 - i, CH + j])
            out[8 + j] = a
    g0 = 2.0 * h0
    g1 = 2.0 * h1
    g2 = 2.0 * h2
    # Q = q∘(c, 2g)/|q|² with |q|² of this q: g = ½ vec(q̃∘Q) and c = q·Q hold exactly (the
    # start's n would scale g by |q|²/n at every step, a drift of the truncation error of |q|)
    inv_n = 1.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    out[0] = q0
    out[1] = q1
    out[2] = q2
    out[3] = q3
    # q∘(c, 2g)
    out[4] = (c * q0 - q1 * g0 - q2 * g1 - q3 * g2) * inv_n
    out[5] = (c * q1 + q0 * g0 + q2 * g2 - q3 * g1) * inv_n
    out[6] = (c * q2 + q0 * g1 - q1 * g2 + q3 * g0) * inv_n
    out[7] = (c * q3 + q0 * g2 + q1 * g1 - q2 * g0) * inv_n
    return h0, h1, h2


@jit
def _kink(work, p, sc, pieces, nw, h):
    """The earliest time in (0, h] a wheel's Ω leaves its friction piece, and which wheel
    (−1: none)."""
    CO = CH + nw
    best = h
    which = -1
    for j in range(nw):
        b = SC.WHEELS + j * WHEEL.SIZE
        lc = sc[b + WHEEL.LC]
        if sc[b + WHEEL.FRICTION] == 0.0 or lc <= 0.0:
            continue
        piece = int(pieces[j])
        end = _horner(work, p, CO + j, best)
        if _piece_of(end, lc) == piece:
            continue
        # the threshold crossed first from the piece
        om0 = work[0, CO + j]
        if piece == PIECE_INSIDE:
            thr = lc if end > om0 else -lc
        elif piece == PIECE_POS:
            thr = lc
        else:
            thr = -lc
        lo = 0.0
        hi = best
        s0 = om0 - thr
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            v = _horner(work, p, CO + j, mid) - thr
            if (v > 0.0) == (s0 > 0.0) and v != 0.0:
                lo = mid
            else:
                hi = mid
        best = hi
        which = j
    return best, which


@jit
def step_prepare(params, sc, work, tstate, seg_end, max_step):
    """The first half of :func:`gyrostat_step`: row 0 of the table (q, g, h, the torque's
    auxiliary series, ω[0] and Ω[0]) from the state in ``work[Y]``, and the friction pieces
    of the step. Returns ``(status, n, c, d)``: n = |q|², c = q·Q, d the longest step (to
    ``seg_end``, at most ``max_step``)."""
    nw = int(sc[SC.NW])
    t = tstate[0]
    y = work[Y]
    n, c = _initial_row(work, t, params)
    if tstate[TS.HAS_G] != 0.0:
        # g as the last step ended, not ½ vec(q̃∘Q) of the rebuilt Q: that round trip is
        # biased by 3e-17 relative (measured), a drift of |g| over 1e5 steps
        work[0, COL.G] = tstate[TS.G]
        work[0, COL.G + 1] = tstate[TS.G + 1]
        work[0, COL.G + 2] = tstate[TS.G + 2]
    for j in range(nw):
        work[0, CH + j] = y[8 + j]
    # order 0 of ω and Ω, for the friction pieces
    pieces = tstate[TS.SIZE : TS.SIZE + nw]
    d = min(seg_end - t, max_step)
    if not d > 0.0:
        return STEP_TOO_SMALL, n, c, d
    friction = has_friction(sc, nw)
    tstate[TS.HLIN] = 0.0 if friction else 1.0
    if friction:
        # ω[0], Ω[0] first (the pieces depend on Ω[0]; without friction the recurrences
        # compute ω[0] and nothing reads Ω or a piece)
        gyrostat_order0(work, sc, nw)
        for j in range(nw):
            if pieces[j] < 0.0:
                b = SC.WHEELS + j * WHEEL.SIZE
                pieces[j] = _piece_of(work[0, CH + nw + j], sc[b + WHEEL.LC])
    return SUCCESS, n, c, d


@jit
def step_complete(sc, work, tstate, counters, rtol, atol, seg_end, max_step, pu, n, c, d):
    """The second half of :func:`gyrostat_step`, once the table holds the orders 0..``pu``
    (:func:`gyrostat_coefficients`): the step size, a friction kink inside the step, the new
    state. Returns a status."""
    nw = int(sc[SC.NW])
    t = tstate[0]
    p = int(tstate[3])
    y = work[Y]
    pieces = tstate[TS.SIZE : TS.SIZE + nw]
    hlin = tstate[TS.HLIN] != 0.0
    if pu >= p:
        if hlin:  # the rows of h Jorba & Zou's radius reads, unwritten by the recurrences
            for k in range(2, p + 1):
                for j in range(nw):
                    work[k, CH + j] = 0.0
        rho = _jz_radius(work, p, rtol, atol, nw)
        h_abs = rho * tstate[4]
    else:
        h_abs = d
    status, t_new = step_end(t, min(h_abs, d), seg_end, max_step)
    if status != SUCCESS:
        return status
    h = t_new - t
    tstate[TS.P_USED] = pu
    tstate[TS.N] = n
    tstate[TS.C] = c
    hk = h
    which = -1
    if not hlin:
        hk, which = _kink(work, pu, sc, pieces, nw, h)
    prev = -1
    if which >= 0:
        prev = int(pieces[which])
        if hk < h:
            h = hk
            t_new = t + h
    gh = dense_state(work, tstate, h, y, nw)
    for i in range(8 + nw):
        if not math.isfinite(y[i]):
            for ii in range(8):
                y[ii] = work[0, ii]
            for j in range(nw):
                y[8 + j] = work[0, CH + j]
            return NONFINITE
    tstate[TS.G] = gh[0]
    tstate[TS.G + 1] = gh[1]
    tstate[TS.G + 2] = gh[2]
    tstate[TS.HAS_G] = 1.0
    # the next step's pieces: the crossed wheel enters the next piece, the others re-decide
    if not hlin:
        for j in range(nw):
            pieces[j] = PIECE_FREE
    if which >= 0:
        om_end = _horner(work, pu, CH + nw + which, h)
        if prev == PIECE_INSIDE:
            pieces[which] = PIECE_POS if om_end > 0.0 else PIECE_NEG
        else:
            pieces[which] = PIECE_INSIDE
    tstate[2] = t
    tstate[1] = h
    tstate[0] = t_new
    counters[0] += 1
    counters[4] = 1
    return SUCCESS


@jit
def gyrostat_step(params, sc, work, tstate, counters, rtol, atol, seg_end, max_step):
    """One Taylor step of the gyrostat from the state in ``work[Y]`` at ``tstate[0]``, never
    past ``seg_end``. Returns a status. (:func:`step_prepare`, the recurrences, then
    :func:`step_complete`; the SIMD batch of :mod:`attitude._core.gyrostat_batch` runs the
    recurrences of several members at once between the same two halves.)"""
    status, n, c, d = step_prepare(params, sc, work, tstate, seg_end, max_step)
    if status != SUCCESS:
        return status
    nw = int(sc[SC.NW])
    pieces = tstate[TS.SIZE : TS.SIZE + nw]
    pu = gyrostat_coefficients(work, int(tstate[3]), params, sc, n, pieces, d, rtol, atol, nw)
    counters[1] += pu
    return step_complete(sc, work, tstate, counters, rtol, atol, seg_end, max_step, pu, n, c, d)


@jit(inline="always")
def gyrostat_order0(cf, sc, nw):
    """ω[0] = M (g[0] − ℓ[0]) and Ω_j[0] into row 0 (as the recurrences compute them)."""
    l0 = l1 = l2 = 0.0
    for j in range(nw):
        b = SC.WHEELS + j * WHEEL.SIZE
        h = cf[0, CH + j]
        l0 = F(h, sc[b + WHEEL.AXIS], l0)
        l1 = F(h, sc[b + WHEEL.AXIS + 1], l1)
        l2 = F(h, sc[b + WHEEL.AXIS + 2], l2)
    e0 = cf[0, COL.G] - l0
    e1 = cf[0, COL.G + 1] - l1
    e2 = cf[0, COL.G + 2] - l2
    w0 = F(sc[5], e2, F(sc[4], e1, sc[3] * e0))
    w1 = F(sc[8], e2, F(sc[7], e1, sc[6] * e0))
    w2 = F(sc[11], e2, F(sc[10], e1, sc[9] * e0))
    for j in range(nw):
        b = SC.WHEELS + j * WHEEL.SIZE
        aw = F(sc[b + WHEEL.AXIS + 2], w2, F(sc[b + WHEEL.AXIS + 1], w1, sc[b + WHEEL.AXIS] * w0))
        cf[0, CH + nw + j] = F(cf[0, CH + j], sc[b + WHEEL.INVJ], -aw)


# One step inlined whole into the single-run driver (entry_points binds it; the SIMD batch
# keeps the calls): the step's halves, the recurrences and the small kernels they call pass
# their arrays as seven arguments each. The recurrences inlined: the sensor day 0.47 -> 0.43 s,
# the noiseless one 0.27 -> 0.21 s (interleaved runs at load ~2), for 17 s more compilation of
# the closed-loop Taylor driver (56.6 -> 73.9 s cold, at load ~1.5).
_initial_row_inline = inline_copy(_initial_row, globals())
_dense_state_inline = inline_copy(dense_state, globals())
_kink_inline = inline_copy(_kink, globals())
_step_prepare_inline = inline_copy(step_prepare, globals(), _initial_row="_initial_row_inline")
_step_complete_inline = inline_copy(
    step_complete, globals(), dense_state="_dense_state_inline", _kink="_kink_inline"
)
_gyrostat_coefficients_inline = inline_copy(gyrostat_coefficients, globals())
gyrostat_step_inline = inline_copy(
    gyrostat_step,
    globals(),
    step_prepare="_step_prepare_inline",
    step_complete="_step_complete_inline",
    gyrostat_coefficients="_gyrostat_coefficients_inline",
)

#: The command source of :func:`taylor_holds_run` (as :data:`attitude._core.holds.BOUNDARY`):
#: the open-loop schedule here; the flight software's copies rebind it.
BOUNDARY = schedule_boundary


@jit
def taylor_holds_run(
    P, y0, t0, t_out, y_out, work, tstate, counters, rtol, atol, t_end, max_step, max_steps, ctl
):
    """The gyrostat's Taylor integration through held commands (the arguments and layouts of
    :func:`attitude._core.holds.holds_run`, with this module's ``work`` and ``tstate``)."""
    hs = ctl[0]
    params = P[0]
    sc = P[1]
    nw = int(sc[SC.NW])
    n = y0.shape[0]
    m = t_out.shape[0]
    y = work[Y]
    if counters[3] == 0:
        for i in range(n):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        set_order(tstate, order_from_tolerance(rtol))
        for j in range(nw):
            tstate[TS.SIZE + j] = PIECE_FREE
        hs[HS.NEXT] = 0.0
        hs[HS.PENDING] = 1.0
        hs[HS.HOLD_END] = math.nan
        counters[3] = 1
        counters[4] = 0
    k = 0
    while True:
        while k < m:
            to = t_out[k]
            t = tstate[0]
            if to == t:
                if hs[HS.PENDING] != 0.0:
                    break
                for i in range(n):
                    y_out[k, i] = y[i]
            elif counters[4] == 1 and to >= tstate[2] and t > to:
                dense_state(work, tstate, to - tstate[2], y_out[k], nw)
            else:
                break
            record(sc, y_out[k], n)
            k += 1
        if hs[HS.PENDING] != 0.0:
            bs = BOUNDARY(P, y, tstate[0], t_end, ctl)
            if bs == BOUNDARY_NEEDS_COMMANDS:
                return NEEDS_COMMANDS, k
            if bs != BOUNDARY_DONE:  # the source's own status (RECORDS_FULL, STEP_FAILED)
                return bs, k
            hs[HS.PENDING] = 0.0
            continue
        if k == m:
            return SUCCESS, k
        if counters[0] >= max_steps:
            return TOO_MANY_STEPS, k
        seg_end = hs[HS.SEG_END]
        status = gyrostat_step(params, sc, work, tstate, counters, rtol, atol, seg_end, max_step)
        if status != SUCCESS:
            return status, k
        if tstate[0] == seg_end and seg_end < t_end:
            hs[HS.PENDING] = 1.0
