"""Linear covariance analysis of inertial pointing with wheels, a gyro and a star tracker
through the MEKF (docs/closed_loop_covariance.md): the closed-loop linearised plant, sensors,
filter and control law as one discrete linear system x_{k+1} = F x_k + G w_k at the ticks, and
its steady-state covariance from the discrete Lyapunov equation X = F X Fᵀ + G Gᵀ.

Written from the models' equations (docs/sensors.md, docs/flight_software.md), not from the
package's code: the independent truth of tests/test_ensemble_closed_loop.py and of
benchmarks/closed_loop_ensemble.py.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl

#: Blocks of the reduced state z = (θ, ω, e_θ, e_β, L), 3 each.
THETA, OMEGA, E_THETA, E_BETA, TORQUE = (slice(3 * i, 3 * i + 3) for i in range(5))


def cross_matrix(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def plant(inertia: np.ndarray, h: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation (Φ, Γ) of θ̇ = ω, Ĩ ω̇ = [h×] ω + L over T.

    ``inertia`` is Ĩ = I − Σ J_k a_k a_kᵀ (the body without the wheels' axial inertia), ``h``
    the wheels' momentum Σ h_k a_k in body axes (held: the steady state's torques are tiny)."""
    z = np.zeros((3, 3))
    inv = np.linalg.inv(inertia)
    a = np.block([[z, np.eye(3)], [z, inv @ cross_matrix(h)]])
    b = np.vstack([z, inv])
    m = np.zeros((9, 9))
    m[:6, :6] = a * T
    m[:6, 6:] = b * T
    e = sl.expm(m)
    return e[:6, :6], e[:6, 6:]


def filter_gains(T: float, sv: float, su: float, R: np.ndarray, P0: np.ndarray, n: int) -> list:
    """The MEKF's gains K_k (6 × 3) at ticks 1..n: its Riccati recursion with Φ = [[1, −T],
    [0, 1]] (ω̂ T ≪ 1), Farrenkopf's Q and the star tracker's R (Markley & Crassidis 2014,
    eqs. 6.83–6.85, Joseph update)."""
    i3, z = np.eye(3), np.zeros((3, 3))
    phi = np.block([[i3, -T * i3], [z, i3]])
    q = np.block(
        [
            [(sv**2 * T + su**2 * T**3 / 3) * i3, -(su**2) * T**2 / 2 * i3],
            [-(su**2) * T**2 / 2 * i3, su**2 * T * i3],
        ]
    )
    H = np.hstack([i3, z])
    P = P0.copy()
    gains = []
    for _ in range(n):
        P = phi @ P @ phi.T + q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        ikh = np.eye(6) - K @ H
        P = ikh @ P @ ikh.T + K @ R @ K.T
        gains.append(K)
    return gains


def closed_loop(phi, gam, T, K, P, sv, su, R, gain) -> tuple[np.ndarray, np.ndarray]:
    """(F, G) of z_{k+1} = F z_k + G w_k, z = (θ, ω, e_θ, e_β, L) (15), w = (N_u, N_v, N_st)
    (9 standard normals) for one tick with the filter gain ``gain`` = [K₁; K₂].

    Tick k+1: the plant under L_k; the drift β_{k+1} = β_k + σ_u √T N_u; the gyro's rate
    ω̃ = ½(ω_k + ω_{k+1}) + ½(β_k + β_{k+1}) + (σ_v²/T + σ_u² T/12)^½ N_v; the filter's
    prediction θ̂⁻ = θ̂_k + T (ω̃ − β̂_k), its update with θ̃ = θ_{k+1} + R^½ N_st; the law
    L = −(K/4) θ̂ − P (ω̃ − β̂) (MRP feedback, σ ≈ θ/4, inertial reference). Built in the
    state with β and the estimates (θ̂, β̂), then written in the errors e_θ = θ̂ − θ,
    e_β = β̂ − β, where the drift β (a random walk) drops out."""
    i3 = np.eye(3)
    n = 18  # (θ, ω, β, θ̂, β̂, L)
    th, om, be, thh, bh, L = (slice(3 * i, 3 * i + 3) for i in range(6))
    F = np.zeros((n, n))
    G = np.zeros((n, 9))
    k1, k2 = gain[:3], gain[3:]
    F[0:6, 0:6] = phi
    F[0:6, L] = gam
    F[be, be] = i3
    G[be, 0:3] = np.sqrt(su**2 * T) * i3
    wt = 0.5 * F[om] + 0.5 * F[be]  # ω̃: ½ (ω_{k+1} + β_{k+1}) ...
    wt[:, om] += 0.5 * i3  # ... + ½ ω_k
    wt[:, be] += 0.5 * i3  # ... + ½ β_k
    wg = 0.5 * G[be].copy()
    wg[:, 3:6] = np.sqrt(sv**2 / T + su**2 * T / 12) * i3
    pred = T * wt
    pred[:, thh] += i3
    pred[:, bh] -= T * i3
    pred_g = T * wg
    innov = F[th] - pred
    innov_g = -pred_g
    innov_g[:, 6:9] += np.linalg.cholesky(R)
    F[thh] = pred + k1 @ innov
    G[thh] = pred_g + k1 @ innov_g
    F[bh] = k2 @ innov
    F[bh, bh] += i3
    G[bh] = k2 @ innov_g
    F[L] = -(K / 4) * F[thh] - P * (wt - F[bh])
    G[L] = -(K / 4) * G[thh] - P * (wg - G[bh])
    # to the errors: θ̂ = e_θ + θ, β̂ = e_β + β; then drop β
    S = np.eye(n)
    S[thh, th] = i3
    S[bh, be] = i3
    Fz = np.linalg.solve(S, F @ S)
    Gz = np.linalg.solve(S, G)
    assert np.all(np.delete(Fz[:, be], be, axis=0) == 0.0)  # β drops out exactly
    keep = [i for i in range(n) if not 6 <= i < 9]
    return Fz[np.ix_(keep, keep)], Gz[keep]


def pointing_covariance(inertia, h, T, K, P, sv, su, R, P0, n_ticks):
    """(X_ss, X_n): the steady-state covariance of z (discrete Lyapunov equation with the
    filter's steady gain) and the covariance after ``n_ticks`` ticks from a known state (the
    time-varying recursion X_{k+1} = F_k X_k F_kᵀ + G_k G_kᵀ with the filter's gains from
    ``P0``)."""
    phi, gam = plant(inertia, h, T)
    gains = filter_gains(T, sv, su, R, P0, max(n_ticks, 20000))
    F, G = closed_loop(phi, gam, T, K, P, sv, su, R, gains[-1])
    assert np.max(np.abs(np.linalg.eigvals(F))) < 1.0  # stable: a steady state exists
    Xss = sl.solve_discrete_lyapunov(F, G @ G.T)
    X = np.zeros_like(Xss)
    for k in range(n_ticks):
        F, G = closed_loop(phi, gam, T, K, P, sv, su, R, gains[k])
        X = F @ X @ F.T + G @ G.T
    return Xss, X
