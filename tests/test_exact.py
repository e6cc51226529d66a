"""Tests of attitude.exact (exact torque-free motion) and its compiled free flow.

Independent truth used here:

* Taylor-series integration of the Euler / Euler-parameter equations
  ``ġ = g × (g/I)``, ``q̇ = ½ q∘(0, g/I)`` (written out in this file, order 30–36) in
  extended precision: ``numpy.longdouble`` (64-bit mantissa, eps ≈ 1.1e-19) for the
  well-conditioned regimes, and Python's ``decimal`` at 40–70 digits near and on the separatrix,
  where the motion is so sensitive to the data (a relative change of 1e-18 in g moves the
  solution by ~3e-11 at t = 1000, measured) that a long-double integration is not accurate
  enough to judge a double-precision result. Both start from the exact value of
  ``g0 = ½ vec(q̃0∘Q0)`` for the float64 inputs.
* scipy's DOP853 at rtol 1e-13 on random bodies and states, compared at 1e-9 (the accuracy that
  integrator reaches on these spans, not ours).
* Closed forms: uniform rotation about a principal axis or for a sphere; conservation of the
  space angular momentum, kinetic energy, ``|q|`` and ``q·Q``.
* The flow property (n steps of the free flow equal one evaluation at n h), symplecticity of
  the free flow in R⁸ (finite differences) and the ODE off the constraint manifold.

Tolerances: our error is round-off that grows with the phase, ``≈ c·eps·Ω t`` with Ω the
largest angular rate (c ≈ 1 measured); the tests allow ``2e-15 + 2·eps·Ω t`` (≈ 4e-13 at
Ω t = 1000) unless stated.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from decimal import Decimal, localcontext

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from attitude._core import exact as X
from attitude.errors import AttitudeValueError
from attitude.exact import torque_free, torque_free_states

EPS = 2.0**-52
LD = np.longdouble

# ------------------------------------------------------------------------------------------
# independent helpers
# ------------------------------------------------------------------------------------------


def qmul(a, b):
    """Hamilton product for arrays (..., 4) of any dtype (float, longdouble, Decimal objects)."""
    a0, a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    b0, b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
        ],
        axis=-1,
    )


def conj(a):
    return a * np.array([1, -1, -1, -1], dtype=a.dtype)


def pure(v):
    return np.concatenate([np.zeros((*v.shape[:-1], 1), dtype=v.dtype), v], axis=-1)


def body_momentum(q, Q):
    """g = ½ vec(q̃∘Q) (Arribas et al. eq. 17)."""
    return qmul(conj(q), Q)[..., 1:] / 2


def _cross(a, b):
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def taylor_longdouble(Iinv, q0, g0, h, nsteps, order, every):
    """Taylor-series integration of ġ = g × w, q̇ = ½ q∘(0, w), w = g ⊙ Iinv in long double,
    batched over the leading axis of q0 (B, 4), g0 (B, 3).

    The Taylor coefficients follow from Cauchy products of the quadratic right-hand side:
    (k+1) g_{k+1} = Σ_j g_j × w_{k−j},  (k+1) q_{k+1} = ½ Σ_j q_j∘(0, w_{k−j}),
    formed from the summed outer products Σ_j g_j w_{k−j}ᵀ and Σ_j q_j w_{k−j}ᵀ.
    Returns the states every ``every`` steps, including t = 0.
    """
    B = q0.shape[0]
    qc = np.zeros((B, order + 1, 4), dtype=LD)
    gc = np.zeros((B, order + 1, 3), dtype=LD)
    wc = np.zeros((B, order + 1, 3), dtype=LD)
    inv = [LD(1) / LD(k + 1) for k in range(order)]
    q, g = q0.copy(), g0.copy()
    qs, gs = [q.copy()], [g.copy()]
    for step in range(nsteps):
        qc[:, 0], gc[:, 0], wc[:, 0] = q, g, g * Iinv
        for k in range(order):
            W = wc[:, k::-1]
            O = np.matmul(gc[:, : k + 1].transpose(0, 2, 1), W)  # Σ_j g_j w_{k-j}ᵀ
            P = np.matmul(qc[:, : k + 1].transpose(0, 2, 1), W)  # Σ_j q_j w_{k-j}ᵀ
            f = inv[k]
            gc[:, k + 1, 0] = (O[:, 1, 2] - O[:, 2, 1]) * f
            gc[:, k + 1, 1] = (O[:, 2, 0] - O[:, 0, 2]) * f
            gc[:, k + 1, 2] = (O[:, 0, 1] - O[:, 1, 0]) * f
            wc[:, k + 1] = gc[:, k + 1] * Iinv
            f = f / 2
            qc[:, k + 1, 0] = -(P[:, 1, 0] + P[:, 2, 1] + P[:, 3, 2]) * f
            qc[:, k + 1, 1] = (P[:, 0, 0] + P[:, 2, 2] - P[:, 3, 1]) * f
            qc[:, k + 1, 2] = (P[:, 0, 1] - P[:, 1, 2] + P[:, 3, 0]) * f
            qc[:, k + 1, 3] = (P[:, 0, 2] + P[:, 1, 1] - P[:, 2, 0]) * f
        qn, gn = qc[:, order].copy(), gc[:, order].copy()
        for k in range(order - 1, -1, -1):
            qn = qn * h + qc[:, k]
            gn = gn * h + gc[:, k]
        q, g = qn, gn
        if (step + 1) % every == 0:
            qs.append(q.copy())
            gs.append(g.copy())
    return np.array(qs), np.array(gs)


def taylor_decimal(Iinv, q0, g0, h, nsteps, order, every):
    """The same Taylor recursion for one state in decimal arithmetic (context precision), with
    plain loops (lists of Decimal)."""
    q, g = list(q0), list(g0)
    inv = [Decimal(1) / (k + 1) for k in range(order)]
    qs, gs = [list(q)], [list(g)]
    for step in range(nsteps):
        qc, gc, wc = [q], [g], [[g[i] * Iinv[i] for i in range(3)]]
        for k in range(order):
            c0 = c1 = c2 = p0 = p1 = p2 = p3 = Decimal(0)
            for j in range(k + 1):
                a, b, w = gc[j], qc[j], wc[k - j]
                c0 += a[1] * w[2] - a[2] * w[1]
                c1 += a[2] * w[0] - a[0] * w[2]
                c2 += a[0] * w[1] - a[1] * w[0]
                p0 -= b[1] * w[0] + b[2] * w[1] + b[3] * w[2]
                p1 += b[0] * w[0] + b[2] * w[2] - b[3] * w[1]
                p2 += b[0] * w[1] - b[1] * w[2] + b[3] * w[0]
                p3 += b[0] * w[2] + b[1] * w[1] - b[2] * w[0]
            f = inv[k]
            gk = [c0 * f, c1 * f, c2 * f]
            f = f / 2
            qc.append([p0 * f, p1 * f, p2 * f, p3 * f])
            gc.append(gk)
            wc.append([gk[i] * Iinv[i] for i in range(3)])
        qn, gn = list(qc[order]), list(gc[order])
        for k in range(order - 1, -1, -1):
            qn = [qn[i] * h + qc[k][i] for i in range(4)]
            gn = [gn[i] * h + gc[k][i] for i in range(3)]
        q, g = qn, gn
        if (step + 1) % every == 0:
            qs.append(list(q))
            gs.append(list(g))
    return np.array(qs, dtype=object), np.array(gs, dtype=object)


def rand_unit(rng, n=None):
    q = rng.normal(size=(4,) if n is None else (n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def state(q0, g0):
    q0 = np.asarray(q0, float)
    return q0, 2.0 * qmul(q0, pure(np.asarray(g0, float)))


def uniform_rotation(q0, g0, inertia, t):
    """Closed form for g an eigenvector of the inertia: q(t) = q0∘exp(ω t / 2)."""
    w = np.asarray(g0, float) / np.asarray(inertia, float)
    wn = np.linalg.norm(w)
    t = np.asarray(t, float)[:, None]
    if wn == 0:
        return np.broadcast_to(q0, (t.shape[0], 4))
    M = np.concatenate([np.cos(0.5 * wn * t), np.sin(0.5 * wn * t) * w / wn], axis=1)
    return qmul(np.broadcast_to(q0, M.shape), M)


def rates(inertia, g):
    """Largest angular rate of the problem (body rates and the elliptic frequency)."""
    return float(np.linalg.norm(g) / np.min(inertia))


# ------------------------------------------------------------------------------------------
# long-time accuracy against extended precision
# ------------------------------------------------------------------------------------------

# name: (inertia, g0, q0 or None for a random attitude)
LD_CASES = {
    "about largest axis": ((1.0, 2.0, 3.0), (0.3, 0.2, 0.9), None),
    "about smallest axis": ((1.0, 2.0, 3.0), (0.9, 0.3, 0.2), None),
    "unsorted, cyclic": ((3.0, 1.0, 2.0), (0.3, 0.2, 0.9), None),
    "unsorted, odd permutation": ((2.0, 1.0, 3.0), (-0.4, 0.7, 0.5), None),
    "oblate I1 = I2": ((1.0, 1.0, 1.5), (0.3, 0.2, 0.9), None),
    "prolate I2 = I3": ((1.0, 2.0, 2.0), (0.3, 0.2, 0.9), None),
    "axisymmetric, unsorted": ((2.0, 1.0, 2.0), (0.6, -0.2, 0.5), None),
    "sphere": ((2.0, 2.0, 2.0), (0.3, 0.2, 0.9), None),
    "spin about axis 3": ((1.0, 2.0, 3.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 0.0)),
    "spin about the middle axis": ((1.0, 2.0, 3.0), (0.0, 0.9, 0.0), (1.0, 0.0, 0.0, 0.0)),
    "near spin about axis 1": ((1.0, 2.0, 3.0), (0.8, 1e-7, -2e-7), None),
}


def _exact_g(q0, Q0, kind):
    """g0 = ½ vec(q̃0∘Q0) evaluated exactly enough (longdouble / Decimal) from the floats."""
    if kind == "ld":
        return body_momentum(q0.astype(LD), Q0.astype(LD))
    qd = np.array([Decimal(float(x)) for x in q0], dtype=object)
    Qd = np.array([Decimal(float(x)) for x in Q0], dtype=object)
    return body_momentum(qd, Qd)


def _compare(inertia, q0, Q0, ts, q_ref, g_ref):
    q, Q = torque_free(inertia, q0, Q0, ts)
    g = body_momentum(q, Q)
    G = np.linalg.norm(body_momentum(q0, Q0))
    g_ref = g_ref.astype(float)
    q_ref = q_ref.astype(float)
    Q_ref = 2.0 * qmul(q_ref, pure(g_ref))
    eg = np.max(np.abs(g - g_ref), axis=1) / G
    eq = np.max(np.abs(q - q_ref), axis=1)
    eQ = np.max(np.abs(Q - Q_ref), axis=1) / (2 * G)
    return eg, eq, eQ


def test_long_time_against_longdouble_taylor():
    """All non-separatrix regimes, t ≤ 1000 (≈ 1000 rad of rotation), vs a long-double Taylor
    integration (its own error is below 1e-16 here: rates ≤ 1, step 0.5 ≪ the distance ≥ 3 to
    the complex singularities of the solution, order 30)."""
    rng = np.random.default_rng(11)
    names = list(LD_CASES)
    Is, q0s, Q0s = [], [], []
    for name in names:
        inertia, g0, q0 = LD_CASES[name]
        q0 = rand_unit(rng) if q0 is None else np.array(q0)
        q0, Q0 = state(q0, g0)
        Is.append(inertia)
        q0s.append(q0)
        Q0s.append(Q0)
    q0s, Q0s = np.array(q0s), np.array(Q0s)
    g0s = _exact_g(q0s, Q0s, "ld")
    Iinv = LD(1) / np.array(Is, dtype=LD)
    h, nsteps, every = 0.5, 2000, 100
    q_ref, g_ref = taylor_longdouble(Iinv, q0s.astype(LD), g0s, LD(h), nsteps, 30, every)
    ts = np.arange(nsteps // every + 1) * (h * every)
    for b, name in enumerate(names):
        eg, eq, eQ = _compare(Is[b], q0s[b], Q0s[b], ts, q_ref[:, b], g_ref[:, b])
        tol = 2e-15 + 2 * EPS * rates(Is[b], g0s[b].astype(float)) * ts
        assert np.all(eg <= tol), (name, eg.max())
        assert np.all(eq <= tol), (name, eq.max())
        assert np.all(eQ <= tol), (name, eQ.max())
        assert eq.max() < 3e-13 and eg.max() < 3e-13, name


SEP_I = (3.0, 3.75, 5.0)  # I2 = 2 I1 I3/(I1 + I3): E_2 = (g3² − g1²)/4 exactly in floats


def test_separatrix_far_in_time():
    """On the separatrix the motion tends to the saddle (spin about the middle axis) for
    t → ±∞: g → (0, ±G, 0) exponentially, with T, |g| and |q| conserved and the output finite
    long after sech(λt) has underflowed (λ ≈ 0.1 here, λt up to 1e5)."""
    q0, Q0 = state(np.array([1.0, 0.0, 0.0, 0.0]), (1.0, 0.3, -1.0))
    g0 = body_momentum(q0, Q0)
    G = np.linalg.norm(g0)
    T0 = 0.5 * np.sum(g0 * g0 / np.array(SEP_I))
    ts = np.array([1e3, -1e3, 1e4, -1e4, 1e6])
    q, Q = torque_free(SEP_I, q0, Q0, ts)
    g = body_momentum(q, Q)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(Q))
    assert np.abs(np.abs(g[:, 1]) - G).max() < 1e-15 * G
    assert np.abs(g[:, [0, 2]]).max() < 1e-15 * G
    assert np.abs(0.5 * np.sum(g * g / np.array(SEP_I), axis=1) - T0).max() < 8 * EPS * T0
    assert np.abs(np.linalg.norm(q, axis=1) - 1.0).max() < 4 * EPS
    for t in ts:
        qf = X.free_flow(*SEP_I, q0, Q0, t)[0]
        assert np.all(np.isfinite(qf))


@pytest.mark.parametrize(
    ("name", "g0", "q0", "prec", "order", "tmax"),
    [
        ("on the separatrix", (1.0, 0.3, -1.0), (1.0, 0.0, 0.0, 0.0), 40, 36, 300.0),
        (
            "1e-8 inside, about axis 1",
            (1.0 + 1e-8, 0.3, -1.0),
            (0.5, 0.5, -0.5, 0.5),
            34,
            32,
            1000.0,
        ),
        ("1e-8 inside, about axis 3", (1.0 - 1e-8, 0.3, 1.0), None, 34, 32, 1000.0),
        ("1e-14 from the separatrix", (1.0 - 1e-14, -0.3, 1.0), None, 34, 32, 1000.0),
    ],
)
def test_separatrix_against_decimal_taylor(name, g0, q0, prec, order, tmax):
    """Near and on the separatrix vs a Taylor integration in decimal arithmetic (step 2, ≤ 1/7
    of the distance ≈ 15 to the complex singularities: truncation ≤ 1e-28 per step).

    Near it, a relative change of 1e-18 in g0 changes the solution by ~3e-11 at t = 1000
    (measured), so the reference needs more than long double. On it, the motion tends to the
    saddle (spin about the middle axis) and any error of a reference grows like e^{λ t}
    (λ ≈ 0.1 here): the comparison stops at t = 300 (e^{30} ≈ 1e13, reference error ≲ 1e-20).
    """
    rng = np.random.default_rng(len(name))
    q0 = rand_unit(rng) if q0 is None else np.array(q0)
    q0, Q0 = state(q0, g0)
    P = X.prepare(*SEP_I, q0, Q0, True)
    if name == "on the separatrix":
        assert P.kind == 2.0  # exactly on it: the hyperbolic branch
    else:
        assert P.kind == 1.0 and 0 < P.m1 < 3e-8
    h = 2.0
    nsteps = int(tmax / h)
    every = nsteps // 10
    with localcontext() as ctx:
        ctx.prec = prec
        gd = list(_exact_g(q0, Q0, "dec"))
        qd = [Decimal(float(x)) for x in q0]
        Iinv = [Decimal(1) / Decimal(x) for x in SEP_I]
        q_ref, g_ref = taylor_decimal(Iinv, qd, gd, Decimal(h), nsteps, order, every)
    q_ref, g_ref = q_ref[:, None], g_ref[:, None]
    ts = np.arange(nsteps // every + 1) * (h * every)
    eg, eq, eQ = _compare(SEP_I, q0, Q0, ts, q_ref[:, 0], g_ref[:, 0])
    tol = 2e-15 + 2 * EPS * rates(SEP_I, g0) * ts
    assert np.all(eg <= tol), eg
    assert np.all(eq <= tol), eq
    assert np.all(eQ <= tol), eQ


def test_random_bodies_against_dop853():
    """Random inertia (any order), states and both regimes vs scipy DOP853 (rtol 1e-13) at
    t ≤ 20; compared at 1e-9, which is DOP853's accuracy, not ours."""
    rng = np.random.default_rng(7)

    def rhs(t, y, inertia):
        q, g = y[:4], y[4:]
        w = g / inertia
        return np.concatenate([0.5 * qmul(q, pure(w)), np.cross(g, w)])

    regimes = set()
    for i in range(12):
        while True:
            inertia = rng.uniform(0.5, 2.0, 3)
            if all(inertia[i] <= inertia[(i + 1) % 3] + inertia[(i + 2) % 3] for i in range(3)):
                break
        g0 = rng.normal(size=3)
        q0, Q0 = state(rand_unit(rng), g0)
        P = X.prepare(*inertia, q0, Q0, True)
        regimes.add((P.kind, P.cidx))
        tend = 20.0 if i % 2 == 0 else -20.0  # backward in time too
        ts = np.linspace(0.0, tend, 9)
        sol = solve_ivp(
            rhs,
            (0, tend),
            np.r_[q0, g0],
            method="DOP853",
            rtol=1e-13,
            atol=1e-15,
            t_eval=ts,
            args=(inertia,),
        )
        q, Q = torque_free(inertia, q0, Q0, ts)
        assert np.abs(q - sol.y[:4].T).max() < 1e-9
        assert np.abs(body_momentum(q, Q) - sol.y[4:].T).max() < 1e-9 * np.linalg.norm(g0)
    assert regimes == {(1.0, 0.0), (1.0, 2.0)}  # both regimes were drawn


# ------------------------------------------------------------------------------------------
# closed forms and conservation
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("inertia", "g0"),
    [
        ((2.0, 2.0, 2.0), (0.3, -0.2, 0.9)),  # sphere: any g
        ((1.0, 2.0, 3.0), (0.0, 0.0, -1.3)),  # principal axes
        ((1.0, 2.0, 3.0), (0.7, 0.0, 0.0)),
        ((1.0, 2.0, 3.0), (0.0, 0.5, 0.0)),  # middle axis (unstable, still exact)
        ((1.0, 1.0, 1.5), (0.3, 0.4, 0.0)),  # axisymmetric, g in the equatorial plane
        ((1.0, 2.0, 2.0), (0.0, 0.3, -0.4)),
        ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0)),  # no angular momentum: q constant
    ],
)
def test_uniform_rotation_closed_form(inertia, g0):
    q0 = np.array([0.0, 0.0, 0.0, 1.0])  # exact, so g = g0 exactly
    q0, Q0 = state(q0, g0)
    ts = np.array([0.0, 0.1, 1.0, 10.0, 100.0, 1000.0])
    q, Q = torque_free(inertia, q0, Q0, ts)
    ref = uniform_rotation(q0, g0, inertia, ts)
    om = np.linalg.norm(np.asarray(g0) / inertia)
    assert np.all(np.abs(q - ref).max(axis=1) <= 2e-16 + 2 * EPS * om * ts)
    assert np.abs(body_momentum(q, Q) - g0).max() <= 2 * EPS * max(np.linalg.norm(g0), 1e-300)
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(Q))


def test_axisymmetric_precession_closed_form():
    """I1 = I2: g3 constant, (g1, g2) rotates at ν = g3 (1/I3 − 1/I1) (Landau & Lifshitz §33)."""
    I1, I3 = 1.3, 2.1
    q0, Q0 = state(np.array([1.0, 0.0, 0.0, 0.0]), (0.4, 0.0, 0.7))
    ts = np.linspace(0.0, 300.0, 31)
    _, Q = torque_free((I1, I1, I3), q0, Q0, ts)
    nu = 0.7 * (1 / I3 - 1 / I1)
    ref = np.stack([0.4 * np.cos(nu * ts), -0.4 * np.sin(nu * ts), 0.7 + 0 * ts], axis=1)
    g = body_momentum(*torque_free((I1, I1, I3), q0, Q0, ts))
    assert np.abs(g - ref).max() < 2e-15 + 2 * EPS * ts.max()
    assert Q.shape == (31, 4)


@pytest.mark.parametrize("seed", range(4))
def test_conservation_laws(seed):
    """Space angular momentum G = ½ vec(Q∘q̃), T, |q| and q·Q at t up to 1e5: M(t) is evaluated
    directly (not stepped), so these hold to a few ulp at any t."""
    rng = np.random.default_rng(100 + seed)
    inertia = np.sort(rng.uniform(1.0, 2.0, 3))[rng.permutation(3)]
    g0 = rng.normal(size=3)
    q0, Q0 = state(rand_unit(rng), g0)
    ts = np.concatenate([[0.0], 10.0 ** rng.uniform(-3, 5, 40), -(10.0 ** rng.uniform(-3, 3, 5))])
    q, Q = torque_free(inertia, q0, Q0, ts)
    G0 = 0.5 * qmul(Q0, conj(q0))[1:]
    Gs = 0.5 * qmul(Q, conj(q))[:, 1:]
    Gn = np.linalg.norm(G0)
    g = body_momentum(q, Q)
    T = 0.5 * np.sum(g * g / inertia, axis=1)
    T0 = 0.5 * np.sum(g0 * g0 / inertia)
    assert np.abs(Gs - G0).max() <= 8 * EPS * Gn
    assert np.abs(np.linalg.norm(g, axis=1) - Gn).max() <= 8 * EPS * Gn
    assert np.abs(T - T0).max() <= 8 * EPS * T0
    assert np.abs(np.linalg.norm(q, axis=1) - 1.0).max() <= 4 * EPS
    assert np.abs(np.sum(q * Q, axis=1)).max() <= 16 * EPS * Gn  # |Q| = 2 G


# ------------------------------------------------------------------------------------------
# axisymmetric and nearly axisymmetric bodies, every orientation of g
# ------------------------------------------------------------------------------------------


def symmetric_top(inertia, q0, Q0, ts, dps=40):
    """Closed-form motion of an axisymmetric body in mpmath (independent of the elliptic
    machinery): with e_s the symmetry axis, I⊥ the two equal moments, G = ½ vec(Q0∘q̃0) and
    ν = g_s (1/I_s − 1/I⊥), q(t) = exp_S(G t / I⊥)∘q0∘exp_B(ν t e_s), g(t) = exp_B(−ν t e_s) g0
    (a rotation about the space angular momentum and one about the body symmetry axis, Landau &
    Lifshitz §33); exp(v) = (cos ½|v|, sin ½|v| v/|v|). g0 = ½ vec(q̃0∘Q0) exactly from the
    floats. Returns q, g as float arrays (len(ts), 4), (len(ts), 3)."""
    import mpmath as mp

    with mp.workdps(dps):
        Iv = [mp.mpf(float(x)) for x in inertia]
        s = next(k for k in range(3) if Iv[(k + 1) % 3] == Iv[(k + 2) % 3])
        Ip = Iv[(s + 1) % 3]
        q = np.array([mp.mpf(float(x)) for x in q0], dtype=object)
        Q = np.array([mp.mpf(float(x)) for x in Q0], dtype=object)
        g = qmul(conj(q), Q)[1:] / 2
        Gs = qmul(Q, conj(q))[1:] / 2
        nu = g[s] * (1 / Iv[s] - 1 / Ip)
        Gn = mp.sqrt(sum(x * x for x in Gs))

        def expq(axis, angle):
            return np.array([mp.cos(angle / 2)] + [mp.sin(angle / 2) * a for a in axis], object)

        es = [mp.mpf(int(k == s)) for k in range(3)]
        qs, gs = [], []
        for t in ts:
            t = mp.mpf(float(t))
            R = expq([x / Gn for x in Gs], Gn * t / Ip) if Gn != 0 else expq(es, 0 * t)
            B = expq(es, nu * t)
            qs.append([float(x) for x in qmul(qmul(R, q), B)])
            gs.append([float(x) for x in qmul(qmul(conj(B), pure_obj(g)), B)[1:]])
    return np.array(qs), np.array(gs)


def pure_obj(v):
    return np.array([0 * v[0], *v], dtype=object)


# g_s / |g| of the relative orientations tried (0 and 1 exactly, underflow, slow precession)
AXI_GS = [0.0, 1e-300, 1e-160, 1e-23, 1e-16, 1e-12, 1e-6, 1e-3, 0.5, 1.0 - 1e-9, 1.0]


@pytest.mark.parametrize("s", [0, 1, 2])
@pytest.mark.parametrize("shape", ["prolate", "oblate"])
def test_axisymmetric_every_orientation_closed_form(s, shape):
    """Symmetry axis 1, 2 or 3, prolate (I_s < I⊥) or oblate, g from exactly perpendicular to
    exactly parallel to the symmetry axis: free_flow and torque_free vs the closed form, for
    small and large steps of either sign. (Before the addition-theorem evaluation, g nearly
    perpendicular — g_s/|g| ≲ 1e-6 — gave errors from 1e-10 up to radians per call.)"""
    rng = np.random.default_rng(10 * s + len(shape))
    inertia = [1.5, 1.5, 1.5]
    inertia[s] = 1.0 if shape == "prolate" else 2.5
    ts = np.array([0.0, 1e-6, 0.01, 1.0, -3.0, 100.0, 1000.0])
    others = [k for k in range(3) if k != s]
    worst = 0.0
    for gs in AXI_GS:
        for exact_q in (True, False):
            g = np.zeros(3)
            perp = rng.normal(size=2)
            g[others] = 0.8 * math.sqrt(1.0 - gs * gs) * perp / np.linalg.norm(perp)
            g[s] = 0.8 * gs
            # an exact q0 gives g exactly (g_s = 0 stays 0); a random one rounds it
            q0 = np.array([0.0, 0.0, 0.0, 1.0]) if exact_q else rand_unit(rng)
            q0, Q0 = state(q0, g)
            q_ref, g_ref = symmetric_top(inertia, q0, Q0, ts)
            q, Q = torque_free(inertia, q0, Q0, ts)
            tol = 2e-15 + 2 * EPS * rates(inertia, g) * np.abs(ts)
            eq = np.abs(q - q_ref).max(axis=1)
            eg = np.abs(body_momentum(q, Q) - g_ref).max(axis=1) / 0.8
            assert np.all(eq <= tol), (gs, exact_q, eq)
            assert np.all(eg <= tol), (gs, exact_q, eg)
            for k, t in enumerate(ts):
                qf = X.free_flow(*inertia, q0, Q0, t)[0]
                ef = np.abs(np.array(qf) - q_ref[k]).max()
                assert ef <= tol[k], (gs, exact_q, t, ef)
                worst = max(worst, ef)
    assert worst < 1e-13


@pytest.mark.parametrize("eta", [0.0, 1e-14, 1e-10, 1e-6])
@pytest.mark.parametrize("gs", [0.0, 1e-23, 1e-12, 1e-6, 0.3])
def test_nearly_axisymmetric_against_decimal_taylor(eta, gs):
    """I = (1, 2, 2(1 + η)) (η = 0: exactly axisymmetric; η > 0: the asymmetric elliptic branch
    with a slowly precessing g), g nearly perpendicular to the near-symmetry axis 1: vs a
    Taylor integration in decimal arithmetic, and continuity in η (the solutions for η and 0
    differ by O(η Ω t), not by a branch switch)."""
    inertia = (1.0, 2.0, 2.0 * (1.0 + eta))
    rng = np.random.default_rng(int(1e3 * gs) + int(-math.log10(eta)) if eta else 7)
    perp = rng.normal(size=2)
    g = np.array([gs, *(math.sqrt(1 - gs * gs) * perp / np.linalg.norm(perp))])
    q0, Q0 = state(rand_unit(rng), g)
    ts = (0.01, 3.0)
    with localcontext() as ctx:
        ctx.prec = 40
        gd = list(_exact_g(q0, Q0, "dec"))
        qd = [Decimal(float(x)) for x in q0]
        Iinv = [Decimal(1) / Decimal(x) for x in inertia]
        refs = [taylor_decimal(Iinv, qd, gd, Decimal(t) / 10, 10, 24, 10) for t in ts]
    q_axi, _ = symmetric_top((1.0, 2.0, 2.0), q0, Q0, ts)
    for k, (t, (q_ref, g_ref)) in enumerate(zip(ts, refs, strict=True)):
        q, Q = X.free_flow(*inertia, q0, Q0, t)
        tol = 2e-15 + 2 * EPS * t
        assert np.abs(np.array(q) - q_ref[-1].astype(float)).max() <= tol
        gq = body_momentum(np.array(q), np.array(Q))
        assert np.abs(gq - g_ref[-1].astype(float)).max() <= tol
        assert np.abs(np.array(q) - q_axi[k]).max() <= tol + eta * t


def test_pi_addition_theorem_against_quadrature():
    """The identity free_rotation uses for the increment of Legendre's Π:
    P(u + v) − P(u) − P(v) = (n/κ) atan(κ sn u sn v sn(u+v) / X), P(u) = ∫_0^u dw/(1 − n sn²w),
    κ² = n(n − m)(1 − n) ≥ 0, X = 1 − n (sn²(u+v) − sn u sn v cn(u+v) dn(u+v)), for n ∈ [−1, 0]
    (checked with mpmath quadrature at 30 digits, including m = 0, m = 1 and n = −1)."""
    import mpmath as mp

    rng = np.random.default_rng(4)
    with mp.workdps(30):
        for n, m in [(-0.3, 0.0), (-1.0, 0.5), (-0.2, 1.0), (0.0, 0.7)] + [
            (-rng.uniform(), rng.uniform()) for _ in range(4)
        ]:
            n, m = mp.mpf(n), mp.mpf(m)
            u, v = (mp.mpf(x) for x in rng.uniform(-3, 3, 2))
            w = u + v

            def P(x, n=n, m=m):
                return mp.quad(lambda y: 1 / (1 - n * mp.ellipfun("sn", y, m) ** 2), [0, x])

            su, sv, sw = (mp.ellipfun("sn", x, m) for x in (u, v, w))
            cw, dw = mp.ellipfun("cn", w, m), mp.ellipfun("dn", w, m)
            kap = mp.sqrt(n * (n - m) * (1 - n))
            Xw = 1 - n * (sw**2 - su * sv * cw * dw)
            z = su * sv * sw / Xw
            E = n * z * (mp.atan(kap * z) / (kap * z) if kap * z != 0 else 1)
            assert Xw >= 1
            assert abs(P(w) - P(u) - P(v) - E) < mp.mpf(10) ** -25


def test_composed_free_flow_has_no_energy_drift():
    """A composed free flow (as inside a splitting integrator) must not drift in T or |g|.

    Each call's M is applied exactly (rational arithmetic) to g, so only M's direction is
    measured: for a symmetric top g_s is conserved exactly, and its mean change per call over
    2000 calls of h = 0.01 must be far below the ~7e-17 systematic error (0.3 ulp, always the
    same sign) that forming M as a product of nearly cancelling O(1) quaternions gave. Then
    1e5 calls on a full state (q, Q): |ΔT|/T at the level of a random walk of the rounding
    (≲ 1e-13), not the ~2e-12 of a 2e-17-per-call bias."""
    from fractions import Fraction as F

    inertia = (1.0, 2.0, 2.0)
    w = (0.0, 1.0, 0.4, -1.4)
    d = []
    for _ in range(2000):
        M = [F(x) for x in X.free_flow(*inertia, (1.0, 0.0, 0.0, 0.0), w, 0.01)[0]]
        n2 = sum(x * x for x in M)
        v = [F(x) for x in w]
        # g ← M̃∘g∘M / |M|², exactly
        a = [
            M[0] * v[0] + M[1] * v[1] + M[2] * v[2] + M[3] * v[3],
            M[0] * v[1] - M[1] * v[0] - M[2] * v[3] + M[3] * v[2],
            M[0] * v[2] + M[1] * v[3] - M[2] * v[0] - M[3] * v[1],
            M[0] * v[3] - M[1] * v[2] + M[2] * v[1] - M[3] * v[0],
        ]
        gn = [
            a[0] * M[1] + a[1] * M[0] + a[2] * M[3] - a[3] * M[2],
            a[0] * M[2] - a[1] * M[3] + a[2] * M[0] + a[3] * M[1],
            a[0] * M[3] + a[1] * M[2] - a[2] * M[1] + a[3] * M[0],
        ]
        gn = [x / n2 for x in gn]
        d.append(float(gn[0] - v[1]))
        w = (0.0, *(float(x) for x in gn))
    assert abs(np.mean(d)) < 1e-18
    # full state: T and |g| after 1e5 calls
    inertia = (2.0, 2.0, 1.0)
    q0, Q0 = state(np.array([0.5, 0.5, -0.5, 0.5]), (0.3, 0.2, 0.9))
    q, Q = tuple(q0), tuple(Q0)
    for _ in range(100_000):
        q, Q = X.free_flow(*inertia, q, Q, 0.01)
    g0 = _exact_g(q0, Q0, "dec")
    g1 = _exact_g(np.array(q), np.array(Q), "dec")
    T0 = sum(g0[i] ** 2 / Decimal(inertia[i]) for i in range(3))
    T1 = sum(g1[i] ** 2 / Decimal(inertia[i]) for i in range(3))
    assert abs(float(T1 / T0 - 1)) < 3e-13
    assert abs(float(sum(x * x for x in g1) / sum(x * x for x in g0) - 1)) < 3e-13


# ------------------------------------------------------------------------------------------
# the compiled free flow (for splitting integrators)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("inertia", "g0"),
    [
        ((1.0, 2.0, 3.0), (0.3, 0.2, 0.9)),
        ((3.0, 2.0, 1.0), (0.9, 0.3, 0.2)),
        # closer to the separatrix each intermediate rounding of the state is amplified by the
        # motion itself (measured: a 1-ulp change of Q0 moves q(148) by 4e-12 at 1e-5 from
        # it, so 400 roundings give ~1e-10 for any stepping method), hence 1e-3 here
        (SEP_I, (1.0 - 1e-3, 0.3, 1.0)),
        ((1.0, 1.0, 2.0), (0.3, 0.2, 0.9)),
        # axisymmetric / nearly axisymmetric, g almost perpendicular to the symmetry axis
        # (slow precession: the factors D_p/λ of the attitude angle are huge)
        ((2.0, 1.0, 1.0), (1e-23, -1e-3, 1.5e-3)),
        ((1.0, 1.0, 2.0), (0.6, -0.8, 1e-12)),
        ((1.0, 2.0, 2.0 * (1.0 + 1e-10)), (1e-9, 0.6, 0.8)),
    ],
)
def test_free_flow_composition_equals_direct_evaluation(inertia, g0):
    rng = np.random.default_rng(3)
    q0, Q0 = state(rand_unit(rng), g0)
    h, n = 0.37, 400
    q, Q = tuple(q0), tuple(Q0)
    for _ in range(n):
        q, Q = X.free_flow(*inertia, q, Q, h)
    qd, Qd = torque_free(inertia, q0, Q0, n * h)
    G = np.linalg.norm(g0)
    # each step restarts from a rounded state: the errors add up to ~n eps (times 1 + Ω h)
    tol = 8 * n * EPS * (1 + rates(inertia, g0) * h)
    assert np.abs(np.array(q) - qd).max() < tol
    assert np.abs(np.array(Q) - Qd).max() < 2 * tol * G
    # backward flow undoes the forward flow
    # (the backward flow amplifies that round-off by the condition number of the motion,
    # ≈ 20 for the near-separatrix case)
    qb, _ = X.free_flow(*inertia, q, Q, -n * h)
    assert np.abs(np.array(qb) - q0).max() < 30 * tol
    y = np.r_[q0, Q0]
    X.free_flow_inplace(*inertia, y, h)
    q1, Q1 = X.free_flow(*inertia, q0, Q0, h)
    assert np.array_equal(y, np.r_[q1, Q1])


def test_free_flow_off_the_constraint_manifold_solves_eq7():
    """From |q| ≠ 1, q·Q ≠ 0 the free flow is the exact flow of H = ⅛ Σ_{i=1..3}
    (q̃∘Q)_i² / I_i in R⁸: q̇ = ½ q∘(0, ω), Q̇ = ½ Q∘(0, ω), ω = ½ vec(q̃∘Q) / I."""
    inertia = np.array([1.2, 0.9, 1.7])
    rng = np.random.default_rng(9)
    q0 = 1.05 * rand_unit(rng)
    Q0 = rng.normal(size=4)  # q0·Q0 ≠ 0

    def rhs(t, y):
        q, Q = y[:4], y[4:]
        w = 0.5 * qmul(conj(q), Q)[1:] / inertia
        return np.concatenate([0.5 * qmul(q, pure(w)), 0.5 * qmul(Q, pure(w))])

    ts = np.linspace(0, 15.0, 6)
    sol = solve_ivp(rhs, (0, 15.0), np.r_[q0, Q0], "DOP853", t_eval=ts, rtol=1e-13, atol=1e-15)
    for k, t in enumerate(ts):
        q, Q = X.free_flow(*inertia, q0, Q0, t)
        assert np.abs(np.array(q) - sol.y[:4, k]).max() < 1e-10
        assert np.abs(np.array(Q) - sol.y[4:, k]).max() < 1e-10
        assert abs(np.linalg.norm(q) - np.linalg.norm(q0)) < 4 * EPS
        assert abs(np.dot(q, Q) - np.dot(q0, Q0)) < 16 * EPS


def test_free_flow_is_symplectic():
    """Jacobian J of (q, Q) ↦ flow_h(q, Q) by central differences: Jᵀ Ω J = Ω (Ω the canonical
    form dq ∧ dQ on R⁸); the finite-difference error is ~1e-9."""
    inertia = (1.0, 2.0, 3.0)
    rng = np.random.default_rng(5)
    q0, Q0 = state(rand_unit(rng), (0.4, -0.7, 0.5))
    y0 = np.r_[q0, Q0]
    d = 1e-6
    J = np.empty((8, 8))
    for k in range(8):
        yp, ym = y0.copy(), y0.copy()
        yp[k] += d
        ym[k] -= d
        fp = np.concatenate(X.free_flow(*inertia, yp[:4], yp[4:], 2.5))
        fm = np.concatenate(X.free_flow(*inertia, ym[:4], ym[4:], 2.5))
        J[:, k] = (fp - fm) / (2 * d)
    Om = np.block([[np.zeros((4, 4)), np.eye(4)], [-np.eye(4), np.zeros((4, 4))]])
    assert np.abs(J.T @ Om @ J - Om).max() < 1e-7


def test_kernels_run_without_jit():
    """The kernels are valid Python (ATTITUDE_DISABLE_JIT=1) and agree with the compiled ones."""
    # axisymmetric, g almost perpendicular to the symmetry axis (the slow-precession case)
    Qaxi = state(np.array([0.5, 0.5, -0.5, 0.5]), (1e-20, 0.6, -0.8))[1].tolist()
    code = (
        "import numpy as np\n"
        "from attitude.exact import torque_free\n"
        "from attitude._core.exact import free_flow\n"
        "q0 = np.array([0.5, 0.5, -0.5, 0.5])\n"
        "for I, Q0 in [((1., 2., 3.), [0.1, 0.6, -0.2, 1.3]), ((3., 3.75, 5.), [0, 2., .6, -2.]),"
        " ((1., 1., 2.), [0.3, 0.2, 0.5, 0.1]), ((2., 2., 2.), [0., 1., 0., 0.]),"
        f" ((2., 1., 1.), {Qaxi!r})]:\n"
        "    Q0 = np.array(Q0, float); Q0 -= np.dot(q0, Q0) * q0\n"
        "    q, Q = torque_free(I, q0, Q0, [0.0, 3.0, -40.0, 700.0])\n"
        "    print(q.tolist(), Q.tolist(), free_flow(*I, q0, Q0, 3.0), sep='|')\n"
    )
    env = dict(os.environ, ATTITUDE_DISABLE_JIT="1", NUMBA_DISABLE_JIT="1")
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
    ).stdout
    q0 = np.array([0.5, 0.5, -0.5, 0.5])
    lines = out.strip().splitlines()
    cases = [
        ((1.0, 2.0, 3.0), [0.1, 0.6, -0.2, 1.3]),
        ((3.0, 3.75, 5.0), [0, 2.0, 0.6, -2.0]),
        ((1.0, 1.0, 2.0), [0.3, 0.2, 0.5, 0.1]),
        ((2.0, 2.0, 2.0), [0.0, 1.0, 0.0, 0.0]),
        ((2.0, 1.0, 1.0), Qaxi),
    ]
    for line, (inertia, Q0) in zip(lines, cases, strict=True):
        Q0 = np.array(Q0, float)
        Q0 -= np.dot(q0, Q0) * q0
        q, Q = torque_free(inertia, q0, Q0, [0.0, 3.0, -40.0, 700.0])
        pq, pQ, pf = (eval(part) for part in line.split("|"))
        assert np.abs(np.array(pq) - q).max() < 1e-14
        assert np.abs(np.array(pQ) - Q).max() < 1e-14 * np.linalg.norm(Q0)
        f = X.free_flow(*inertia, q0, Q0, 3.0)
        assert np.abs(np.array(pf) - np.array(f)).max() < 1e-14


# ------------------------------------------------------------------------------------------
# public interface
# ------------------------------------------------------------------------------------------


def test_public_shapes_units_and_alias():
    from astropy import units as astropy_units

    q0, Q0 = state(np.array([1.0, 0.0, 0.0, 0.0]), (0.3, 0.2, 0.9))
    q, Q = torque_free([1.0, 2.0, 3.0], q0, Q0, 2.0)
    assert q.shape == (4,) and Q.shape == (4,)
    qa, Qa = torque_free([1.0, 2.0, 3.0], q0, Q0, [2.0])
    assert qa.shape == (1, 4) and np.array_equal(qa[0], q) and np.array_equal(Qa[0], Q)
    qe, Qe = torque_free([1.0, 2.0, 3.0], q0, Q0, np.array([]))
    assert qe.shape == (0, 4) and Qe.shape == (0, 4)
    u = astropy_units
    # Quantities are converted to SI (kg m², kg m² s⁻¹, s; kg km² based before issue 16)
    qu, Qu = torque_free(
        [1.0, 2.0, 3.0] * u.kg * u.m**2, q0, Q0 * u.kg * u.m**2 / u.s, 2000.0 * u.ms
    )
    assert np.array_equal(qu, q) and np.array_equal(Qu, Q)
    qk, Qk = torque_free(
        [1.0, 2.0, 3.0] * u.kg * u.km**2, q0, Q0 * u.kg * u.km**2 / u.s, 2000.0 * u.ms
    )
    np.testing.assert_allclose(qk, q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(Qk, Q * 1e6, rtol=0, atol=1e-14 * 1e6)
    assert torque_free_states is torque_free
    # t = 0 returns the initial state (to round-off)
    q00, Q00 = torque_free([1.0, 2.0, 3.0], q0, Q0, 0.0)
    assert np.abs(q00 - q0).max() < 2 * EPS and np.abs(Q00 - Q0).max() < 4 * EPS


@pytest.mark.parametrize(
    ("args", "name"),
    [
        (([1.0, 2.0, 4.0], [1, 0, 0, 0], [0, 1, 0, 0], 1.0), "inertia"),  # triangle
        (([1.0, -2.0, 2.0], [1, 0, 0, 0], [0, 1, 0, 0], 1.0), "inertia"),
        (([1.0, 2.0], [1, 0, 0, 0], [0, 1, 0, 0], 1.0), "inertia"),
        (([1.0, 2.0, np.inf], [1, 0, 0, 0], [0, 1, 0, 0], 1.0), "inertia"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 1e-2], [0, 1, 0, 0], 1.0), "q0"),
        (([1.0, 2.0, 3.0], [0, 0, 0, 0], [0, 1, 0, 0], 1.0), "q0"),
        (([1.0, 2.0, 3.0], [[1, 0, 0, 0]], [0, 1, 0, 0], 1.0), "q0"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 0], [1e-3, 1, 0, 0], 1.0), "Q0"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 0], [0, 1, 0, np.nan], 1.0), "Q0"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 0], [0, 1, 0], 1.0), "Q0"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 0], [0, 1, 0, 0], [[1.0, 2.0]]), "t"),
        (([1.0, 2.0, 3.0], [1, 0, 0, 0], [0, 1, 0, 0], [1.0, np.nan]), "t"),
    ],
)
def test_bad_input_raises_naming_the_argument(args, name):
    with pytest.raises(AttitudeValueError, match=rf"^{name}"):
        torque_free(*args)


def test_small_and_large_scales():
    """The solution is homogeneous: scaling g by s scales time by 1/s; inertia by s scales
    time by s. Checked over 600 orders of magnitude (the kernels rescale by powers of two, so
    nothing under- or overflows and the results agree to round-off)."""
    inertia = np.array([1.0, 2.0, 3.0])
    q0 = np.array([0.5, 0.5, 0.5, -0.5])
    g0 = np.array([0.3, 0.2, 0.9])
    q0, Q0 = state(q0, g0)
    ts = np.linspace(0.0, 50.0, 11)
    qr, Qr = torque_free(inertia, q0, Q0, ts)
    for s in [1e-300, 1e-150, 1e-15, 1e-5, 1e5, 1e15, 1e150, 1e300]:
        q, Q = torque_free(inertia, q0, s * Q0, ts / s)
        assert np.abs(q - qr).max() < 1e-13 and np.abs(Q / s - Qr).max() < 1e-13
        q, Q = torque_free(s * inertia, q0, Q0, ts * s)
        assert np.abs(q - qr).max() < 1e-13 and np.abs(Q - Qr).max() < 1e-13
        q, Q = torque_free(s * inertia, q0, s * Q0, ts)
        assert np.abs(q - qr).max() < 1e-13 and np.abs(Q / s - Qr).max() < 1e-13
    # near the separatrix the double-double E_B must survive the scaling too
    q1, Q1 = state(np.array([1.0, 0.0, 0.0, 0.0]), (1.0 - 1e-12, 0.3, 1.0))
    qr, _ = torque_free(SEP_I, q1, Q1, [100.0])
    for s in [2.0**-900, 2.0**900]:
        q, _ = torque_free(SEP_I, q1, s * Q1, [100.0 / s])
        assert np.abs(q - qr).max() < 1e-13
    assert math.isfinite(float(np.sum(qr)))
