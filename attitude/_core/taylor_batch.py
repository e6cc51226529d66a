"""The Taylor method on LANES ensemble members at once (structure of arrays, SIMD).

:mod:`attitude._core.taylor` integrates one member; here a *batch* of LANES members
(:data:`attitude._core.lanes.LANES`) shares one coefficient table ``cf[k, column, lane]`` whose
last axis is the member, so the automatic-differentiation recurrences of eq. 7 (the Cauchy
products, >90 % of the work of a step) run as SIMD instructions over the members
(:func:`taylor_coefficients_lanes`, the lane-wise mirror of
:func:`attitude._core.taylor.taylor_coefficients`), as heyoka's batch mode does.

Everything else is per lane, by the scalar kernels themselves on a view ``cf[:, :, lane]`` of the
lane's column: the first row of the table (:func:`attitude._core.taylor._initial_row`, with the
exact Kepler restart), Jorba & Zou's step (:func:`attitude._core.taylor.step_from_coefficients`)
and the output samples (:func:`attitude._core.taylor.emit_samples`). So every lane keeps its own
time and step size, and a member computes, operation for operation, what it computes alone with
``propagate(method="taylor")``: the lane-wise recurrences apply the scalar kernel's floating-point
operations in the scalar kernel's order (multiply–adds as explicit fused operations,
:mod:`attitude._core.fma`, in both; no contraction or reassociation left to the compiler).
tests/test_ensemble_taylor.py checks the results bit for bit against single runs.

A lane whose member is done (or failed) takes the next member of its group at once; when the
group has no member left the lane idles on its last state (its recurrences still run, their
results are unused) until the other lanes are done. Members never interact, so a member's
result does not depend on its lane, its group, the chunking or the thread count.

All members of a call have the same kind of built-in potential (torque-free, heavy top, or the
gravity gradient of a Kepler orbit; checked at the public boundary).

Array layout (N members, m output times) as in :mod:`attitude._core.ensemble`, except
``tstate`` (N, 5): each member's final :mod:`attitude._core.taylor` time state (``tstate[:, 0]``
is the time it reached) and ``counters`` (N, 5): ``[n_steps, n_series_terms, 0, started,
has_step]``.

:func:`taylor_coefficients_lanes` is compiled with LLVM's SLP vectoriser on
(:func:`orbit._shared_jit.slp_vectorized`; numba leaves it off by default): it turns the lane
tuples into SIMD instructions (``<4 x double>`` FMAs; tests/test_ensemble_taylor.py looks for
them in the machine code).
"""

from __future__ import annotations

import math
import sys

import numpy as np

from orbit import _state_kernels as _SK
from orbit._layout import Field, layout
from orbit._rk import NONFINITE, SUCCESS, TOO_MANY_STEPS
from orbit._shared_jit import jit, slp_vectorized, specialise

from . import lanes as V
from .dynamics import diagnostics_row, diagnostics_with
from .fma import fma as F
from .lanes import LANES, simd_lanes
from .potentials import (
    HEAVY_TOP,
    KIND_GRAVITY_GRADIENT,
    KIND_HEAVY_TOP,
    MODEL,
    builtin_potential,
    gravity_gradient_potential_radial,
)
from .quat import rotate_inverse
from .taylor import (
    COL,
    RECIPROCALS,
    WORK_ROWS,
    Y,
    order_from_tolerance,
    order_radius,
    set_order,
    step_end,
)

__all__ = [
    "LANES",
    "batch",
    "new_workspaces",
    "taylor_ensemble_serial",
    "taylor_group_run",
]

_BATCHES: dict[int, object] = {}


def batch(width: int | None = None):
    """The batch integrator at ``width`` lanes (default: :func:`attitude._core.lanes.simd_lanes`,
    the CPU's, chosen at run time): this module for 4, else its copy bound to
    ``lanes.module(8)`` (:func:`orbit._shared_jit.specialise`, compiled and cached on
    first use under its own name). Every width gives the same results, bit for bit: lanes never
    mix, and each computes the scalar kernel's operations in its order."""
    width = simd_lanes() if width is None else int(width)
    if width == LANES:
        return sys.modules[__name__]
    mod = _BATCHES.get(width)
    if mod is None:
        if width != 8:
            raise ValueError(f"batch width {width}: 4 or 8 lanes")
        mod = _BATCHES[width] = specialise(sys.modules[__name__], "lanes8", V=V.module(8), LANES=8)
    return mod


# Per-lane constants of the recurrences (rows of ``cst``, one column per lane).
CONST = layout(
    "per-lane constants",
    ii=Field(3, "", "1/I1, 1/I2, 1/I3"),
    e=Field(3, "", "Euler: 1/I3 − 1/I2, 1/I1 − 1/I3, 1/I2 − 1/I1"),
    n=Field(1, "", "n = |q|²"),
    invn=Field(1, "", "1/n"),
    c=Field(1, "", "c = q·Q"),
    w=Field(1, "N", "heavy top: weight"),
    cm=Field(3, "m", "heavy top: centre of mass"),
    mu=Field(1, "km3/s2", "gravity gradient: μ"),
    d=Field(3, "", "gravity gradient: I3 − I2, I1 − I3, I2 − I1"),
)


@jit(inline="always")
def _lane_constants(params, i, cst, lane):
    """Column ``lane`` of ``cst`` from member ``i``'s ``params`` (the values
    :func:`attitude._core.taylor.taylor_coefficients` computes at its start; n, c and 1/n
    change every step: :func:`_lane_state_constants`)."""
    iI0 = 1.0 / params[i, 0]
    iI1 = 1.0 / params[i, 1]
    iI2 = 1.0 / params[i, 2]
    cst[CONST.II, lane] = iI0
    cst[CONST.II + 1, lane] = iI1
    cst[CONST.II + 2, lane] = iI2
    cst[CONST.E, lane] = iI2 - iI1
    cst[CONST.E + 1, lane] = iI0 - iI2
    cst[CONST.E + 2, lane] = iI1 - iI0
    kind = int(params[i, MODEL.KIND])
    if kind == KIND_HEAVY_TOP:
        cst[CONST.W, lane] = params[i, MODEL.KIND + HEAVY_TOP.WEIGHT]
        cst[CONST.CM, lane] = params[i, MODEL.KIND + HEAVY_TOP.CM]
        cst[CONST.CM + 1, lane] = params[i, MODEL.KIND + HEAVY_TOP.CM + 1]
        cst[CONST.CM + 2, lane] = params[i, MODEL.KIND + HEAVY_TOP.CM + 2]
    elif kind == KIND_GRAVITY_GRADIENT:
        cst[CONST.MU, lane] = params[i, MODEL.DATA + _SK.MU]
        cst[CONST.D, lane] = params[i, 2] - params[i, 1]
        cst[CONST.D + 1, lane] = params[i, 0] - params[i, 2]
        cst[CONST.D + 2, lane] = params[i, 1] - params[i, 0]


@jit(inline="always")
def _lane_state_constants(n, c, cst, lane):
    """n = |q|², c = q·Q and 1/n of the lane's current state."""
    cst[CONST.N, lane] = n
    cst[CONST.INVN, lane] = 1.0 / n
    cst[CONST.C, lane] = c


@jit(inline="always")
def _q_from_g(cf, k, col, c, inv_n, s0, s1, s2):
    # Q[k] = (c q[k] + 2 Σ_m g_m ⋆ (q∘e_m)) / n, component col − 4
    s = V.smul(2.0, V.add(V.add(s0, s1), s2))
    V.store(cf, k, col, V.mul(V.fma(c, V.load(cf, k, col - 4), s), inv_n))


@jit(inline="always")
def _q_dot(cf, k1, col, h, iI0, iI1, iI2, s0, s1, s2):
    # q[k + 1] = ½ Σ_m ω_m ⋆ (q∘e_m) / (k + 1), component col
    s = V.fma(iI2, s2, V.fma(iI1, s1, V.mul(iI0, s0)))
    V.store(cf, k1, col, V.smul(h, s))


@jit(inline="always")
def _torque_series_lanes(cf, k, kind, mW, cx, cy, cz, mu3, mmu, D0, D1, D2):
    """:func:`attitude._core.taylor.torque_series` on lane tuples, statement for statement: the
    torque series of the batch integrators (this module's and attitude._core.gyrostat_batch's)."""
    Z = V.ZERO
    t0 = t1 = t2 = Z
    inv = RECIPROCALS[k]
    if kind == KIND_HEAVY_TOP:
        s0 = V.load(cf, k, COL.A)
        s1 = V.load(cf, k, COL.A + 1)
        s2 = V.load(cf, k, COL.A + 2)
        t0 = V.mul(mW, V.fma(cy, s2, V.mul(V.neg(cz), s1)))
        t1 = V.mul(mW, V.fma(cz, s0, V.mul(V.neg(cx), s2)))
        t2 = V.mul(mW, V.fma(cx, s1, V.mul(V.neg(cy), s0)))
        b0 = b1 = b2 = Z
        for j in range(k + 1):
            s0 = V.load(cf, j, COL.A)
            s1 = V.load(cf, j, COL.A + 1)
            s2 = V.load(cf, j, COL.A + 2)
            w0 = V.load(cf, k - j, COL.W)
            w1 = V.load(cf, k - j, COL.W + 1)
            w2 = V.load(cf, k - j, COL.W + 2)
            b0 = V.fma(s1, w2, V.fma(V.neg(s2), w1, b0))
            b1 = V.fma(s2, w0, V.fma(V.neg(s0), w2, b1))
            b2 = V.fma(s0, w1, V.fma(V.neg(s1), w0, b2))
        V.store(cf, k + 1, COL.A, V.smul(inv, b0))
        V.store(cf, k + 1, COL.A + 1, V.smul(inv, b1))
        V.store(cf, k + 1, COL.A + 2, V.smul(inv, b2))
    elif kind == KIND_GRAVITY_GRADIENT:
        s = x0 = x1 = x2 = Z
        for j in range(k + 1):
            r0 = V.load(cf, j, COL.A)
            r1 = V.load(cf, j, COL.A + 1)
            r2 = V.load(cf, j, COL.A + 2)
            u0 = V.load(cf, k - j, COL.A)
            u1 = V.load(cf, k - j, COL.A + 1)
            u2 = V.load(cf, k - j, COL.A + 2)
            s = V.fma(r2, u2, V.fma(r1, u1, V.fma(r0, u0, s)))
            x0 = V.fma(r1, u2, x0)
            x1 = V.fma(r2, u0, x1)
            x2 = V.fma(r0, u1, x2)
        V.store(cf, k, COL.R2, s)
        V.store(cf, k, COL.X, V.mul(D0, x0))
        V.store(cf, k, COL.X + 1, V.mul(D1, x1))
        V.store(cf, k, COL.X + 2, V.mul(D2, x2))
        s00 = V.load(cf, 0, COL.R2)
        if k == 0:
            for ln in range(LANES):
                r2s = cf[0, COL.R2, ln]
                cf[0, COL.U3, ln] = 1.0 / (r2s * math.sqrt(r2s))
                cf[0, COL.U5, ln] = cf[0, COL.U3, ln] / r2s
        else:
            # u = s^(−3/2): power recurrence; |r|⁻⁵ = u / s: division.
            acc = Z
            for j in range(k):
                coef = -1.5 * (k - j) - j
                acc = V.fma(V.smul(coef, V.load(cf, k - j, COL.R2)), V.load(cf, j, COL.U3), acc)
            V.store(cf, k, COL.U3, V.div(acc, V.smul(k, s00)))
            acc = V.load(cf, k, COL.U3)
            for j in range(1, k + 1):
                acc = V.fma(V.neg(V.load(cf, j, COL.R2)), V.load(cf, k - j, COL.U5), acc)
            V.store(cf, k, COL.U5, V.div(acc, s00))
        # τ[k] = 3μ (|r|⁻⁵ ⋆ r × I r)[k];  ṙ = v + r × ω;  v̇ = −μ |r|⁻³ r + v × ω
        b0 = b1 = b2 = Z
        d0 = d1 = d2 = Z
        f0 = f1 = f2 = Z
        for j in range(k + 1):
            u5 = V.load(cf, j, COL.U5)
            u3 = V.load(cf, j, COL.U3)
            w0 = V.load(cf, k - j, COL.W)
            w1 = V.load(cf, k - j, COL.W + 1)
            w2 = V.load(cf, k - j, COL.W + 2)
            r0 = V.load(cf, j, COL.A)
            r1 = V.load(cf, j, COL.A + 1)
            r2 = V.load(cf, j, COL.A + 2)
            v0 = V.load(cf, j, COL.V)
            v1 = V.load(cf, j, COL.V + 1)
            v2 = V.load(cf, j, COL.V + 2)
            t0 = V.fma(u5, V.load(cf, k - j, COL.X), t0)
            t1 = V.fma(u5, V.load(cf, k - j, COL.X + 1), t1)
            t2 = V.fma(u5, V.load(cf, k - j, COL.X + 2), t2)
            b0 = V.fma(r1, w2, V.fma(V.neg(r2), w1, b0))
            b1 = V.fma(r2, w0, V.fma(V.neg(r0), w2, b1))
            b2 = V.fma(r0, w1, V.fma(V.neg(r1), w0, b2))
            d0 = V.fma(v1, w2, V.fma(V.neg(v2), w1, d0))
            d1 = V.fma(v2, w0, V.fma(V.neg(v0), w2, d1))
            d2 = V.fma(v0, w1, V.fma(V.neg(v1), w0, d2))
            f0 = V.fma(u3, V.load(cf, k - j, COL.A), f0)
            f1 = V.fma(u3, V.load(cf, k - j, COL.A + 1), f1)
            f2 = V.fma(u3, V.load(cf, k - j, COL.A + 2), f2)
        t0 = V.mul(t0, mu3)
        t1 = V.mul(t1, mu3)
        t2 = V.mul(t2, mu3)
        V.store(cf, k + 1, COL.A, V.smul(inv, V.add(V.load(cf, k, COL.V), b0)))
        V.store(cf, k + 1, COL.A + 1, V.smul(inv, V.add(V.load(cf, k, COL.V + 1), b1)))
        V.store(cf, k + 1, COL.A + 2, V.smul(inv, V.add(V.load(cf, k, COL.V + 2), b2)))
        V.store(cf, k + 1, COL.V, V.smul(inv, V.fma(mmu, f0, d0)))
        V.store(cf, k + 1, COL.V + 1, V.smul(inv, V.fma(mmu, f1, d1)))
        V.store(cf, k + 1, COL.V + 2, V.smul(inv, V.fma(mmu, f2, d2)))
    return t0, t1, t2


@slp_vectorized
@jit
def taylor_coefficients_lanes(cf, p, kind, cst):
    """Rows 1..p of the coefficient table of every lane from its row 0: the recurrences of
    :func:`attitude._core.taylor.taylor_coefficients`, statement for statement, on lane tuples.
    """
    iI0 = V.load_row(cst, CONST.II)
    iI1 = V.load_row(cst, CONST.II + 1)
    iI2 = V.load_row(cst, CONST.II + 2)
    e0 = V.load_row(cst, CONST.E)
    e1 = V.load_row(cst, CONST.E + 1)
    e2 = V.load_row(cst, CONST.E + 2)
    n = V.load_row(cst, CONST.N)
    inv_n = V.load_row(cst, CONST.INVN)
    c = V.load_row(cst, CONST.C)
    mW = V.neg(V.load_row(cst, CONST.W))
    cx = V.load_row(cst, CONST.CM)
    cy = V.load_row(cst, CONST.CM + 1)
    cz = V.load_row(cst, CONST.CM + 2)
    mu = V.load_row(cst, CONST.MU)
    mu3 = V.smul(3.0, mu)
    mmu = V.neg(mu)
    D0 = V.load_row(cst, CONST.D)
    D1 = V.load_row(cst, CONST.D + 1)
    D2 = V.load_row(cst, CONST.D + 2)
    Z = V.ZERO
    for k in range(p + 1):
        V.store(cf, k, COL.W, V.mul(iI0, V.load(cf, k, COL.G)))
        V.store(cf, k, COL.W + 1, V.mul(iI1, V.load(cf, k, COL.G + 1)))
        V.store(cf, k, COL.W + 2, V.mul(iI2, V.load(cf, k, COL.G + 2)))
        a00 = a10 = a20 = a30 = Z
        a01 = a11 = a21 = a31 = Z
        a02 = a12 = a22 = a32 = Z
        p12 = p20 = p01 = Z
        for j in range(k + 1):
            q0 = V.load(cf, j, 0)
            q1 = V.load(cf, j, 1)
            q2 = V.load(cf, j, 2)
            q3 = V.load(cf, j, 3)
            g0 = V.load(cf, k - j, COL.G)
            g1 = V.load(cf, k - j, COL.G + 1)
            g2 = V.load(cf, k - j, COL.G + 2)
            p12 = V.fma(V.load(cf, j, COL.G + 1), g2, p12)
            p20 = V.fma(V.load(cf, j, COL.G + 2), g0, p20)
            p01 = V.fma(V.load(cf, j, COL.G), g1, p01)
            a00 = V.fma(V.neg(q1), g0, a00)
            a10 = V.fma(q0, g0, a10)
            a20 = V.fma(q3, g0, a20)
            a30 = V.fma(V.neg(q2), g0, a30)
            a01 = V.fma(V.neg(q2), g1, a01)
            a11 = V.fma(V.neg(q3), g1, a11)
            a21 = V.fma(q0, g1, a21)
            a31 = V.fma(q1, g1, a31)
            a02 = V.fma(V.neg(q3), g2, a02)
            a12 = V.fma(q2, g2, a12)
            a22 = V.fma(V.neg(q1), g2, a22)
            a32 = V.fma(q0, g2, a32)
        if k > 0:
            # Q = q∘(c, 2g)/n
            _q_from_g(cf, k, 4, c, inv_n, a00, a01, a02)
            _q_from_g(cf, k, 5, c, inv_n, a10, a11, a12)
            _q_from_g(cf, k, 6, c, inv_n, a20, a21, a22)
            _q_from_g(cf, k, 7, c, inv_n, a30, a31, a32)
        if k == p:
            break
        h = 0.5 / (k + 1.0)
        # q̇ = ½ q∘(0, ω)
        _q_dot(cf, k + 1, 0, h, iI0, iI1, iI2, a00, a01, a02)
        _q_dot(cf, k + 1, 1, h, iI0, iI1, iI2, a10, a11, a12)
        _q_dot(cf, k + 1, 2, h, iI0, iI1, iI2, a20, a21, a22)
        _q_dot(cf, k + 1, 3, h, iI0, iI1, iI2, a30, a31, a32)
        inv = RECIPROCALS[k]
        t0, t1, t2 = _torque_series_lanes(cf, k, kind, mW, cx, cy, cz, mu3, mmu, D0, D1, D2)
        # Euler's equations: ġ = g × ω + n τ
        V.store(cf, k + 1, COL.G, V.smul(inv, V.fma(e0, p12, V.mul(n, t0))))
        V.store(cf, k + 1, COL.G + 1, V.smul(inv, V.fma(e1, p20, V.mul(n, t1))))
        V.store(cf, k + 1, COL.G + 2, V.smul(inv, V.fma(e2, p01, V.mul(n, t2))))


# ------------------------------------------------------------------------------------------------
# one lane's step: attitude._core.taylor's scalar kernels, statement for statement, on column
# ``lane`` of the table. Indexing, not array views, and inlined: a view, or an array passed to a
# compiled call, costs two atomic reference-count operations (half the run time before this).
# ------------------------------------------------------------------------------------------------


@jit(inline="always")
def _lane_initial_row(cf, lane, t, params, i):
    """:func:`attitude._core.taylor._initial_row` for the member ``i`` in ``lane`` -> (n, c)."""
    q0 = cf[Y, 0, lane]
    q1 = cf[Y, 1, lane]
    q2 = cf[Y, 2, lane]
    q3 = cf[Y, 3, lane]
    Q0 = cf[Y, 4, lane]
    Q1 = cf[Y, 5, lane]
    Q2 = cf[Y, 6, lane]
    Q3 = cf[Y, 7, lane]
    for j in range(8):
        cf[0, j, lane] = cf[Y, j, lane]
    c = q0 * Q0 + q1 * Q1 + q2 * Q2 + q3 * Q3
    cf[0, COL.G, lane] = 0.5 * (q0 * Q1 - q1 * Q0 - q2 * Q3 + q3 * Q2)
    cf[0, COL.G + 1, lane] = 0.5 * (q0 * Q2 + q1 * Q3 - q2 * Q0 - q3 * Q1)
    cf[0, COL.G + 2, lane] = 0.5 * (q0 * Q3 - q1 * Q2 + q2 * Q1 - q3 * Q0)
    n = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    kind = int(params[i, MODEL.KIND])
    q = (q0, q1, q2, q3)
    if kind == KIND_HEAVY_TOP:
        s = rotate_inverse(q, (0.0, 0.0, 1.0))
        cf[0, COL.A, lane] = s[0]
        cf[0, COL.A + 1, lane] = s[1]
        cf[0, COL.A + 2, lane] = s[2]
    elif kind == KIND_GRAVITY_GRADIENT:
        x, yy, z, vx, vy, vz = _SK.orbit_state(params[i, MODEL.DATA :], t)
        r = rotate_inverse(q, (x, yy, z))
        v = rotate_inverse(q, (vx, vy, vz))
        for j in range(3):
            cf[0, COL.A + j, lane] = r[j]
            cf[0, COL.V + j, lane] = v[j]
    return n, c


@jit(inline="always")
def _lane_block_norm(cf, lane, k, c0):
    m = 0.0
    for j in range(c0, c0 + 4):
        a = abs(cf[k, j, lane])
        if a > m:
            m = a
    return m


@jit(inline="always")
def _lane_radius(cf, lane, p, rtol, atol):
    """:func:`attitude._core.taylor._radius` of ``lane``."""
    floor = atol / rtol
    sq = max(_lane_block_norm(cf, lane, 0, 0), floor)
    sp = max(_lane_block_norm(cf, lane, 0, 4), floor)
    q1 = _lane_block_norm(cf, lane, p - 1, 0)
    rho = order_radius(sq, sp, q1, _lane_block_norm(cf, lane, p - 1, 4), p - 1)
    q2 = _lane_block_norm(cf, lane, p, 0)
    return min(rho, order_radius(sq, sp, q2, _lane_block_norm(cf, lane, p, 4), p))


@jit(inline="always")
def _lane_dense(cf, lane, p, tau):
    """:func:`attitude._core.taylor.dense_eval` of ``lane`` -> the 8 values."""
    a0, a1, a2, a3 = cf[p, 0, lane], cf[p, 1, lane], cf[p, 2, lane], cf[p, 3, lane]
    a4, a5, a6, a7 = cf[p, 4, lane], cf[p, 5, lane], cf[p, 6, lane], cf[p, 7, lane]
    for k in range(p - 1, -1, -1):
        a0 = F(a0, tau, cf[k, 0, lane])
        a1 = F(a1, tau, cf[k, 1, lane])
        a2 = F(a2, tau, cf[k, 2, lane])
        a3 = F(a3, tau, cf[k, 3, lane])
        a4 = F(a4, tau, cf[k, 4, lane])
        a5 = F(a5, tau, cf[k, 5, lane])
        a6 = F(a6, tau, cf[k, 6, lane])
        a7 = F(a7, tau, cf[k, 7, lane])
    return a0, a1, a2, a3, a4, a5, a6, a7


@jit(inline="always")
def _lane_step(cf, lane, lts, lcnt, rtol, atol, t_end, max_step):
    """:func:`attitude._core.taylor.step_from_coefficients` of ``lane`` (time state
    ``lts[lane]``, counters ``lcnt[lane]``)."""
    p = int(lts[lane, 3])
    t = lts[lane, 0]
    rho = _lane_radius(cf, lane, p, rtol, atol)
    h_abs = rho * lts[lane, 4]
    status, t_new = step_end(t, h_abs, t_end, max_step)
    if status != SUCCESS:
        return status
    h = t_new - t
    y = _lane_dense(cf, lane, p, h)
    for j in range(8):
        cf[Y, j, lane] = y[j]
    finite = True
    for j in range(8):
        finite = finite and math.isfinite(cf[Y, j, lane])
    if not finite:
        for j in range(8):
            cf[Y, j, lane] = cf[0, j, lane]
        return NONFINITE
    lts[lane, 2] = t
    lts[lane, 1] = h
    lts[lane, 0] = t_new
    lcnt[lane, 0] += 1
    lcnt[lane, 4] = 1
    return SUCCESS


@jit(inline="always")
def _lane_emit(cf, lane, lts, lcnt, t_out, y_out, i, k, direction):
    """:func:`attitude._core.taylor.emit_samples` of ``lane`` into member ``i``'s samples."""
    m = t_out.shape[0]
    p = int(lts[lane, 3])
    while k < m:
        to = t_out[k]
        t = lts[lane, 0]
        if to == t:
            for j in range(8):
                y_out[i, k, j] = cf[Y, j, lane]
        elif (
            lcnt[lane, 4] == 1
            and direction * (to - lts[lane, 2]) >= 0.0
            and direction * (t - to) > 0
        ):
            y = _lane_dense(cf, lane, p, to - lts[lane, 2])
            for j in range(8):
                y_out[i, k, j] = y[j]
        else:
            break
        k += 1
    return k


# ------------------------------------------------------------------------------------------------
# one group of members through one batch of LANES lanes
# ------------------------------------------------------------------------------------------------


@jit
def orbit_radial_table(d, t, out):
    """``out[k] = orbit_radial(d, t[k])`` (r, r̂): the orbit at the output times, once for all
    the members that share it (the gravity gradient's potential in their diagnostics)."""
    for k in range(t.shape[0]):
        r, ux, uy, uz = _SK.orbit_radial(d, t[k])
        out[k, 0] = r
        out[k, 1] = ux
        out[k, 2] = uy
        out[k, 3] = uz


@jit
def diagnostics_orbit_table(y, params, tab, out):
    """:func:`attitude._core.dynamics.diagnostics_with` for the gravity gradient with the
    orbit looked up in ``tab`` (:func:`orbit_radial_table`): the same operations on the same
    numbers, without a Kepler solve per sample."""
    mu = params[MODEL.DATA + _SK.MU]
    for k in range(y.shape[0]):
        q = (y[k, 0], y[k, 1], y[k, 2], y[k, 3])
        U = gravity_gradient_potential_radial(
            q, tab[k, 0], tab[k, 1], tab[k, 2], tab[k, 3], mu, params
        )
        diagnostics_row(y, k, U, params, out)


@jit
def _finish(i, lane, st, k, params, t, y_out, diag, lts, lint, tstate, counters, status, n_done,
            orbit_tab):  # fmt: skip
    """Member ``i`` (in ``lane``) is done with status ``st`` after ``k`` samples."""
    status[i] = st
    n_done[i] = k
    for j in range(5):
        tstate[i, j] = lts[lane, j]
        counters[i, j] = lint[lane, j]
    # Diagnostics of the samples reached; a failed member's rows after them are NaN (as
    # attitude._core.ensemble.member_run).
    if orbit_tab.shape[0] > 0:
        diagnostics_orbit_table(y_out[i, :k], params[i], orbit_tab[:k], diag[i, :k])
    else:
        diagnostics_with(builtin_potential, t[:k], y_out[i, :k], params[i], diag[i, :k])
    for r in range(k, t.shape[0]):
        for j in range(y_out.shape[2]):
            y_out[i, r, j] = math.nan
        for j in range(diag.shape[2]):
            diag[i, r, j] = math.nan


#: Columns of the per-lane integer state ``lint`` (LANES, LANE.SIZE).
LANE = layout(
    "lane state",
    counters=Field(5, "", "the member's counters"),
    member=Field(1, "", "the member in the lane (−1: idle)"),
    k=Field(1, "", "its next output sample"),
)
#: Columns of a group's state ``gst`` (int64): the next member to take (start: not begun),
#: and 1 once every member of the group has ended.
GROUP = layout("group state", next=1, done=1)


def new_workspaces(n_groups, lanes=LANES):
    """The arrays of ``n_groups`` batch integrators of ``lanes`` lanes (the ``LANES`` of the
    :func:`batch` that runs them), ``(cf, cst, lts, lint, gst)``, each with a leading group
    axis; ``gst[:, GROUP.NEXT] = -1``: not begun. They persist between the calls of a run that is
    paused at its step budget."""
    gst = np.zeros((n_groups, GROUP.SIZE), dtype=np.int64)
    for g in range(n_groups):
        gst[g, GROUP.NEXT] = -1
    return (np.zeros((n_groups, WORK_ROWS, COL.SIZE, lanes)),
            np.zeros((n_groups, CONST.SIZE, lanes)), np.zeros((n_groups, lanes, 5)),
            np.zeros((n_groups, lanes, LANE.SIZE), dtype=np.int64), gst)  # fmt: skip


# No reference counting in the step loop (numba's _nrt=False): every array it touches is
# allocated by its caller, and an array passed to an inlined helper would otherwise cost two
# atomic operations per call (more than the step's bookkeeping).
@jit(_nrt=False)
def taylor_group(params, y0, t, y_out, diag, tstate, counters, status, n_done, rtol, atol,
                 max_step, max_steps, orbit_tab, start, stop, cf, cst, lts, lint, gst,
                 budget):  # fmt: skip
    """Members ``start..stop-1`` through one batch integrator of LANES lanes (the workspace
    ``cf, cst, lts, lint`` and group state ``gst`` of one group of :func:`new_workspaces`),
    for at most ``budget`` batch steps (0: to the end). Paused at the budget, the lanes keep
    their members in the workspace: the next call goes on bit for bit (the lanes are
    independent, so no member's steps depend on when the group pauses). Returns the number of
    batch steps taken."""
    m = t.shape[0]
    t_end = t[m - 1]
    direction = 1.0 if t_end >= t[0] else -1.0
    p = order_from_tolerance(rtol)
    kind = int(params[start, MODEL.KIND])
    if gst[GROUP.DONE] != 0:
        return 0
    if gst[GROUP.NEXT] < 0:
        # Every lane starts from a valid state (a lane without a member repeats the first one).
        for lane in range(LANES):
            for j in range(8):
                cf[Y, j, lane] = y0[start, j]
            n, c = _lane_initial_row(cf, lane, t[0], params, start)
            _lane_constants(params, start, cst, lane)
            _lane_state_constants(n, c, cst, lane)
            lint[lane, LANE.MEMBER] = -1
        gst[GROUP.NEXT] = start
    nxt = gst[GROUP.NEXT]
    refill = True
    taken = 0
    while True:
        if refill:  # idle lanes take the next members (those that need no step finish here)
            refill = False
            for lane in range(LANES):
                while lint[lane, LANE.MEMBER] < 0 and nxt < stop:
                    i = nxt
                    nxt += 1
                    for j in range(8):
                        cf[Y, j, lane] = y0[i, j]
                    lts[lane, 0] = t[0]
                    lts[lane, 1] = 0.0
                    lts[lane, 2] = t[0]
                    set_order(lts[lane], p)
                    for j in range(5):
                        lint[lane, j] = 0
                    lint[lane, 3] = 1
                    k = _lane_emit(cf, lane, lts, lint, t, y_out, i, 0, direction)
                    if k < m and lint[lane, 0] < max_steps:
                        lint[lane, LANE.MEMBER] = i
                        lint[lane, LANE.K] = k
                        _lane_constants(params, i, cst, lane)
                    else:
                        st = SUCCESS if k >= m else TOO_MANY_STEPS
                        _finish(i, lane, st, k, params, t, y_out, diag, lts, lint, tstate,
                                counters, status, n_done, orbit_tab)  # fmt: skip
            gst[GROUP.NEXT] = nxt
        active = 0
        for lane in range(LANES):
            if lint[lane, LANE.MEMBER] >= 0:
                active += 1
        if active == 0:
            gst[GROUP.DONE] = 1
            return taken
        if budget > 0 and taken >= budget:
            return taken  # paused: the lanes hold their members
        taken += 1
        for lane in range(LANES):
            i = lint[lane, LANE.MEMBER]
            if i >= 0:
                n, c = _lane_initial_row(cf, lane, lts[lane, 0], params, i)
                _lane_state_constants(n, c, cst, lane)
        taylor_coefficients_lanes(cf, p, kind, cst)
        for lane in range(LANES):
            i = lint[lane, LANE.MEMBER]
            if i < 0:
                continue
            lint[lane, 1] += p
            st = _lane_step(cf, lane, lts, lint, rtol, atol, t_end, max_step)
            k = lint[lane, LANE.K]
            if st == SUCCESS:
                k = _lane_emit(cf, lane, lts, lint, t, y_out, i, k, direction)
                lint[lane, LANE.K] = k
                if k < m and lint[lane, 0] < max_steps:
                    continue
                if k < m:
                    st = TOO_MANY_STEPS
            _finish(i, lane, st, k, params, t, y_out, diag, lts, lint, tstate, counters, status,
                    n_done, orbit_tab)  # fmt: skip
            lint[lane, LANE.MEMBER] = -1
            refill = True


@jit(nogil=True, _nrt=False)
def taylor_group_run(params, y0, t, y_out, diag, tstate, counters, status, n_done, rtol, atol,
                     max_step, max_steps, orbit_tab, group, cf, cst, lts, lint, gst, budget,
                     g):  # fmt: skip
    """Group ``g`` (members ``g * group`` on, ``group`` per batch integrator, the workspaces of
    :func:`new_workspaces`) for at most ``budget`` batch steps this call, GIL released: the
    groups of a chunk run on Python threads (attitude.ensemble._chunks)."""
    n = y0.shape[0]
    start = g * group
    return taylor_group(params, y0, t, y_out, diag, tstate, counters, status, n_done, rtol, atol,
                        max_step, max_steps, orbit_tab, start, min(n, start + group), cf[g],
                        cst[g], lts[g], lint[g], gst[g], budget)  # fmt: skip


@jit(nogil=True)
def taylor_ensemble_serial(params, y0, t, y_out, diag, tstate, counters, status, n_done, rtol,
                           atol, max_step, max_steps, orbit_tab, group, cf, cst, lts, lint, gst,
                           budget):  # fmt: skip
    """All members, one group after the other, GIL released (what a Dask worker thread runs),
    for at most ``budget`` batch steps this call (over all groups)."""
    n = y0.shape[0]
    left = budget
    g = 0
    for start in range(0, n, group):
        if gst[g, GROUP.DONE] == 0:
            if budget > 0 and left <= 0:
                return
            taken = taylor_group(params, y0, t, y_out, diag, tstate, counters, status, n_done,
                                 rtol, atol, max_step, max_steps, orbit_tab, start,
                                 min(n, start + group), cf[g], cst[g], lts[g], lint[g], gst[g],
                                 left)  # fmt: skip
            left -= taken
        g += 1
