"""Torque models that add up and depend on the body rates (attitude.potentials.Sum, CustomTorque).

Checks: a sum's torque is the sum of its terms' torques to round-off; a sum of one model is that
model (bit for bit); built-in sums run on the package's cached entry points; a rate-dependent
damping torque on a spherical body follows its closed form; energies count the conservative
terms only; the per-model torque output adds up to the torque that drives the motion.
"""

from __future__ import annotations

import numpy as np
import pytest

import attitude
from attitude import CustomTorque, GravityGradient, HeavyTop, TorqueFree
from attitude import quaternion as qt
from attitude._core import entry_points as builtin_entry_points
from attitude.canonical import momenta_from_angular_velocity
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import Sum
from orbit import KeplerOrbit

I_SAT = np.array([400.0, 500.0, 600.0]) * 1e-6  # kg km2 (the paper's satellite)
ORBIT = KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12)
RNG = np.random.default_rng(7)


def _const_torque(q, t):
    return (1e-9, -2e-9, 3e-9)


def _const_potential(q, t):
    return 0.0


def _damping(q, omega, t):
    return -2.5e-3 * omega


def _random_unit(n):
    return qt.normalize(RNG.normal(size=(n, 4)))


def test_sum_of_terms_is_the_sum_of_their_torques():
    gg = GravityGradient(ORBIT, inertia=I_SAT)
    ht = HeavyTop(1e-6, [1e-3, 0.0, 2e-3])
    ct = CustomTorque(_const_torque)
    q = _random_unit(50)
    t = RNG.uniform(0.0, ORBIT.period, 50)
    for model, parts in (((gg + ht), (gg, ht)), ((gg + ct + ht), (gg, ct, ht))):
        want = sum(p.torque(q, t) for p in parts)
        got = model.torque(q, t)
        scale = max(np.max(np.abs(p.torque(q, t))) for p in parts)
        np.testing.assert_allclose(got, want, rtol=0, atol=4e-16 * scale)
    # U of the conservative terms only (the custom torque has none)
    np.testing.assert_allclose(
        (gg + ct + ht).value(q, t), gg.value(q, t) + ht.value(q, t), rtol=1e-15, atol=0
    )


def test_sum_of_one_model_is_that_model_and_builtin_sums_use_the_cached_kernels():
    gg = GravityGradient(ORBIT)
    assert Sum(gg) is gg
    assert (gg + TorqueFree()) is gg and (TorqueFree() + gg) is gg
    assert isinstance(TorqueFree() + TorqueFree(), TorqueFree)
    assert sum([gg]) is gg
    # a sum of sums is flat; built-in terms first in the compiled order
    ct = CustomTorque(_const_torque)
    s = ct + (gg + HeavyTop(1.0, [0, 0, 1]))
    assert [t.name for t in s.terms] == ["gravity_gradient", "heavy_top", "custom_torque"]
    assert (gg + HeavyTop(1.0, [0, 0, 1]))._entry_points() is builtin_entry_points
    assert s._entry_points() is not builtin_entry_points
    # bit for bit: a propagation with GG alone and with GG + TorqueFree
    q0 = qt.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = momenta_from_angular_velocity(q0, [1e-3, 0.0, 2e-3], I_SAT)
    t = np.linspace(0.0, 2000.0, 21)
    a = attitude.propagate(I_SAT, q0, Q0, t, potential=gg, rtol=1e-12)
    b = attitude.propagate(I_SAT, q0, Q0, t, potential=gg + TorqueFree(), rtol=1e-12)
    assert np.array_equal(a.q.values, b.q.values) and np.array_equal(a.Q.values, b.Q.values)


def test_term_names_are_unique_and_label_the_torque_output():
    s = CustomTorque(_const_torque) + CustomTorque(_const_torque) + GravityGradient(ORBIT)
    assert s.term_names() == ["gravity_gradient", "custom_torque", "custom_torque_2"]
    with pytest.raises(AttitudeValueError, match="name"):
        CustomTorque(_const_torque, name="not an identifier")


def test_per_model_torque_adds_up_to_the_driving_torque():
    gg = GravityGradient(ORBIT)
    ct = CustomTorque(_const_torque, potential=_const_potential, name="thruster")
    q0 = qt.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = momenta_from_angular_velocity(q0, [1e-3, 0.0, 2e-3], I_SAT)
    t = np.linspace(0.0, 3000.0, 31)
    ds = attitude.propagate(I_SAT, q0, Q0, t, potential=gg + ct, rtol=1e-12)
    assert list(ds.model_label.values) == ["gravity_gradient", "thruster", "total"]
    tau = ds.torque.values
    # each term against its own model evaluated at the run's attitudes
    np.testing.assert_allclose(
        tau[:, 0], GravityGradient(ORBIT, inertia=I_SAT).torque(ds.q.values, t), rtol=1e-13
    )
    np.testing.assert_allclose(tau[:, 1], np.broadcast_to([1e-9, -2e-9, 3e-9], (31, 3)))
    np.testing.assert_allclose(tau[:, 2], tau[:, 0] + tau[:, 1], rtol=0, atol=1e-24)
    # dG/dt = total torque in space axes (Euler's second law), central differences of a run
    h = 1.0
    dense = attitude.propagate(
        I_SAT, q0, Q0, [0.0, h, 2 * h], potential=gg + ct, rtol=1e-13, atol=1e-16
    )
    dG = (dense.G.values[2] - dense.G.values[0]) / (2 * h)
    tau_s = qt.rotate(dense.q.values[1], dense.torque.values[1, 2])
    np.testing.assert_allclose(dG, tau_s, rtol=1e-5)


_SLOW = pytest.mark.slow  # compiles the user model into another formulation (~8 s each)


@pytest.mark.parametrize(
    ("form", "atol"),
    [
        ("canonical", 1e-11),
        pytest.param("euler_equations", 1e-8, marks=_SLOW),
        pytest.param("schwab", 1e-8, marks=_SLOW),
        pytest.param("euler_angles", 1e-8, marks=_SLOW),
    ],
)
def test_rate_damping_on_a_sphere_follows_the_closed_form(form, atol):
    # I = i 1: I dω/dt = −k ω (the gyroscopic term vanishes), so ω(t) = ω0 exp(−k t / i); ω
    # reaches the torque in each formulation
    i, k = 2.0, 2.5e-3
    w0 = np.array([0.3, -0.2, 0.5])
    q0 = qt.from_euler([0.1, 0.2, 0.3], "313")
    Q0 = momenta_from_angular_velocity(q0, w0, [i, i, i])
    t = np.linspace(0.0, 2000.0, 41)
    pot = CustomTorque(_damping, name="damper")
    assert pot.rate_dependent and not pot.has_potential
    ds = attitude.propagate(
        [i, i, i], q0, Q0, t, potential=pot, rtol=1e-12, atol=1e-14, formulation=form
    )
    want = w0[None, :] * np.exp(-k * t / i)[:, None]
    np.testing.assert_allclose(ds.omega.values, want, rtol=0, atol=atol)
    if form == "canonical":
        # the attitude turns about the fixed axis w0 by ∫|ω| dt = |w0| i/k (1 − e^{−kt/i})
        angle = np.linalg.norm(w0) * i / k * (1.0 - np.exp(-k * t / i))
        axis = w0 / np.linalg.norm(w0)
        q_want = qt.multiply(q0, qt.from_axis_angle(axis, angle))
        assert np.max(qt.angle_between(ds.q.values, q_want)) < 1e-9


def test_rate_dependent_models_need_omega_and_refuse_the_splittings():
    pot = CustomTorque(_damping)
    q = np.array([1.0, 0, 0, 0])
    with pytest.raises(AttitudeValueError, match="omega"):
        pot.torque(q)
    np.testing.assert_allclose(pot.torque(q, omega=[1.0, 2.0, 3.0]), [-2.5e-3, -5e-3, -7.5e-3])
    q0 = qt.from_euler([0.1, 0.2, 0.3], "313")
    Q0 = momenta_from_angular_velocity(q0, [0.1, 0, 0], [1.0, 1.0, 1.0])
    for method in ("splitting", "nosquish"):
        with pytest.raises(AttitudeValueError, match="body rates"):
            attitude.propagate(
                [1, 1, 1], q0, Q0, [0.0, 1.0], potential=pot + GravityGradient(ORBIT),
                method=method, dt=0.1,
            )  # fmt: skip
    with pytest.raises(AttitudeTypeError, match="tau"):
        CustomTorque(lambda q: (0.0, 0.0, 0.0))
    with pytest.raises(AttitudeTypeError, match="model"):
        Sum(GravityGradient(ORBIT), "not a model")


def test_energy_counts_the_conservative_terms_and_names_the_others():
    ht = HeavyTop(0.5, [1.0, 0.0, 0.0])
    ct = CustomTorque(_damping, name="damper")
    q0 = np.array([0.5, -(0.5**0.5), 0.0, 0.5])
    Q0 = momenta_from_angular_velocity(q0, [0.2, -0.1, 0.3], [1.25, 1.0, 0.75])
    t = np.linspace(0.0, 20.0, 4001)
    ds = attitude.propagate([1.25, 1.0, 0.75], q0, Q0, t, potential=ht + ct, rtol=1e-12)
    assert ds.attrs["terms_without_potential"] == "damper"
    np.testing.assert_allclose(
        ds.potential_energy.values, ht.value(ds.q.values), rtol=1e-14, atol=1e-15
    )
    # the damper only takes energy out: dH/dt = ω·τ_damper = −k|ω|² < 0
    assert np.all(np.diff(ds.energy.values) < 0)
    dH = np.gradient(ds.energy.values, t)
    want = -2.5e-3 * np.sum(ds.omega.values**2, axis=1)
    np.testing.assert_allclose(dH[5:-5], want[5:-5], rtol=1e-4)
