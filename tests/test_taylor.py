"""method="taylor": Taylor coefficients against mpmath, accuracy against the exact solution and
dop853, conservation against dop853 at equal tolerance, dense output, chunking, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import orbit
from attitude import quaternion as qt
from attitude._core import taylor as kt
from attitude.body import RigidBody
from attitude.canonical import project_state
from attitude.errors import AttitudeValueError
from attitude.exact import torque_free
from attitude.potentials import (
    CustomPotential,
    CustomTorque,
    GravityGradient,
    HeavyTop,
    TorqueFree,
    as_potential,
)
from attitude.propagate import Problem, propagate
from attitude.scenario import load
from attitude.taylor import TaylorStepper

mp = pytest.importorskip("mpmath")

ROOT = Path(__file__).resolve().parents[1]
I_PAPER = np.array([1.25, 1.0, 0.75])
Q0_RAW = (np.array([0.5, -1 / math.sqrt(2), 0.0, 0.5]), np.array([0.3, -0.848528, 0.141421, -1.5]))
HEAVY = HeavyTop(0.5, [1.0, 0.0, 0.0])


def paper_state():
    q, Q, _ = project_state(*Q0_RAW)
    return q, Q


def gg_orbit():
    return orbit.KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12, f0=0.0)


def problem(inertia, potential, y0, t):
    body = RigidBody(inertia)
    pot = as_potential(potential).bind(body)
    return Problem(
        body, pot, pot._params(body.inertia), np.asarray(y0, float), t, pot._entry_points()
    )


# ---------------------------------------------------------------------------------------------
# Taylor coefficients against an independent mpmath expansion of eq. 7 as written
# (term-by-term series arithmetic on q̃∘Q, q∘ω, Q∘ω, 2 q∘τ; no Euler-equation shortcut).
class S:
    """Truncated power series with mpmath coefficients (length fixed by the operands)."""

    def __init__(self, c):
        self.c = list(c)

    def _other(self, o):
        if isinstance(o, S):
            return o.c
        return [mp.mpf(o)] + [mp.mpf(0)] * (len(self.c) - 1)

    def __add__(self, o):
        return S([a + b for a, b in zip(self.c, self._other(o), strict=True)])

    __radd__ = __add__

    def __sub__(self, o):
        return S([a - b for a, b in zip(self.c, self._other(o), strict=True)])

    def __neg__(self):
        return S([-a for a in self.c])

    def __mul__(self, o):
        if not isinstance(o, S):
            return S([a * o for a in self.c])
        n = len(self.c)
        return S([mp.fsum(self.c[j] * o.c[k - j] for j in range(k + 1)) for k in range(n)])

    __rmul__ = __mul__


def mul_vec(a, v):
    return (
        -a[1] * v[0] - a[2] * v[1] - a[3] * v[2],
        a[0] * v[0] + a[2] * v[2] - a[3] * v[1],
        a[0] * v[1] - a[1] * v[2] + a[3] * v[0],
        a[0] * v[2] + a[1] * v[1] - a[2] * v[0],
    )


def rotate_inverse(q, v):
    # vec(q̃∘(0, v)∘q) = v − 2w (u × v)... written as the full quaternion product (any |q|)
    w, x, y, z = q[0], -q[1], -q[2], -q[3]
    # p = q̃∘(0, v)
    p0 = -x * v[0] - y * v[1] - z * v[2]
    p1 = w * v[0] + y * v[2] - z * v[1]
    p2 = w * v[1] - x * v[2] + z * v[0]
    p3 = w * v[2] + x * v[1] - y * v[0]
    # p∘q, vector part
    a0, a1, a2, a3 = q
    return (
        p0 * a1 + p1 * a0 + p2 * a3 - p3 * a2,
        p0 * a2 - p1 * a3 + p2 * a0 + p3 * a1,
        p0 * a3 + p1 * a2 - p2 * a1 + p3 * a0,
    )


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def mp_series(y0, inertia, p, torque):
    """Taylor coefficients (p + 1, 8) of eq. 7's solution through y0, in mpmath.

    ``torque(q_series, K)`` returns the body torque as three series of length K.
    """
    I = [mp.mpf(float(x)) for x in inertia]
    coef = [[mp.mpf(float(v))] for v in y0]
    for k in range(p):
        K = k + 1
        x = [S(c[:K]) for c in coef]
        q, Q = x[:4], x[4:]
        w1 = q[0] * Q[1] - q[1] * Q[0] - q[2] * Q[3] + q[3] * Q[2]
        w2 = q[0] * Q[2] + q[1] * Q[3] - q[2] * Q[0] - q[3] * Q[1]
        w3 = q[0] * Q[3] - q[1] * Q[2] + q[2] * Q[1] - q[3] * Q[0]
        om = (w1 * (mp.mpf(0.5) / I[0]), w2 * (mp.mpf(0.5) / I[1]), w3 * (mp.mpf(0.5) / I[2]))
        a = mul_vec(q, om)
        b = mul_vec(Q, om)
        tau = torque(q, K)
        c = mul_vec(q, tau) if tau is not None else None
        for i in range(4):
            coef[i].append(a[i].c[k] / (2 * (k + 1)))
            f = b[i].c[k] / 2 + (2 * c[i].c[k] if c is not None else 0)
            coef[4 + i].append(f / (k + 1))
    return np.array([[float(v) for v in c] for c in coef]).T


def ours(params, y0, t, p):
    work, _, _ = kt.new_state()
    work[kt.Y, :8] = y0
    n, c = kt._initial_row(work, t, params)
    kt.taylor_coefficients(work, p, params, n, c)
    return work[: p + 1, :8].copy()


def assert_coefficients_close(a, b, tol):
    # order by order, relative to the size of that order's coefficients in each block
    for k in range(a.shape[0]):
        for blk in (slice(0, 4), slice(4, 8)):
            scale = np.max(np.abs(b[k, blk]))
            assert np.max(np.abs(a[k, blk] - b[k, blk])) <= tol * scale + 1e-300, (k, blk)


def test_coefficients_torque_free_and_heavy_top_against_mpmath():
    mp.mp.dps = 40
    q, Q = paper_state()
    y0 = np.concatenate([q, Q])
    p = 16
    for pot, torque in (
        (TorqueFree(), lambda qs, K: None),
        (
            HEAVY,
            lambda qs, K: cross(
                [S([mp.mpf(v)] + [mp.mpf(0)] * (K - 1)) for v in (1.0, 0.0, 0.0)],
                rotate_inverse(qs, [S([mp.mpf(v)] + [mp.mpf(0)] * (K - 1)) for v in (0, 0, -0.5)]),
            ),
        ),
    ):
        params = pot._params(I_PAPER)
        ref = mp_series(y0, I_PAPER, p, torque)
        got = ours(params, y0, 0.0, p)
        assert_coefficients_close(got, ref, 1e-13)
        # the comparison is relative order by order, and no order vanishes (ρ ≈ 9 here)
        assert np.min(np.max(np.abs(ref), axis=1)) > 1e-20


def _mp_kepler_functions(o):
    """Exact (mpmath) unit radial vector and 3μ/r³ of the orbit, as functions of t."""
    a, e, inc, raan, argp = (mp.mpf(float(x)) for x in (o.a, o.e, o.inc, o.raan, o.argp))
    mu = mp.mpf(float(o.mu))
    n = mp.sqrt(mu / a**3)
    M0 = mp.mpf(float(o.M0))
    t0 = mp.mpf(float(o.t0))
    cO, sO, ci, si = mp.cos(raan), mp.sin(raan), mp.cos(inc), mp.sin(inc)

    def state(t):
        M = M0 + n * (t - t0)
        E = mp.findroot(lambda E: E - e * mp.sin(E) - M, M + e * mp.sin(M))
        r = a * (1 - e * mp.cos(E))
        f = 2 * mp.atan2(mp.sqrt(1 + e) * mp.sin(E / 2), mp.sqrt(1 - e) * mp.cos(E / 2))
        u = argp + f
        cu, su = mp.cos(u), mp.sin(u)
        x = (cO * cu - sO * ci * su, sO * cu + cO * ci * su, si * su)
        return r, x

    return state, mu


def test_coefficients_gravity_gradient_against_mpmath():
    mp.mp.dps = 40
    o = gg_orbit()
    inertia = np.array([400.0, 500.0, 600.0])
    q, Q = paper_state()
    y0 = np.concatenate([q, Q])
    t_start = 1234.5
    p = 12
    state, mu = _mp_kepler_functions(o)
    tm = mp.mpf(t_start)
    # Series of the radial unit vector and of 3μ/r³ by mpmath's numerical differentiation of
    # the exact Kepler motion (independent of any recurrence).
    xs = [mp.taylor(lambda t, i=i: state(t)[1][i], tm, p) for i in range(3)]
    ks = mp.taylor(lambda t: 3 * mu / state(t)[0] ** 3, tm, p)
    Iv = [mp.mpf(float(v)) for v in inertia]

    def torque(qs, K):
        x = [S(c[:K]) for c in xs]
        xb = rotate_inverse(qs, x)
        ixb = [xb[i] * Iv[i] for i in range(3)]
        k = S(ks[:K])
        return tuple(k * v for v in cross(xb, ixb))

    ref = mp_series(y0, inertia, p, torque)
    got = ours(GravityGradient(o)._params(inertia), y0, t_start, p)
    assert_coefficients_close(got, ref, 1e-11)
    assert np.max(np.abs(ref[p, 4:])) > 0.0


# ---------------------------------------------------------------------------------------------
# Accuracy against independent solutions.
def test_torque_free_against_exact_solution():
    q0, Q0 = paper_state()
    t = np.linspace(0.0, 200.0, 401)
    tq, tQ = torque_free(I_PAPER, q0, Q0, t)
    for rtol, bound in ((1e-10, 1e-8), (1e-13, 1e-11), (1e-15, 1e-12)):
        ds = propagate(I_PAPER, q0, Q0, t, method="taylor", rtol=rtol, atol=rtol * 1e-2)
        err = np.max(qt.angle_between(ds.q.values, tq))
        errQ = np.max(np.abs(ds.Q.values - tQ))
        assert err < bound and errQ < bound, (rtol, err, errQ)
        assert ds.attrs["method"] == "taylor" and ds.attrs["order"] == kt.order_from_tolerance(rtol)


@pytest.mark.parametrize("pot", [TorqueFree(), HEAVY], ids=["torque_free", "heavy_top"])
def test_agrees_with_dop853(pot):
    q0, Q0 = paper_state()
    t = np.linspace(0.0, 100.0, 1001)
    ref = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    for rtol, bound in ((1e-10, 1e-7), (1e-13, 1e-10)):
        ds = propagate(I_PAPER, q0, Q0, t, potential=pot, method="taylor", rtol=rtol, atol=1e-16)
        assert float(np.max(np.abs(ds.q - ref.q))) < bound
        assert float(np.max(np.abs(ds.Q - ref.Q))) < bound
        assert float(np.max(np.abs(ds.omega - ref.omega))) < 10 * bound


def test_gravity_gradient_paper_case_agrees_with_dop853():
    """Sect. 6.2 (scenarios/paper_keplerian.toml): one orbit, 1201 outputs."""
    sc = load(ROOT / "scenarios/paper_keplerian.toml")
    ref = sc.run(rtol=1e-14, atol=1e-16)
    for rtol, bound in ((1e-9, 1e-8), (1e-12, 1e-10)):
        ds = sc.run(method="taylor", rtol=rtol, atol=rtol * 1e-2)
        assert ds.attrs["method"] == "taylor"
        assert float(np.max(np.abs(ds.q - ref.q))) < bound
        q_scale = float(np.max(np.abs(ref.Q)))  # |Q| ~ 1.7e6 kg m²/s (the scenario is in SI)
        assert float(np.max(np.abs(ds.Q - ref.Q))) < bound * 2 * q_scale
        np.testing.assert_array_equal(ds.r.values, ref.r.values)  # the same analytic orbit
        # H is not conserved (U depends on t): compare it with dop853's, relative
        e_ref = np.abs(ref.energy.values).max()
        assert float(np.max(np.abs(ds.energy - ref.energy))) < bound * e_ref


def test_gravity_gradient_ten_orbits_and_hyperbolic():
    q0, Q0 = paper_state()
    inertia = np.array([400.0, 500.0, 600.0])
    o = gg_orbit()
    t = np.linspace(0.0, 10 * o.period, 2001)
    pot = GravityGradient(o)
    ref = propagate(inertia, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    ds = propagate(inertia, q0, Q0, t, potential=pot, method="taylor", rtol=1e-12, atol=1e-14)
    assert float(np.max(np.abs(ds.q - ref.q))) < 1e-9
    # a hyperbolic fly-by: the Kepler restart handles e > 1 too
    h = orbit.KeplerOrbit(-20000.0, 1.5, 0.3, 0.2, 0.1, f0=-1.0)
    t = np.linspace(0.0, 4000.0, 41)
    pot = GravityGradient(h)
    ref = propagate(inertia, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    ds = propagate(inertia, q0, Q0, t, potential=pot, method="taylor", rtol=1e-13, atol=1e-15)
    assert float(np.max(np.abs(ds.q - ref.q))) < 1e-10


# ---------------------------------------------------------------------------------------------
# Conservation, measured for both methods at the same tolerance.
@pytest.mark.parametrize("pot", [TorqueFree(), HEAVY], ids=["torque_free", "heavy_top"])
@pytest.mark.parametrize("rtol", [1e-10, 1e-13])
def test_conserves_like_dop853(pot, rtol):
    q0, Q0 = paper_state()
    t = np.linspace(0.0, 1000.0, 2001)
    drift = {}
    for method in ("dop853", "taylor"):
        ds = propagate(I_PAPER, q0, Q0, t, potential=pot, method=method, rtol=rtol, atol=1e-16)
        e = ds.energy.values
        drift[method] = (
            np.max(np.abs(e - e[0])) / abs(e[0]),
            np.max(np.abs(ds.norm_error.values)),
            np.max(np.abs(ds.qQ.values)),
        )
    d, tay = drift["dop853"], drift["taylor"]
    # energy: no worse than dop853 (a factor 3 of slack) or below 1e-13 relative
    assert tay[0] <= max(3 * d[0], 1e-13), drift
    # |q| and q·Q: Q's series is q∘(c, 2g)/n, so q·Q stays at round-off; |q| like H
    assert tay[1] <= max(3 * d[1], 1e-13), drift
    assert tay[2] <= max(3 * d[2], 1e-13), drift


# ---------------------------------------------------------------------------------------------
# Dense output, chunking, backward runs, the step polynomial.
def test_dense_output_matches_step_ends_and_chunks():
    q0, Q0 = paper_state()
    t = np.linspace(0.0, 50.0, 777)
    full = propagate(I_PAPER, q0, Q0, t, potential=HEAVY, method="taylor", rtol=1e-12)
    chunked = propagate(I_PAPER, q0, Q0, t, potential=HEAVY, method="taylor", rtol=1e-12, chunk=5)
    np.testing.assert_array_equal(full.q.values, chunked.q.values)
    np.testing.assert_array_equal(full.Q.values, chunked.Q.values)
    # the same steps with only the end point requested: the dense samples at t lie on the
    # polynomials of those steps, which the stepper reproduces
    y0 = np.concatenate([full.q.values[0], full.Q.values[0]])  # the projected initial state
    pr = problem(I_PAPER, HEAVY, y0, t)
    st = TaylorStepper(pr, rtol=1e-12, atol=1e-12, t_end=50.0)
    j = 1
    while st.t < 50.0:
        st.step()
        while j < t.size and t[j] <= st.t:
            y = st.dense(t[j])
            np.testing.assert_array_equal(y, np.concatenate([full.q[j], full.Q[j]]))
            j += 1
    assert j == t.size
    assert st.coefficients.shape == (st.order + 1, 8)
    with pytest.raises(AttitudeValueError, match="outside the last step"):
        st.dense(-1.0)


def test_backward_returns_to_start():
    q0, Q0 = paper_state()
    fwd = propagate(I_PAPER, q0, Q0, [0.0, 30.0], potential=HEAVY, method="taylor", rtol=1e-14)
    y1 = np.concatenate([fwd.q.values[-1], fwd.Q.values[-1]])
    back = propagate(I_PAPER, y1[:4], y1[4:], [30.0, 0.0], potential=HEAVY, method="taylor",
                     rtol=1e-14)  # fmt: skip
    assert np.max(np.abs(back.q.values[-1] - q0)) < 1e-11


def test_streaming_on_chunk():
    q0, Q0 = paper_state()
    t = np.linspace(0.0, 10.0, 101)
    got = []
    ds = propagate(I_PAPER, q0, Q0, t, method="taylor", chunk=30, on_chunk=got.append)
    full = propagate(I_PAPER, q0, Q0, t, method="taylor")
    assert [g.sizes["time"] for g in got] == [30, 30, 30, 11]
    np.testing.assert_array_equal(np.concatenate([g.q.values for g in got]), full.q.values)
    assert ds.sizes["time"] == 1


# ---------------------------------------------------------------------------------------------
# Errors.
def test_user_potentials_rejected_with_the_method_named():
    q0, Q0 = paper_state()

    def U(q, t):
        return 0.1 * q[0] * q[0]

    def tau(q, t):
        return (0.0, 0.0, 1e-3)

    for pot in (CustomPotential(U), CustomTorque(tau)):
        with pytest.raises(AttitudeValueError, match=r"method: 'taylor'.*dop853"):
            propagate(I_PAPER, q0, Q0, [0.0, 1.0], potential=pot, method="taylor")


def test_not_for_other_formulations():
    q0, Q0 = paper_state()
    with pytest.raises(AttitudeValueError, match="taylor"):
        propagate(I_PAPER, q0, Q0, [0.0, 1.0], method="taylor", formulation="schwab")


def test_stepper_from_state_locates_a_crossing_on_the_polynomial():
    """Event-style use: bisection on the step polynomial finds where q0 crosses zero; the
    crossing agrees with a dense-output propagate at that time."""
    q0, Q0 = paper_state()
    st = TaylorStepper.from_state(I_PAPER, q0, Q0, 0.0, 20.0, HEAVY, rtol=1e-13, atol=1e-15)
    assert st.order == kt.order_from_tolerance(1e-13)
    s_prev = st.y[0]
    crossing = None
    while st.t < 20.0 and crossing is None:
        st.step()
        if np.sign(st.y[0]) != np.sign(s_prev):
            lo, hi = st.t_old, st.t
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if np.sign(st.dense(mid)[0]) == np.sign(s_prev):
                    lo = mid
                else:
                    hi = mid
            crossing = 0.5 * (lo + hi)
        s_prev = st.y[0]
    assert crossing is not None
    ds = propagate(I_PAPER, q0, Q0, [0.0, crossing], potential=HEAVY, rtol=1e-14, atol=1e-16)
    assert abs(float(ds.q[-1, 0])) < 1e-12
    with pytest.raises(AttitudeValueError, match="method: 'taylor'"):
        TaylorStepper.from_state(
            I_PAPER, q0, Q0, 0.0, 1.0, CustomTorque(lambda q, t: (0.0, 0.0, 0.0))
        )
