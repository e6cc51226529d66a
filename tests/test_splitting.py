"""The symplectic methods "nosquish" and "splitting" against independent truth.

Truth used here: the algebraic order conditions of the composition coefficients, DOP853 at tight
tolerance on eq. 7, the closed-form motion of the symmetric top, exact conservation laws (|q|,
q·Q, energy, the vertical angular momentum of the heavy top), time reversibility (a symmetric
method run backwards retraces its steps), and the observed convergence orders.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import mpmath
import numpy as np
import pytest

from attitude import canonical as C
from attitude import quaternion as qt
from attitude._core import splitting as ks
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import CustomPotential, CustomTorque, GravityGradient, HeavyTop
from attitude.propagate import propagate

I_PAPER = np.array([1.25, 1.0, 0.75])
q0_PRINTED = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
Q0_PRINTED = np.array([0.3, -0.848528, 0.141421, -1.5])
HEAVY = HeavyTop(0.5, [1.0, 0.0, 0.0])  # Arribas et al. Sect. 6.1
METHODS = ("nosquish", "splitting")
ORDERS = (2, 4, 6)


@pytest.fixture(scope="module")
def paper_state():
    q, Q, _ = C.project_state(q0_PRINTED, Q0_PRINTED)
    return q, Q


def _run(q0, Q0, t, method, order, dt, potential=None, inertia=I_PAPER, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return propagate(
            inertia, q0, Q0, t, potential=potential, method=method, dt=dt, order=order, **kw
        )


def _attitude_error(q, q_ref):
    return np.max(qt.angle_between(q, q_ref))


def _kepler_orbit():
    from orbit.keplerorbit import KeplerOrbit

    # Arribas et al. Sect. 6.2: a = 7000 km, e = 0.2, i = π/6, Ω = π/4, ω = π/12, f(t0) = 0.
    return KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12)


# --------------------------------------------------------------------------------------------
# Coefficients: the data satisfy the order conditions (independent algebra)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("order", ORDERS)
def test_composition_coefficients_satisfy_order_conditions(order):
    """Symmetric compositions of a symmetric 2nd-order method: Σγ = 1, Σγ³ = 0 (order 4),
    and Σγ⁵ = 0 (order 6) (Hairer, Lubich & Wanner, Sect. V.3)."""
    g = ks.COMPOSITION_GAMMA[order]
    np.testing.assert_array_equal(g, g[::-1])
    assert abs(g.sum() - 1.0) < 1e-15
    if order >= 4:
        assert abs(np.sum(g**3)) < 1e-14
    if order >= 6:
        assert abs(np.sum(g**5)) < 1e-14
    y = ks.YOSHIDA4_GAMMA
    assert abs(y.sum() - 1.0) < 1e-15 and abs(np.sum(y**3)) < 1e-14


@pytest.mark.parametrize("order", ORDERS)
def test_splitting_coefficients_are_consistent_and_palindromic(order):
    a, b = ks.SPLITTING_AB[order]
    assert a.size == b.size + 1
    np.testing.assert_allclose([a.sum(), b.sum()], [1.0, 1.0], atol=1e-15)
    np.testing.assert_array_equal(a, a[::-1])
    np.testing.assert_array_equal(b, b[::-1])
    for name in METHODS:
        kinds, coefs, toffs = ks.method_tables(name, order)
        assert kinds[0] == kinds[-1]
        # time offsets: the free flows (which advance t) add up to one step
        free = kinds != ks.KICK
        assert abs(coefs[free].sum() - 1.0) < 1e-14
        assert abs(coefs[~free].sum() - 1.0) < 1e-14
        np.testing.assert_allclose(toffs[::-1][~free[::-1]], 1.0 - toffs[~free], atol=1e-14)


# Order conditions, checked algebraically: the stage tables are multiplied out as a product of
# exponentials in the free associative algebra (words in non-commuting letters, truncated at
# weight p + 1, 40-digit arithmetic) and compared with the exact flow exp(T + U). Letters: T the
# free rigid body, U the potential (kick); the NO_SQUISH rotor is a symmetric 2nd-order
# approximation of the free flow, log ROTOR(τ) = τT + τ³P + τ⁵F with P, F free letters of
# weights 3 and 5 (nothing else is assumed about it). Order p means: every word of weight <= p
# has the same coefficient in both (Hairer, Lubich & Wanner, Sect. III.5 and V.3).
_WEIGHT = {"T": 1, "U": 1, "P": 3, "F": 5}


def _weight(word):
    return sum(_WEIGHT[c] for c in word)


def _free_mul(x, y, n):
    out = {}
    for w1, c1 in x.items():
        d1 = _weight(w1)
        for w2, c2 in y.items():
            if d1 + _weight(w2) <= n:
                out[w1 + w2] = out.get(w1 + w2, 0) + c1 * c2
    return out


def _free_exp(z, n):
    out = {"": mpmath.mpf(1)}
    term = {"": mpmath.mpf(1)}
    for k in range(1, n + 1):
        term = {w: c / k for w, c in _free_mul(term, z, n).items()}
        for w, c in term.items():
            out[w] = out.get(w, 0) + c
    return out


def _order_defects(kinds, coefs, n):
    """Largest |coefficient| of (method − exact flow) per word weight, up to weight n."""
    with mpmath.workdps(40):
        psi = {"": mpmath.mpf(1)}
        for kind, c in zip(kinds.tolist(), coefs.tolist(), strict=True):
            c = mpmath.mpf(c)  # the float64 data, exactly
            if kind == ks.KICK:
                z = {"U": c}
            elif kind == ks.FREE:
                z = {"T": c}
            else:
                assert kind == ks.ROTOR
                z = {"T": c, "P": c**3, "F": c**5}
            psi = _free_mul(psi, _free_exp(z, n), n)
        exact = _free_exp({"T": mpmath.mpf(1), "U": mpmath.mpf(1)}, n)
        out = dict.fromkeys(range(n + 1), 0.0)
        for w in set(psi) | set(exact):
            d = float(abs(psi.get(w, 0) - exact.get(w, 0)))
            out[_weight(w)] = max(out[_weight(w)], d)
    return out


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("order", ORDERS)
def test_stage_tables_satisfy_the_order_conditions(method, order):
    """The tables the stepper runs (merged kicks included) are of order exactly ``order``.
    Measured: every condition up to weight p holds to <= 1.4e-16 (the rounding of the
    15-digit published coefficients); the first non-vanishing defect at weight p + 1 is
    1e-5 or more."""
    kinds, coefs, _ = ks.method_tables(method, order)
    d = _order_defects(kinds, coefs, order + 1)
    assert max(d[k] for k in range(order + 1)) <= 1e-15, d
    assert d[order + 1] > 1e-6, d  # exactly of this order (the published method, not another)


def test_order_conditions_bind_a_perturbed_coefficient():
    """Palindromic and consistent (Σa = Σb = 1) is not enough: Blanes & Moan's S₁₀ with one
    outer coefficient pair changed in the 12th digit (middle one adjusted so Σa = 1 still)
    fails the order conditions."""
    a, b = ks.SPLITTING_AB[6]
    a = a.copy()
    a[1] += 1e-12
    a[-2] += 1e-12
    a[a.size // 2] -= 2e-12
    np.testing.assert_array_equal(a, a[::-1])
    kinds, coefs, _ = ks._ops_from_ab(a, b, ks.FREE, ks.KICK)
    d = _order_defects(kinds, coefs, 7)
    assert d[3] > 1e-13, d


# --------------------------------------------------------------------------------------------
# Convergence orders (fast)
# --------------------------------------------------------------------------------------------


def _observed_order(errors, dts):
    slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    return slope


# Step sizes where each method is in its asymptotic regime on the span used, with errors well
# above the ~1e-13 accuracy of the DOP853 reference.
CONVERGENCE_DTS = {
    ("nosquish", 2): (0.1, 0.05, 0.025),
    ("nosquish", 4): (0.2, 0.1, 0.05),
    ("nosquish", 6): (0.4, 0.2, 0.1),
    ("splitting", 2): (0.1, 0.05, 0.025),
    ("splitting", 4): (0.2, 0.1, 0.05),
    ("splitting", 6): (0.5, 0.25, 0.125),
}


@pytest.fixture(scope="module")
def heavy_top_reference(paper_state):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 10.0, 6)
    ref = propagate(I_PAPER, q0, Q0, t, potential=HEAVY, rtol=1e-14, atol=1e-16)
    return t, ref


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("order", ORDERS)
def test_observed_order_heavy_top(paper_state, heavy_top_reference, method, order):
    q0, Q0 = paper_state
    t, ref = heavy_top_reference
    dts = CONVERGENCE_DTS[(method, order)]
    errors = [
        _attitude_error(_run(q0, Q0, t, method, order, dt, HEAVY).q.values, ref.q.values)
        for dt in dts
    ]
    assert min(errors) > 1e-12, errors  # still far above the reference's error
    p = _observed_order(errors, dts)
    assert abs(p - order) <= 0.1, (p, errors)


@pytest.mark.parametrize("order", ORDERS)
def test_observed_order_nosquish_torque_free(paper_state, order):
    """The rotor splitting is not exact without torque: it converges at its order."""
    q0, Q0 = paper_state
    t = np.linspace(0.0, 10.0, 6)
    ref = propagate(I_PAPER, q0, Q0, t, rtol=1e-14, atol=1e-16)
    dts = CONVERGENCE_DTS[("nosquish", order)]
    errors = [
        _attitude_error(_run(q0, Q0, t, "nosquish", order, dt).q.values, ref.q.values) for dt in dts
    ]
    assert abs(_observed_order(errors, dts) - order) <= 0.1, errors


def _oscillating_weight(q, t):
    # V = W(t) (q∘c∘q̃)·s3 with c = e1: (q∘e1∘q̃)_3 = 2 (q1 q3 − q0 q2), made homogeneous of
    # degree 0 in q; W(t) = 0.5 (1 + 0.8 cos 1.7t).
    w = 0.5 * (1.0 + 0.8 * np.cos(1.7 * t))
    n2 = q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2
    return w * 2.0 * (q[1] * q[3] - q[0] * q[2]) / n2


def test_observed_order_time_dependent_potential(paper_state):
    """A strongly time-dependent potential (a heavy top whose weight oscillates, written as a
    CustomPotential): the extended-phase-space treatment of t keeps the full order (a kick at
    the wrong time would drop it to 1 or 2). Also exercises the user-kernel loop."""
    q0, Q0 = paper_state
    pot = CustomPotential(_oscillating_weight, time_dependent=True)
    t = np.linspace(0.0, 6.0, 4)
    ref = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    all_dts = {2: (0.1, 0.05, 0.025), 4: (0.2, 0.1, 0.05), 6: (0.25, 0.125, 0.0625)}
    for order, dts in all_dts.items():
        errors = [
            _attitude_error(_run(q0, Q0, t, "splitting", order, dt, pot).q.values, ref.q.values)
            for dt in dts
        ]
        assert abs(_observed_order(errors, dts) - order) <= 0.1, (order, errors)


# --------------------------------------------------------------------------------------------
# Exactness without torque, agreement with DOP853
# --------------------------------------------------------------------------------------------


def test_splitting_is_exact_for_the_symmetric_top():
    """I1 = I2 closed form (precession about G, spin ν = g3 (1/I3 − 1/I1)): the splitting
    without torque is the exact flow, so a huge step is as good as a small one."""
    inertia = np.array([2.0, 2.0, 0.7])
    rng = np.random.default_rng(3)
    q0 = qt.normalize(rng.normal(size=4))
    g0 = np.array([0.4, -0.9, 1.3])
    Q0 = C.momenta_from_body_angular_momentum(q0, g0)
    t = np.linspace(0.0, 200.0, 41)
    G = qt.rotate(q0, g0)
    nu = g0[2] * (1 / inertia[2] - 1 / inertia[0])
    prec = qt.from_rotation_vector(np.outer(t, G / inertia[0]))
    spin = qt.from_rotation_vector(np.outer(t, [0.0, 0.0, nu]))
    exact = qt.multiply(qt.multiply(prec, q0), spin)
    for order in ORDERS:
        ds = _run(q0, Q0, t, "splitting", order, 5.0, inertia=inertia)
        assert _attitude_error(ds.q.values, exact) < 5e-12  # round-off of ~400 free flows
    # the rotor splitting is not exact for it
    ds = _run(q0, Q0, t, "nosquish", 2, 5.0, inertia=inertia)
    assert _attitude_error(ds.q.values, exact) > 1e-3


def test_axisymmetric_heavy_top_from_rest_splitting():
    """A symmetric body (I1 = I2) released from rest under gravity with an off-axis centre of
    mass: the kicks make g almost perpendicular to e3, the delicate case of the free flow."""
    _axisymmetric_from_rest("splitting")


def test_axisymmetric_heavy_top_from_rest_nosquish():
    _axisymmetric_from_rest("nosquish")


def _axisymmetric_from_rest(method):
    inertia = np.array([2.0, 2.0, 1.0])
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = np.zeros(4)
    pot = HeavyTop(0.5, [0.3, 0.2, 0.1])
    t = np.linspace(0.0, 2.0, 5)
    ref = propagate(inertia, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    for order, tol in ((2, 1e-6), (4, 1e-9), (6, 1e-11)):  # truncation errors at dt = 0.01
        ds = _run(q0, Q0, t, method, order, 0.01, pot, inertia=inertia)
        assert _attitude_error(ds.q.values, ref.q.values) < tol, order


@pytest.mark.parametrize("method", METHODS)
def test_agrees_with_dop853_at_small_steps(paper_state, method):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 20.0, 21)
    for pot in (None, HEAVY):
        ref = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
        ds = _run(q0, Q0, t, method, 6, 0.02, pot)
        assert _attitude_error(ds.q.values, ref.q.values) < 1e-11
        np.testing.assert_allclose(ds.Q.values, ref.Q.values, atol=1e-11)
        np.testing.assert_allclose(ds.omega.values, ref.omega.values, atol=1e-11)


def test_user_kernels_give_the_builtin_results(paper_state):
    """The heavy top written as a CustomTorque runs through the generic (uncached) loop and
    must give the built-in potential's numbers."""
    q0, Q0 = paper_state

    def tau(q, t):
        # τ_B = c × F_B, F_B = q̃∘(−W s3)∘q, c = e1, W = 0.5
        w = 0.5
        fy = -w * 2.0 * (q[2] * q[3] + q[0] * q[1])
        fz = -w * (q[0] ** 2 - q[1] ** 2 - q[2] ** 2 + q[3] ** 2)
        return (0.0, -fz, fy)

    pot = CustomTorque(tau)
    t = np.linspace(0.0, 5.0, 6)
    for method in METHODS:
        a = _run(q0, Q0, t, method, 4, 0.05, pot)
        b = _run(q0, Q0, t, method, 4, 0.05, HEAVY)
        np.testing.assert_allclose(a.q.values, b.q.values, atol=1e-14)


# --------------------------------------------------------------------------------------------
# Geometric properties (fast versions; the 1e6-step runs are marked slow below)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("order", ORDERS)
def test_forward_then_backward_returns_to_start(paper_state, method, order):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 50.0, 11)
    fwd = _run(q0, Q0, t, method, order, 0.05, HEAVY)
    back = _run(fwd.q.values[-1], fwd.Q.values[-1], t[::-1], method, order, 0.05, HEAVY)
    # 1000 steps out and back: round-off only (symmetric methods: Φ_{−h} = Φ_h⁻¹)
    assert np.max(np.abs(back.q.values[-1] - q0)) < 3e-12
    assert np.max(np.abs(back.Q.values[-1] - Q0)) < 3e-12
    # and every intermediate output is retraced
    assert np.max(np.abs(back.q.values[::-1] - fwd.q.values)) < 3e-12


@pytest.mark.parametrize("method", METHODS)
def test_reversible_with_the_gravity_gradient(paper_state, method):
    """Time-dependent potential (orbit-driven): reversibility in the extended phase space."""
    orbit = _kepler_orbit()
    q0, Q0 = paper_state
    inertia = np.array([400.0, 500.0, 600.0])  # Arribas et al. Sect. 6.2 (kg km²)
    pot = GravityGradient(orbit)
    t = np.linspace(0.0, orbit.period, 5)
    fwd = _run(q0, Q0, t, method, 4, 20.0, pot, inertia=inertia)
    back = _run(fwd.q.values[-1], fwd.Q.values[-1], t[::-1], method, 4, 20.0, pot, inertia=inertia)
    assert np.max(np.abs(back.q.values[-1] - q0)) < 1e-12
    assert np.max(np.abs(back.Q.values[-1] - Q0)) < 1e-12


def test_gravity_gradient_agrees_with_dop853(paper_state):
    """Arribas et al. Sect. 6.2 over one orbit: both methods agree with DOP853."""
    orbit = _kepler_orbit()
    q0, Q0 = paper_state
    inertia = np.array([400.0, 500.0, 600.0])
    pot = GravityGradient(orbit)
    t = np.linspace(0.0, orbit.period, 9)
    ref = propagate(inertia, q0, Q0, t, potential=pot, rtol=1e-13, atol=1e-15)
    errs = {}
    for method in METHODS:
        ds = _run(q0, Q0, t, method, 4, 10.0, pot, inertia=inertia)
        errs[method] = _attitude_error(ds.q.values, ref.q.values)
        assert np.max(np.abs(ds.norm_error.values)) < 1e-13
    assert errs["splitting"] < 1e-9 and errs["nosquish"] < 1e-8, errs
    assert errs["splitting"] < errs["nosquish"], errs


def test_splitting_error_scales_with_the_torque(paper_state):
    """Near-integrable case (weak heavy top, W = 0.01): the splitting's error is proportional to
    the perturbation, so it beats the rotor splitting by orders of magnitude at the same step;
    and halving the torque halves the splitting's error."""
    q0, Q0 = paper_state
    t = np.linspace(0.0, 10.0, 6)
    errs = {}
    for w in (0.01, 0.005):
        pot = HeavyTop(w, [1.0, 0.0, 0.0])
        ref = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
        for method in METHODS:
            ds = _run(q0, Q0, t, method, 4, 0.2, pot)
            errs[method, w] = _attitude_error(ds.q.values, ref.q.values)
    assert errs["splitting", 0.01] < 1e-2 * errs["nosquish", 0.01], errs
    assert 1.8 < errs["splitting", 0.01] / errs["splitting", 0.005] < 2.2, errs


@pytest.mark.parametrize("method", METHODS)
def test_invariants_and_bounded_energy_short(paper_state, method):
    """2e5 steps of the order-2 methods on the heavy top: invariants at round-off, energy error
    oscillating with no drift, the vertical angular momentum G3 (a symmetry: rotations about
    s3) conserved to round-off by every sub-flow."""
    q0, Q0 = paper_state
    dt = 0.01
    t = np.arange(0, 200_001, 100) * dt
    ds = _run(q0, Q0, t, method, 2, dt, HEAVY)
    assert np.max(np.abs(ds.norm_error.values)) < 1e-13
    assert np.max(np.abs(ds.qQ.values)) <= 1e-15  # measured 4.4e-16 (both methods)
    dE = np.abs(ds.energy.values - ds.energy.values[0])
    n10 = dE.size // 10
    assert 1e-8 < np.max(dE[1:n10]) < 1e-4
    assert np.max(dE[-n10:]) <= 1.2 * np.max(dE[1:n10])
    G3 = ds.G.values[:, 2]
    assert np.max(np.abs(G3 - G3[0])) < 1e-12


# --------------------------------------------------------------------------------------------
# Output times, chunking, streaming, validation
# --------------------------------------------------------------------------------------------


def test_output_times_need_not_be_multiples_of_dt(paper_state):
    """Each output interval is split into equal steps <= dt: outputs land exactly, and the
    result converges like the method."""
    q0, Q0 = paper_state
    t = np.array([0.0, 0.35, 1.0, 1.013, 3.7])
    ref = propagate(I_PAPER, q0, Q0, t, potential=HEAVY, rtol=1e-14, atol=1e-16)
    ds = _run(q0, Q0, t, "splitting", 6, 0.01, HEAVY)
    np.testing.assert_array_equal(ds.time.values, t)
    assert _attitude_error(ds.q.values, ref.q.values) < 1e-12
    # steps: ceil of each interval / dt
    assert ds.attrs["n_steps"] == 35 + 65 + 2 + 269


def test_steps_equal_dt_for_commensurate_outputs():
    # t = k·dt computed in floating point must not gain a step to round-off
    for dt in (0.1, 0.01, 0.3, 1e-3):
        for k in (1, 3, 7, 10, 1000):
            assert ks.n_steps_for(k * dt, dt) == k
            assert ks.n_steps_for(np.arange(k + 1)[-1] * dt, dt) == k
    assert ks.n_steps_for(0.35, 0.1) == 4


@pytest.mark.parametrize("method", METHODS)
def test_chunked_and_streamed_runs_are_identical(paper_state, method):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 10.0, 23)
    full = _run(q0, Q0, t, method, 4, 0.07, HEAVY)
    chunked = _run(q0, Q0, t, method, 4, 0.07, HEAVY, chunk=5)
    np.testing.assert_array_equal(full.q.values, chunked.q.values)
    np.testing.assert_array_equal(full.Q.values, chunked.Q.values)
    parts = []
    last = _run(q0, Q0, t, method, 4, 0.07, HEAVY, chunk=4, on_chunk=parts.append)
    qs = np.concatenate([p.q.values for p in parts])
    np.testing.assert_array_equal(qs, full.q.values)
    np.testing.assert_array_equal(last.q.values[-1], full.q.values[-1])
    progress = []
    _run(q0, Q0, t, method, 4, 0.07, HEAVY, chunk=10, progress=lambda *a: progress.append(a))
    assert [p[0] for p in progress] == [10, 20, 23]
    assert progress[-1][2] == t[-1]


def test_attrs_record_method_order_and_work(paper_state):
    q0, Q0 = paper_state
    ds = _run(q0, Q0, [0.0, 1.0], "nosquish", 6, 0.1, HEAVY)
    assert ds.attrs["method"] == "nosquish"
    assert ds.attrs["order"] == 6 and ds.attrs["dt"] == 0.1
    assert ds.attrs["n_steps"] == 10
    # 9 stages; the first and last kicks of consecutive steps are merged
    assert ds.attrs["n_free_flow"] == 90
    assert ds.attrs["n_torque"] == 10 * 9 + 1


@pytest.mark.parametrize("method", METHODS)
def test_bad_options_are_rejected_before_work(paper_state, method):
    q0, Q0 = paper_state
    with pytest.raises(AttitudeValueError, match="dt"):
        propagate(I_PAPER, q0, Q0, [0.0, 1.0], method=method)
    for bad in (3, 8, 0):
        with pytest.raises(AttitudeValueError, match="order"):
            propagate(I_PAPER, q0, Q0, [0.0, 1.0], method=method, dt=0.1, order=bad)
    with pytest.raises(AttitudeTypeError, match="order"):
        propagate(I_PAPER, q0, Q0, [0.0, 1.0], method=method, dt=0.1, order=4.0)
    with pytest.raises(AttitudeValueError, match="dt"):
        propagate(I_PAPER, q0, Q0, [0.0, 1.0], method=method, dt=-0.1)
    with pytest.raises(AttitudeValueError, match="max_steps"):
        propagate(I_PAPER, q0, Q0, [0.0, 10.0], method=method, dt=1e-3, max_steps=100)


def test_kernels_run_with_jit_disabled(paper_state):
    """The compiled loop is valid Python: the same numbers with ATTITUDE_DISABLE_JIT=1."""
    q0, Q0 = paper_state
    code = (
        "import numpy as np, sys\n"
        "from attitude.propagate import propagate\n"
        "from attitude.potentials import HeavyTop\n"
        f"q0 = np.array({q0.tolist()}); Q0 = np.array({Q0.tolist()})\n"
        "out = []\n"
        "for m in ('nosquish', 'splitting'):\n"
        "    ds = propagate([1.25, 1.0, 0.75], q0, Q0, [0.0, 0.5, 1.0],"
        " potential=HeavyTop(0.5, [1, 0, 0]), method=m, dt=0.1, order=4)\n"
        "    out.append(ds.q.values)\n"
        "np.save(sys.argv[1], np.array(out))\n"
    )
    out = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"nojit_split_{os.getpid()}.npy")
    env = {**os.environ, "ATTITUDE_DISABLE_JIT": "1"}
    subprocess.run([sys.executable, "-c", code, out], check=True, env=env, timeout=300)
    nojit = np.load(out)
    os.remove(out)
    for i, m in enumerate(METHODS):
        ds = _run(q0, Q0, [0.0, 0.5, 1.0], m, 4, 0.1, HEAVY)
        np.testing.assert_allclose(nojit[i], ds.q.values, atol=1e-14)


# --------------------------------------------------------------------------------------------
# 1e6-step runs (slow)
# --------------------------------------------------------------------------------------------

# Steps chosen so the truncation part of the energy error is well above the accumulated
# round-off (with the exact free flow fixed, order-6 splitting on the heavy top gives
# last/first = 1.00 at dt = 0.25 as well as at 0.3).
LONG_DT = {
    ("nosquish", 2): 0.01,
    ("nosquish", 4): 0.05,
    ("nosquish", 6): 0.1,
    ("splitting", 2): 0.01,
    ("splitting", 4): 0.1,
    ("splitting", 6): 0.25,
}


@pytest.mark.slow
@pytest.mark.parametrize("case", ["torque_free", "heavy_top"])
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("order", ORDERS)
def test_million_steps(paper_state, case, method, order):
    q0, Q0 = paper_state
    pot = HEAVY if case == "heavy_top" else None
    dt = LONG_DT[(method, order)]
    t = np.arange(0, 1_000_001, 100) * dt
    ds = _run(q0, Q0, t, method, order, dt, pot)
    assert ds.attrs["n_steps"] == 1_000_000
    # measured over the 12 runs: max abs(abs(q) - 1) 5.4e-14 to 6.4e-13, max abs(q.Q) 4.2e-16
    # to 5.0e-16 (docs/integrators.md: q.Q = w0 is never touched, only converted at outputs)
    assert np.max(np.abs(ds.norm_error.values)) <= 1e-12
    assert np.max(np.abs(ds.qQ.values)) <= 1.5e-15
    E = ds.energy.values
    dE = np.abs(E - E[0])
    n10 = dE.size // 10
    first, last = np.max(dE[1:n10]), np.max(dE[-n10:])
    if method == "splitting" and case == "torque_free":
        # The exact flow: no truncation error at all, only accumulated round-off (a random walk,
        # so the last/first ratio is noise; measured max |ΔE|/E ≤ 4.4e-13 over 1e6 steps).
        assert np.max(dE) < 1e-12 * abs(E[0])
    else:
        assert last <= 1.2 * first, (first, last)
