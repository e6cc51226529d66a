"""Potentials: torques against finite differences of U, the generalised force of Schwab eq. 25,
user potentials by complex step, and gravity-gradient physics (Arribas et al. eq. 20)."""

from __future__ import annotations

import numpy as np
import pytest

import orbit
from attitude import canonical as C
from attitude import quaternion as qt
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import (
    CustomPotential,
    CustomTorque,
    GravityGradient,
    HeavyTop,
    TorqueFree,
)
from attitude.propagate import METHODS, propagate

I_SAT = np.array([400.0, 500.0, 600.0])  # kg km², Arribas et al. Sect. 6.2


def paper_orbit(e=0.2):
    return orbit.KeplerOrbit(7000.0, e, np.pi / 6, np.pi / 4, np.pi / 12, f0=0.0)


def fd_torque(pot, q, t, h=1e-6):
    """τ_k = −dU/dθ_k for the body rotation q∘exp(θ e_k / 2), by central differences."""
    tau = np.empty(3)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        up = pot.value(qt.multiply(q, qt.from_rotation_vector(e)), t)
        um = pot.value(qt.multiply(q, qt.from_rotation_vector(-e)), t)
        tau[k] = -(up - um) / (2 * h)
    return tau


@pytest.mark.parametrize(
    "pot",
    [
        HeavyTop(0.5, [0.7, 0.2, -0.3]),  # c_x != 1: not the kind code in params[3]
        GravityGradient(paper_orbit(), inertia=I_SAT),
    ],
    ids=["heavy_top", "gravity_gradient"],
)
def test_torque_is_minus_derivative_of_potential(pot):
    rng = np.random.default_rng(20)
    for _ in range(5):
        q = qt.normalize(rng.normal(size=4))
        t = rng.uniform(0, 6000)
        tau = pot.torque(q, t)
        ref = fd_torque(pot, q, t)
        scale = np.max(np.abs(ref)) + 1e-300
        np.testing.assert_allclose(tau, ref, atol=2e-8 * scale)


def test_generalized_force_is_minus_tangential_gradient():
    """2 q∘(0, τ) = −(∇U − (q·∇U) q) for the quadratic form of eq. 18 (Schwab eq. 25)."""
    W, c = 0.5, np.array([0.7, 0.2, -0.3])
    pot = HeavyTop(W, c)

    def U4(q):  # V = W (q∘c∘q̃)·s3 written with Schwab's eq. 7 matrix: quadratic in q
        q0, q1, q2, q3 = q
        row3 = np.array(
            [2 * (q3 * q1 - q0 * q2), 2 * (q3 * q2 + q0 * q1), q0**2 - q1**2 - q2**2 + q3**2]
        )
        return W * row3 @ c

    rng = np.random.default_rng(21)
    q = qt.normalize(rng.normal(size=4))
    h = 1e-6
    grad = np.array([(U4(q + h * e) - U4(q - h * e)) / (2 * h) for e in np.eye(4)])
    tangential = grad - np.dot(q, grad) * q
    np.testing.assert_allclose(pot.generalized_force(q), -tangential, atol=1e-9)
    # and it is orthogonal to q: |q| and q·Q are invariants of the flow
    assert abs(np.dot(pot.generalized_force(q), q)) < 1e-15


def test_torque_free_has_no_potential_energy():
    """No potential: U = 0 exactly and H = T = ½ ω·g (found by cosmic-ray: a torque-free
    potential energy of 1 survived, shifting every energy by a constant)."""
    rng = np.random.default_rng(24)
    q = qt.normalize(rng.normal(size=(6, 4)))
    assert np.all(TorqueFree().value(q) == 0.0)
    assert np.all(TorqueFree().torque(q) == 0.0)
    q0, Q0, _ = C.project_state([0.5, -(0.5**0.5), 0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    ds = propagate([1.25, 1.0, 0.75], q0, Q0, np.linspace(0.0, 5.0, 6))
    assert np.all(ds.potential_energy.values == 0.0)
    T = 0.5 * np.sum(ds.omega.values * ds.g.values, axis=1)
    np.testing.assert_allclose(ds.energy.values, T, rtol=1e-14)


def test_heavy_top_sign_is_physical():
    """V = W z_c: the hanging top has the lower energy (eq. 18 as printed has the other sign)."""
    pot = HeavyTop(2.0, [0.0, 0.0, 1.5])  # centre of mass on b3
    upright = np.array([1.0, 0.0, 0.0, 0.0])  # b3 = s3
    hanging = qt.from_axis_angle([1.0, 0.0, 0.0], np.pi)  # b3 = −s3
    assert pot.value(upright) == pytest.approx(3.0)
    assert pot.value(hanging) == pytest.approx(-3.0)
    # a slight tilt of the upright top is pushed further over (unstable), of the hanging one back
    tilt = qt.from_axis_angle([1.0, 0.0, 0.0], 0.1)
    assert pot.torque(tilt)[0] > 0
    assert pot.torque(qt.multiply(hanging, tilt))[0] < 0


def test_custom_potential_matches_builtin_heavy_top():
    """The heavy top as a user potential U(q, t) (complex-step torque) = the built-in kernel."""
    W, cx, cy, cz = 0.5, 0.7, 0.2, -0.3  # c_x != 1 (the heavy-top kind code is 1)

    def U(q, t):
        q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
        return W * (
            2 * (q3 * q1 - q0 * q2) * cx
            + 2 * (q3 * q2 + q0 * q1) * cy
            + (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) * cz
        )

    user = CustomPotential(U)
    builtin = HeavyTop(W, [cx, cy, cz])
    rng = np.random.default_rng(22)
    q = qt.normalize(rng.normal(size=(10, 4)))
    np.testing.assert_allclose(user.torque(q), builtin.torque(q), atol=1e-15)
    np.testing.assert_allclose(user.value(q), builtin.value(q), atol=1e-15)
    # and inside the integrator
    q0, Q0, _ = C.project_state([0.5, -(0.5**0.5), 0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    t = np.linspace(0, 20, 11)
    a = propagate([1.25, 1.0, 0.75], q0, Q0, t, potential=user, rtol=1e-12, atol=1e-14)
    b = propagate([1.25, 1.0, 0.75], q0, Q0, t, potential=builtin, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(a.q.values, b.q.values, atol=1e-12)
    np.testing.assert_allclose(a.energy.values, b.energy.values, atol=1e-12)


def test_magnetic_dipole_example():
    """U = −m·B_B with B_B = q̃∘B∘q: τ = m × B_B (docs/potentials.md example)."""
    m = np.array([0.1, -0.2, 0.3])
    B = np.array([0.0, 2.0, 1.0])

    def U(q, t):
        # B in body axes: rotate_inverse written out (works for complex q: complex step)
        w, x, y, z = q[0], q[1], q[2], q[3]
        bx = (
            (w * w + x * x - y * y - z * z) * B[0]
            + 2 * (x * y + w * z) * B[1]
            + 2 * (x * z - w * y) * B[2]
        )
        by = (
            2 * (x * y - w * z) * B[0]
            + (w * w - x * x + y * y - z * z) * B[1]
            + 2 * (y * z + w * x) * B[2]
        )
        bz = (
            2 * (x * z + w * y) * B[0]
            + 2 * (y * z - w * x) * B[1]
            + (w * w - x * x - y * y + z * z) * B[2]
        )
        return -(m[0] * bx + m[1] * by + m[2] * bz)

    pot = CustomPotential(U, time_dependent=False)
    rng = np.random.default_rng(23)
    q = qt.normalize(rng.normal(size=(8, 4)))
    Bb = qt.rotate_inverse(q, B)
    np.testing.assert_allclose(pot.torque(q), np.cross(m, Bb), atol=1e-15)
    np.testing.assert_allclose(pot.value(q), -(Bb @ m), atol=1e-15)


def test_user_potential_errors():
    import math

    def bad(q, t):  # math.sqrt does not take a complex argument
        return math.sqrt(q[0] * q[0])

    with pytest.raises(AttitudeTypeError, match="potential"):
        CustomPotential(bad)

    def bad_torque(q, t):
        return (1.0, 2.0)

    with pytest.raises(AttitudeTypeError, match="torque"):
        CustomTorque(bad_torque)
    with pytest.raises(AttitudeValueError, match="weight"):
        HeavyTop(-1.0, [1, 0, 0])
    with pytest.raises(AttitudeValueError, match="center_of_mass"):
        HeavyTop(1.0, [1, 0])
    with pytest.raises(AttitudeTypeError, match="orbit"):
        GravityGradient("LEO")
    with pytest.raises(AttitudeValueError, match="inertia"):
        GravityGradient(paper_orbit()).value([1, 0, 0, 0])
    assert TorqueFree().torque([1, 0, 0, 0]).tolist() == [0.0, 0.0, 0.0]


def test_gravity_gradient_uses_orbit_geometry():
    """Eq. 20 against the MacCullagh expression evaluated from the orbit state directly."""
    o = paper_orbit()
    pot = GravityGradient(o, inertia=I_SAT)
    rng = np.random.default_rng(24)
    for t in (0.0, 1234.5, 5000.0):
        q = qt.normalize(rng.normal(size=4))
        r, _ = o.to_state(t)
        rn = np.linalg.norm(r)
        xb = qt.rotate_inverse(q, r / rn)
        U = 3 * o.mu / (2 * rn**3) * xb @ (I_SAT * xb)
        assert pot.value(q, t) == pytest.approx(U, rel=1e-13)
        np.testing.assert_allclose(
            pot.torque(q, t), 3 * o.mu / rn**3 * np.cross(xb, I_SAT * xb), rtol=1e-12
        )


def test_jacobi_integral_circular_orbit():
    """Circular orbit: H − n G·ĥ is conserved (the potential is steady in the orbital frame)."""
    o = orbit.KeplerOrbit(7000.0, 0.0, 0.4, 0.3, 0.0)
    pot = GravityGradient(o)
    q0 = qt.normalize([0.3, 0.5, -0.2, 0.8])
    Q0 = C.momenta_from_angular_velocity(q0, [1e-3, -2e-3, 1.5e-3], I_SAT)
    t = np.linspace(0, 3 * o.period, 301)
    ds = propagate(I_SAT, q0, Q0, t, potential=pot, rtol=1e-13, atol=1e-15)
    h_hat = qt.rotate(o.frame_quaternion(0.0), [0.0, 0.0, 1.0])
    J = ds.energy.values - o.mean_motion * ds.G.values @ h_hat
    scale = np.max(np.abs(ds.potential_energy.values))
    assert np.max(np.abs(J - J[0])) / scale < 1e-9
    # and H alone is *not* conserved (so the test can fail)
    assert np.max(np.abs(ds.energy.values - ds.energy.values[0])) / scale > 1e-3


def test_pitch_libration_frequency():
    """Small pitch librations about the local vertical at n sqrt(3 (I_y − I_x) / I_z).

    Body axes x radial, y along-track, z orbit normal, rotating with the orbital frame. With
    pitch θ about z, x̂_B = (cos θ, −sin θ, 0) and eq. 20 gives U = const + (3μ/2r³)(I_y − I_x)
    sin²θ, so I_z θ̈ = −3n²(I_y − I_x) θ for small θ in a circular orbit (e.g. Hughes,
    Spacecraft Attitude Dynamics, Sect. 9.3).
    """
    o = orbit.KeplerOrbit(7000.0, 0.0, 0.5, 0.2, 0.3)
    n = o.mean_motion
    theta0 = 1e-4
    q0 = qt.multiply(o.frame_quaternion(0.0), qt.from_axis_angle([0, 0, 1], theta0))
    Q0 = C.momenta_from_angular_velocity(q0, [0.0, 0.0, n], I_SAT)
    t = np.linspace(0, 6 * o.period, 6001)
    ds = propagate(I_SAT, q0, Q0, t, potential=GravityGradient(o), rtol=1e-12, atol=1e-16)
    rel = qt.multiply(qt.conjugate(o.frame_quaternion(t)), ds.q.values)
    theta = 2 * np.arctan2(rel[:, 3], rel[:, 0])
    # period from the zero crossings, linearly interpolated
    s = np.sign(theta)
    i = np.nonzero(s[:-1] != s[1:])[0]
    tz = t[i] - theta[i] * (t[i + 1] - t[i]) / (theta[i + 1] - theta[i])
    half_periods = np.diff(tz)
    omega_measured = np.pi / np.mean(half_periods)
    omega_theory = n * np.sqrt(3 * (I_SAT[1] - I_SAT[0]) / I_SAT[2])
    assert omega_measured == pytest.approx(omega_theory, rel=1e-5)
    assert np.max(np.abs(theta)) == pytest.approx(theta0, rel=1e-3)


def test_paper_keplerian_all_methods_agree():
    """Sect. 6.2 case: every registered method gives the same attitude."""
    o = paper_orbit()
    pot = GravityGradient(o)
    q0, Q0, _ = C.project_state([0.5, -(0.5**0.5), 0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    t = np.linspace(0.0, 1000.0, 11)
    ref = propagate(I_SAT, q0, Q0, t, potential=pot, rtol=1e-13, atol=1e-15)
    runs = {"scipy:DOP853": {"rtol": 1e-12, "atol": 1e-14}}
    for name in ("splitting", "nosquish"):
        if name in METHODS:
            runs[name] = {"dt": 0.5, "order": 6}
    for method, opts in runs.items():
        ds = propagate(I_SAT, q0, Q0, t, potential=pot, method=method, **opts)
        err = np.max(qt.angle_between(ds.q.values, ref.q.values))
        assert err < 1e-9, (method, err)
