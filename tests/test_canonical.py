"""Canonical variables (q, Q): maps to g, G, ω, T and the 3-1-3 weakly canonical map."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude import canonical as C
from attitude import quaternion as qt
from attitude.body import RigidBody
from attitude.errors import AttitudeValueError, SingularityError

I_PAPER = np.array([1.25, 1.0, 0.75])


def random_state(rng, n=None):
    shape = () if n is None else (n,)
    q = rng.normal(size=(*shape, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    g = rng.normal(size=(*shape, 3))
    return q, g


def eq8_body_momentum(angles, momenta):
    """g from 3-1-3 angles and momenta, Arribas et al. eq. 8, written out independently."""
    _phi, th, psi = angles
    Phi, Th, Psi = momenta
    a = (Phi - Psi * np.cos(th)) / np.sin(th)
    return np.array([a * np.sin(psi) + Th * np.cos(psi), a * np.cos(psi) - Th * np.sin(psi), Psi])


def test_momenta_round_trip_with_body_momentum():
    rng = np.random.default_rng(1)
    q, g = random_state(rng, 50)
    Q = C.momenta_from_body_angular_momentum(q, g)
    np.testing.assert_allclose(C.body_angular_momentum(q, Q), g, atol=1e-14)
    # Q lies in the tangent plane of the unit sphere at q.
    np.testing.assert_allclose(np.sum(q * Q, axis=-1), 0.0, atol=1e-14)


def test_space_momentum_is_rotated_body_momentum():
    rng = np.random.default_rng(2)
    q, g = random_state(rng, 50)
    Q = C.momenta_from_body_angular_momentum(q, g)
    G = C.space_angular_momentum(q, Q)
    np.testing.assert_allclose(G, qt.rotate(q, g), atol=1e-14)
    # and the explicit component formulas printed after eq. 17
    p0, p1, p2, p3 = np.moveaxis(q, -1, 0)
    P0, P1, P2, P3 = np.moveaxis(Q, -1, 0)
    G_paper = 0.5 * np.stack(
        [
            -p1 * P0 + p0 * P1 - p3 * P2 + p2 * P3,
            -p2 * P0 + p3 * P1 + p0 * P2 - p1 * P3,
            -p3 * P0 - p2 * P1 + p1 * P2 + p0 * P3,
        ],
        -1,
    )
    np.testing.assert_allclose(G, G_paper, atol=1e-14)


def test_angular_velocity_and_kinetic_energy():
    rng = np.random.default_rng(3)
    q, omega = random_state(rng, 20)
    Q = C.momenta_from_angular_velocity(q, omega, I_PAPER)
    np.testing.assert_allclose(C.angular_velocity(q, Q, I_PAPER), omega, atol=1e-14)
    T = C.kinetic_energy(q, Q, I_PAPER)
    np.testing.assert_allclose(T, 0.5 * np.sum(I_PAPER * omega**2, -1), rtol=1e-14)
    # eq. 6 written with the quaternion ⊗ product, I0 irrelevant (scalar part of q̃∘Q is 0)
    w = qt.multiply(qt.conjugate(q), Q)
    I4 = np.array([1e300, *I_PAPER])
    np.testing.assert_allclose(T, np.sum(w * w / I4, -1) / 8, rtol=1e-14)


def test_momenta_of_a_non_unit_q_are_refused():
    """Q = 2 q∘(0, I ω) of q = 1.5 (1, 0, 0, 0) gives back 1.5 ω once q is normalised: a
    silently wrong state; |q| off 1 by more than 1e-6 is refused, naming q and the fix."""
    body = RigidBody(I_PAPER)
    w = np.array([0.0, 0.0, 1.0])
    Q = 2.0 * qt.multiply(np.array([1.5, 0, 0, 0]), np.array([0.0, *(I_PAPER * w)]))
    assert C.angular_velocity([1.0, 0, 0, 0], Q, I_PAPER)[2] == pytest.approx(1.5)  # the trap
    for call in (
        lambda q: C.momenta_from_angular_velocity(q, w, body),
        lambda q: C.momenta_from_body_angular_momentum(q, I_PAPER * w),
    ):
        with pytest.raises(AttitudeValueError, match=r"^q: \|q\| = 1\.5 is not 1 .*normalize"):
            call([1.5, 0.0, 0.0, 0.0])
        with pytest.raises(AttitudeValueError, match=r"^q: \|q\| at index \(1,\) = 0\.5 "):
            call([[1.0, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0]])
        q = qt.normalize(np.array([1.0, 2.0, 3.0, 4.0])) * (1.0 + 9e-7)  # within 1e-6: taken
        np.testing.assert_allclose(C.angular_velocity(q, call(q), I_PAPER), w, atol=3e-6)


def test_omega_is_twice_conj_q_times_qdot():
    # Schwab eq. 15: ω' = 2 q̄∘q̇ with q̇ = ½ q∘(0, ω') (eq. 16), by finite differences of
    # the exact motion q(t) = q0∘exp(ω t/2) about a fixed body axis.
    rng = np.random.default_rng(4)
    q0, w = random_state(rng)
    h = 1e-6
    qp = qt.multiply(q0, qt.from_rotation_vector(w * h))
    qm = qt.multiply(q0, qt.from_rotation_vector(-w * h))
    qdot = (qp - qm) / (2 * h)
    np.testing.assert_allclose(2 * qt.multiply(qt.conjugate(q0), qdot)[1:], w, atol=1e-9)


@settings(max_examples=60, deadline=None)
@given(
    phi=st.floats(-3.1, 3.1),
    theta=st.floats(0.05, 3.09),
    psi=st.floats(-3.1, 3.1),
    m=st.lists(st.floats(-5, 5), min_size=3, max_size=3),
)
def test_eq12_to_15_round_trip_and_eq8(phi, theta, psi, m):
    angles = np.array([phi, theta, psi])
    momenta = np.array(m)
    q, Q = C.from_euler_canonical(angles, momenta)
    assert abs(np.linalg.norm(q) - 1) < 1e-15
    assert abs(np.dot(q, Q)) < 1e-12 * max(1, np.abs(momenta).max())
    # g from eq. 8 equals ½ q̃∘Q for the same state (the weakly canonical map, Sect. 5)
    np.testing.assert_allclose(
        C.body_angular_momentum(q, Q), eq8_body_momentum(angles, momenta), atol=1e-12 * 10
    )
    a2, m2 = C.to_euler_canonical(q, Q)
    np.testing.assert_allclose(a2, angles, atol=1e-11)
    np.testing.assert_allclose(m2, momenta, atol=1e-11 * max(1, 1 / np.sin(theta)))


def test_eq12_is_the_313_quaternion_of_the_rotation_module():
    rng = np.random.default_rng(5)
    angles = np.column_stack(
        [rng.uniform(-3, 3, 30), rng.uniform(0.1, 3.0, 30), rng.uniform(-3, 3, 30)]
    )
    q, _ = C.from_euler_canonical(angles, np.zeros((30, 3)))
    np.testing.assert_allclose(q, qt.from_euler(angles, "313"), atol=1e-15)


def test_paper_initial_conditions_against_eqs_12_and_14():
    """Sect. 6.1 prints q(t0), Q(t0) and 'equivalently' (φ,ϑ,ψ), (Φ,Θ,Ψ). Check both ways.

    Eq. 14 reproduces the printed Q to the printed six digits, but eq. 12 at ϑ = 3π/2 gives
    −q_printed: the printed pair (q, Q) is the state with angular momentum −g of the Euler
    form. (q, Q) and (−q, −Q) are the same physical state; (−q, Q) is not. docs/paper_notes.md.
    """
    q_pr = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
    Q_pr = np.array([0.3, -0.848528, 0.141421, -1.5])
    q, Q = C.from_euler_canonical([np.pi / 4, 3 * np.pi / 2, np.pi / 4], [0.5, 0.6, 0.4])
    np.testing.assert_allclose(Q, Q_pr, atol=5e-7)
    np.testing.assert_allclose(q, -q_pr, atol=1e-15)
    g_printed = C.body_angular_momentum(q_pr, Q_pr)
    g_euler = C.body_angular_momentum(q, Q)
    np.testing.assert_allclose(g_printed, -g_euler, atol=1e-6)


def test_to_euler_canonical_singular():
    q = qt.from_axis_angle([0, 0, 1], 0.3)  # b3 along s3: ϑ = 0
    Q = C.momenta_from_body_angular_momentum(q, [0.1, 0.2, 0.3])
    with pytest.raises(SingularityError, match="ϑ"):
        C.to_euler_canonical(q, Q)
    with pytest.raises(SingularityError, match="angles"):
        C.from_euler_canonical([0.1, np.pi, 0.2], [1, 1, 1])


def test_project_state():
    q_pr = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
    Q_pr = np.array([0.3, -0.848528, 0.141421, -1.5])
    q, Q, corr = C.project_state(q_pr, Q_pr)
    assert 1e-8 < corr < 1e-6
    assert abs(np.dot(q, Q)) < 4e-16
    with pytest.raises(AttitudeValueError, match="q0"):
        C.project_state(q_pr * 1.001, Q_pr)
    with pytest.raises(AttitudeValueError, match="Q0"):
        C.project_state(q_pr, Q_pr + 0.01 * q_pr)


def test_rigid_body_validation_and_tensor():
    with pytest.raises(AttitudeValueError, match="triangle"):
        RigidBody([1.0, 1.0, 2.5])
    with pytest.raises(AttitudeValueError, match="positive"):
        RigidBody([1.0, -1.0, 1.0])
    with pytest.raises(AttitudeValueError, match="inertia"):
        RigidBody([1.0, np.nan, 1.0])
    with pytest.raises(AttitudeValueError, match="shape"):
        RigidBody([1.0, 1.0])
    RigidBody([1.0, 1.0, 2.0])  # flat plate: equality allowed
    rng = np.random.default_rng(6)
    q = qt.normalize(rng.normal(size=4))
    R = qt.to_matrix(q)
    J = R @ np.diag([400.0, 500.0, 600.0]) @ R.T
    body, q_pf = RigidBody.from_tensor(J)
    np.testing.assert_allclose(body.inertia, [400, 500, 600], rtol=1e-13)
    Rp = qt.to_matrix(q_pf)
    np.testing.assert_allclose(Rp @ np.diag(body.inertia) @ Rp.T, J, rtol=1e-12, atol=1e-10)


def test_rigid_body_units():
    from astropy import units as u

    # bodies with units are held in SI, whatever unit they were given in
    b = RigidBody([400, 500, 600] * u.Unit("kg km2"))
    assert b.units == "kg m^2"
    np.testing.assert_allclose(b.inertia, [4e8, 5e8, 6e8], rtol=1e-15)
    b2 = RigidBody([4e8, 5e8, 6e8] * u.Unit("kg m2"))
    np.testing.assert_array_equal(b2.inertia, [4e8, 5e8, 6e8])
    b3 = RigidBody([400, 500, 600], units="kg km2")
    assert b3 == b
    b4 = RigidBody([4e4, 5e4, 6e4] * u.Unit("g cm2"))  # 1 g cm² = 1e-7 kg m²
    np.testing.assert_allclose(b4.inertia, [4e-3, 5e-3, 6e-3], rtol=1e-15)
    with pytest.raises(TypeError, match="inertia"):
        RigidBody([1, 2, 2] * u.s)
