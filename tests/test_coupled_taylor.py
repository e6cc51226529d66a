"""The coupled orbit–attitude system in the Taylor core (issue 41): conservation of the total
energy and angular momentum while spin and orbit visibly exchange them, an independent solution
of Hamilton's equations by scipy's DOP853, and the decoupled limit (a Kepler orbit and the
uncoupled gravity-gradient run)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import orbit
from attitude._coupled_taylor import (
    MU_EARTH,
    coupled_invariants,
    run_coupled_taylor,
)
from attitude.canonical import momenta_from_body_angular_momentum
from attitude.errors import AttitudeValueError
from attitude.potentials import GravityGradient
from attitude.propagate import propagate

# A long, dumbbell-like body (two 50 t masses 100 m from the centre: I = m ℓ² across the bar) in
# a 7000 km near-circular, inclined orbit, tumbling slowly: its gravity-gradient torque trades
# ~6e-10 of the total angular momentum per orbit with the orbit, 1e3 times the tolerance below.
INERTIA = np.array([1e9, 1e9, 2e7])
MASS = 1e5
MU = MU_EARTH
A = 7.0e6
PERIOD = 2.0 * math.pi * math.sqrt(A**3 / MU)


def initial_state():
    """(q0, Q0, r0, v0): a tilted attitude, ω ~ 1e-3 rad/s, an orbit of e ≈ 1e-3, i = 0.3."""
    vc = math.sqrt(MU / A) * 1.0005
    r0 = np.array([A, 0.0, 0.0])
    v0 = np.array([0.0, vc * math.cos(0.3), vc * math.sin(0.3)])
    half = 0.2
    q0 = np.array(
        [math.cos(half), math.sin(half) / math.sqrt(2.0), 0.0, math.sin(half) / math.sqrt(2.0)]
    )
    g0 = INERTIA * np.array([1e-3, -5e-4, 3e-3])  # body angular momentum
    Q0 = momenta_from_body_angular_momentum(q0, g0)  # Q = 2 q∘(0, g) (Arribas et al. eq. 17)
    return q0, Q0, r0, v0


def run(n_orbits, per_orbit=50, mass=MASS, rtol=1e-14):
    q0, Q0, r0, v0 = initial_state()
    t = np.linspace(0.0, n_orbits * PERIOD, n_orbits * per_orbit + 1)
    return run_coupled_taylor(INERTIA, mass, MU, q0, Q0, r0, v0, t, rtol=rtol, atol=rtol * 1e-3)


def drifts(out, mass=MASS):
    """Largest relative changes: total energy, total L (vector), |L|, and the spin's L and
    energy (the exchange), all relative to the totals."""
    inv = coupled_invariants(out, INERTIA, mass, MU)
    e, lv = inv["energy"], inv["L"]
    l0 = np.linalg.norm(lv[0])
    spin_e = inv["E_spin"] + inv["V2"]
    return {
        "energy": np.max(np.abs(e - e[0])) / abs(e[0]),
        "L": np.max(np.linalg.norm(lv - lv[0], axis=1)) / l0,
        "|L|": np.max(np.abs(np.linalg.norm(lv, axis=1) - l0)) / l0,
        "L_spin": np.max(np.linalg.norm(inv["L_spin"] - inv["L_spin"][0], axis=1)) / l0,
        "E_spin": np.max(np.abs(spin_e - spin_e[0])) / abs(e[0]),
    }


@pytest.mark.parametrize("n_orbits", [10, 100, 1000])
def test_total_energy_and_angular_momentum_are_conserved_while_spin_and_orbit_exchange(n_orbits):
    out = run(n_orbits)
    d = drifts(out)
    # the exchange is visible: the spin's share of L and H moves by ≫ the tolerance ...
    assert d["L_spin"] > 1e-10 and d["E_spin"] > 1e-10, d
    # ... while the totals stay constant (measured: 2e-15 after 10 orbits, 2e-14 after 100,
    # 6e-14 after 1000)
    assert d["energy"] <= 1e-12 and d["L"] <= 1e-12 and d["|L|"] <= 1e-12, d
    # without the back-reaction the same exchange is not compensated: L then drifts
    free = drifts(run(n_orbits, mass=math.inf))
    assert free["L"] > 1e-10, free


# ---------------------------------------------------------------------------------------------
# Hamilton's equations of H = |p|²/2m − μm/|r| + V2 + ½ gᵀI⁻¹g written plainly, in space axes
# with a rotation matrix R (body → space): the force and torque are derivatives of V2 taken by
# complex steps of V2 itself, so nothing of the Taylor core's derivation is reused.
def _v2(r_space, rot):
    """V2 = −μ/(2|r|³) (tr I − 3 r̂ᵀ I r̂), r̂ in body axes = Rᵀ r̂_S (complex-safe)."""
    rb = rot.T @ r_space
    rr = np.sqrt(np.sum(r_space * r_space))
    return -MU / (2.0 * rr**3) * (INERTIA.sum() - 3.0 * np.sum(INERTIA * rb * rb) / rr**2)


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _rhs(_t, y):
    r, v, rot, g = y[0:3], y[3:6], y[6:15].reshape(3, 3), y[15:18]
    h = 1e-30
    force = np.empty(3)  # F = −∂V2/∂r (space axes)
    torque = np.empty(3)  # τ_B = −∂V2(R (1 + [δθ]×))/∂δθ (body axes, virtual work)
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0
        force[j] = -_v2(r + 1j * h * e, rot).imag / h
        torque[j] = -_v2(r, rot @ (np.eye(3) + 1j * h * _hat(e))).imag / h
    w = g / INERTIA
    dy = np.empty(18)
    dy[0:3] = v
    dy[3:6] = -MU * r / np.sqrt(r @ r) ** 3 + force / MASS
    dy[6:15] = (rot @ _hat(w)).reshape(9)  # Ṙ = R [ω]×
    dy[15:18] = np.cross(g, w) + torque  # Euler: ġ = g × ω + τ
    return dy


def _matrix(q):
    """Rotation matrix (body → space) of unit quaternions, Schwab eq. 7."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def test_agrees_with_hamiltons_equations_integrated_by_scipy_dop853():
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp
    n_orbits = 3
    out = run(n_orbits, per_orbit=20)
    q0, _, r0, v0 = initial_state()
    y0 = np.concatenate([r0, v0, _matrix(q0).reshape(9), out["g"][0]])
    t = out["t"]
    # atol tiny against each component's scale: relative control throughout
    scale = np.concatenate([np.full(3, A), np.full(3, 7.5e3), np.ones(9), np.full(3, 3e6)])
    sol = solve_ivp(
        _rhs, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-13, atol=1e-16 * scale
    )
    assert sol.success
    ys = sol.y.T
    err_r = np.max(np.linalg.norm(out["r"] - ys[:, 0:3], axis=1)) / A
    err_v = np.max(np.linalg.norm(out["v"] - ys[:, 3:6], axis=1)) / np.linalg.norm(v0)
    err_R = np.max(np.abs(_matrix(out["q"]) - ys[:, 6:15].reshape(-1, 3, 3)))
    err_g = np.max(np.linalg.norm(out["g"] - ys[:, 15:18], axis=1)) / np.linalg.norm(out["g"][0])
    # measured ~1e-12 .. 1e-11: the scipy tolerance level
    assert max(err_r, err_v, err_R, err_g) < 1e-10, (err_r, err_v, err_R, err_g)
    # and that resolves the back-reaction: without it the orbit is off by far more
    free = run(n_orbits, per_orbit=20, mass=math.inf)
    off = np.max(np.linalg.norm(free["r"] - ys[:, 0:3], axis=1)) / A
    assert off > 1e3 * err_r, (off, err_r)


def test_decoupled_limit_is_the_kepler_orbit_and_the_uncoupled_gravity_gradient():
    n_orbits = 3
    out = run(n_orbits, per_orbit=40, mass=math.inf, rtol=1e-15)
    q0, Q0, r0, v0 = initial_state()
    t = out["t"]
    kep = orbit.KeplerOrbit.from_state(r0 / 1e3, v0 / 1e3, mu=MU / 1e9)  # km, km/s, km³/s²
    err_r = np.max(np.linalg.norm(out["r"] - 1e3 * kep.position(t), axis=1)) / A
    err_v = np.max(np.linalg.norm(out["v"] - 1e3 * kep.velocity(t), axis=1)) / np.linalg.norm(v0)
    # measured ~1e-14: round-off of a few hundred steps (and of Kepler's equation)
    assert err_r < 1e-13 and err_v < 1e-13, (err_r, err_v)
    ds = propagate(
        INERTIA, q0, Q0, t, GravityGradient(kep), method="taylor", rtol=1e-14, atol=1e-17
    )
    err_q = np.max(np.abs(out["q"] - ds.q.values))
    err_Q = np.max(np.abs(out["Q"] - ds.Q.values)) / np.max(np.abs(ds.Q.values))
    assert err_q < 1e-11 and err_Q < 1e-11, (err_q, err_Q)


def test_outputs_and_input_errors():
    q0, Q0, r0, v0 = initial_state()
    t = np.linspace(0.0, 600.0, 4)
    out = run_coupled_taylor(INERTIA, MASS, MU, q0, Q0, r0, v0, t)
    assert out["q"].shape == (4, 4) and out["r"].shape == (4, 3) and out["n_steps"] > 0
    # to body axes and back: round-off
    np.testing.assert_allclose(out["r"][0], r0, rtol=0, atol=1e-15 * np.linalg.norm(r0))
    np.testing.assert_allclose(out["v"][0], v0, rtol=0, atol=1e-15 * np.linalg.norm(v0))
    with pytest.raises(AttitudeValueError, match="mass"):
        run_coupled_taylor(INERTIA, -1.0, MU, q0, Q0, r0, v0, t)
    with pytest.raises(AttitudeValueError, match="inertia"):
        run_coupled_taylor([1.0, 0.0, 1.0], MASS, MU, q0, Q0, r0, v0, t)
