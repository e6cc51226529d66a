"""Canonical quaternion variables (q, Q) and the maps to physical quantities.

Arribas, Elipe & Palacios (2006), Sects. 3–5. The Euler parameters ``q`` (unit quaternion, body →
space) and their conjugate momenta ``Q`` (a quaternion in the tangent plane, q·Q = 0) are related
to the body angular momentum g and body angular velocity ω by

    Q = 2 q∘(0, g) = 2 q∘(0, I ω)        (inverse of eq. 17, with g = I ω)
    g = ½ vec(q̃∘Q)                        (eq. 17)
    G = ½ vec(Q∘q̃)                        (space angular momentum, after eq. 17)
    T = ⅛ (I⁻¹⊗q̃∘Q)·(q̃∘Q)               (eq. 6)

and, for the 3-1-3 Euler angles (φ, ϑ, ψ) with conjugate momenta (Φ, Θ, Ψ), by the weakly
canonical map of eqs. 12–15.

All functions broadcast over leading dimensions and return float arrays.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._validation import as_float_array, as_quaternion, as_rate, as_unit_quaternion, as_vector
from .body import inertia_rows
from .errors import AttitudeValueError, SingularityError
from .quaternion import conjugate, multiply

__all__ = [
    "angular_velocity",
    "body_angular_momentum",
    "from_euler_canonical",
    "kinetic_energy",
    "momenta_from_angular_velocity",
    "momenta_from_body_angular_momentum",
    "space_angular_momentum",
    "to_euler_canonical",
]

#: sin ϑ below which the 3-1-3 angles are considered singular (ϑ within ~1e-9 rad of 0 or π).
EULER_SINGULAR_TOL = 1e-9


def _inertia(inertia: Any) -> np.ndarray:
    """Principal moments (3,) of one body or (N, 3) of N bodies (ensemble members)."""
    return inertia_rows(inertia)[0]


def _pure(v: np.ndarray) -> np.ndarray:
    return np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)


def momenta_from_body_angular_momentum(q: Any, g: Any) -> np.ndarray:
    """Conjugate momenta from the body angular momentum: Q = 2 q∘(0, g).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternion (body → space); one off 1 by more than 1e-6 is refused (its Q would
        give the angular velocity scaled by ``|q|``).
    g : array_like or Quantity, shape (..., 3)
        Body-frame angular momentum (a Quantity is converted to kg m² s⁻¹, i.e. N m s: the
        unit of a body with units).

    Returns
    -------
    Q : ndarray, shape (..., 4)
    """
    q = as_unit_quaternion(q, "q")  # (Q of a non-unit q gives ω scaled by |q|)
    g = as_vector(g, "g", unit="kg m2 / s")
    return 2.0 * multiply(q, _pure(g))


def momenta_from_angular_velocity(
    q: Any, omega: Any, inertia: Any, wheel_speeds: Any = None
) -> np.ndarray:
    """Conjugate momenta from the body angular velocity: Q = 2 q∘(0, I ω).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternion (body → space); one off 1 by more than 1e-6 is refused (its Q would
        give the angular velocity scaled by ``|q|``).
    omega : array_like or Quantity, shape (..., 3)
        Body-frame angular velocity: rad per time unit, or a Quantity in any angular-rate unit
        (``deg/s``, ``cycle/min``...) for a body with units (converted to rad/s).
    inertia : RigidBody, Spacecraft, array_like or Quantity, shape (3,) or (N, 3)
        Principal moments of inertia: one body, or one row per ensemble member (as
        ``propagate_ensemble`` takes them; a sequence of N RigidBody too), rows broadcast
        against ``q`` and ``omega``; or a :class:`~attitude.Spacecraft`: with wheels g is the
        total momentum I ω + Σ J_k Ω_k a_k of body and wheels.
    wheel_speeds : array_like or Quantity, shape (..., n_wheels), optional
        A spacecraft's wheel speeds Ω_k relative to the body (rad/s; default: the wheels'
        initial speeds).

    Returns
    -------
    Q : ndarray, shape (..., 4)
        In kg m² s⁻¹ for a body with units.
    """
    if hasattr(inertia, "body_momentum"):  # a Spacecraft (with its wheels)
        craft = inertia
        omega = as_rate(omega, "omega", dimensional=not craft.body.is_dimensionless)
        speeds = None
        if wheel_speeds is not None:
            speeds = as_rate(
                wheel_speeds,
                "wheel_speeds",
                dimensional=not craft.body.is_dimensionless,
                trailing=None,
            )
            if speeds.shape[-1:] != (len(craft.wheels),):
                raise AttitudeValueError(
                    f"wheel_speeds: expected {len(craft.wheels)} wheel speeds in the last "
                    f"dimension, got shape {speeds.shape}"
                )
        return momenta_from_body_angular_momentum(q, craft.body_momentum(omega, speeds))
    if wheel_speeds is not None:
        raise AttitudeValueError(
            "wheel_speeds: only a Spacecraft has wheels; give inertia=Spacecraft(...)"
        )
    inert, units = inertia_rows(inertia)
    omega = as_rate(omega, "omega", dimensional=units is not None)
    return momenta_from_body_angular_momentum(q, omega * inert)


def body_angular_momentum(q: Any, Q: Any) -> np.ndarray:
    """Body angular momentum g = ½ vec(q̃∘Q) (Arribas et al. eq. 17).

    Parameters
    ----------
    q, Q : array_like, shape (..., 4)

    Returns
    -------
    g : ndarray, shape (..., 3)
    """
    q = as_quaternion(q, "q")
    Q = as_quaternion(Q, "Q", nonzero=False)
    return 0.5 * multiply(conjugate(q), Q)[..., 1:]


def space_angular_momentum(q: Any, Q: Any) -> np.ndarray:
    """Space (inertial) angular momentum G = ½ vec(Q∘q̃) (Arribas et al., after eq. 17).

    Parameters
    ----------
    q, Q : array_like, shape (..., 4)

    Returns
    -------
    G : ndarray, shape (..., 3)
    """
    q = as_quaternion(q, "q")
    Q = as_quaternion(Q, "Q", nonzero=False)
    return 0.5 * multiply(Q, conjugate(q))[..., 1:]


def angular_velocity(q: Any, Q: Any, inertia: Any, wheel_speeds: Any = None) -> np.ndarray:
    """Body angular velocity ω = I⁻¹ g, g = ½ vec(q̃∘Q) (``inertia`` (3,) or (N, 3)).

    For a :class:`~attitude.Spacecraft` with wheels, ω = I⁻¹ (g − Σ J_k Ω_k a_k) with the
    wheel speeds Ω_k relative to the body (``wheel_speeds``, default the wheels' initial
    speeds).

    Returns
    -------
    omega : ndarray, shape (..., 3)
    """
    if hasattr(inertia, "rate_from_momentum"):
        speeds = None
        if wheel_speeds is not None:
            speeds = as_rate(wheel_speeds, "wheel_speeds", dimensional=True, trailing=None)
        return inertia.rate_from_momentum(body_angular_momentum(q, Q), speeds)
    return body_angular_momentum(q, Q) / _inertia(inertia)


def kinetic_energy(q: Any, Q: Any, inertia: Any) -> np.ndarray:
    """Rotational kinetic energy T = ⅛ (I⁻¹⊗q̃∘Q)·(q̃∘Q) (Arribas et al. eq. 6).

    The scalar part of q̃∘Q (= q·Q, zero on the constraint manifold) is left out, i.e. I0 → ∞.
    ``inertia``: (3,) or (N, 3), as :func:`momenta_from_angular_velocity`.

    Returns
    -------
    T : ndarray, shape (...)
    """
    g = body_angular_momentum(q, Q)
    return 0.5 * np.sum(g * g / _inertia(inertia), axis=-1)


def from_euler_canonical(angles: Any, momenta: Any) -> tuple[np.ndarray, np.ndarray]:
    """(q, Q) from 3-1-3 Euler angles and their conjugate momenta (eqs. 12 and 14).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        (φ, ϑ, ψ) in rad: node longitude, inclination, proper rotation (Arribas et al. Sect. 4).
    momenta : array_like, shape (..., 3)
        (Φ, Θ, Ψ): the components of the angular momentum on s3, the node ℓ and b3.

    Returns
    -------
    q, Q : ndarray, shape (..., 4)

    Raises
    ------
    SingularityError
        If sin ϑ is within ``EULER_SINGULAR_TOL`` of zero (eq. 14 divides by sin ϑ/2, cos ϑ/2).
    """
    angles = as_float_array(angles, "angles", trailing=3, unit="rad")
    momenta = as_float_array(momenta, "momenta", trailing=3)
    phi, theta, psi = np.moveaxis(angles, -1, 0)
    Phi, Theta, Psi = np.moveaxis(momenta, -1, 0)
    if np.any(np.abs(np.sin(theta)) < EULER_SINGULAR_TOL):
        raise SingularityError(
            "angles: ϑ is 0 or π (mod 2π), where the 3-1-3 angles and their momenta are "
            "singular; give the state as (q, Q) or with body rates instead"
        )
    ch, sh = np.cos(theta / 2), np.sin(theta / 2)
    sp, dp = (phi + psi) / 2, (phi - psi) / 2
    # Eq. 12.
    q = np.stack([ch * np.cos(sp), sh * np.cos(dp), sh * np.sin(dp), ch * np.sin(sp)], axis=-1)
    # Eq. 14.
    Q = np.stack(
        [
            -(Phi + Psi) * np.sin(sp) / ch - 2 * Theta * sh * np.cos(sp),
            -(Phi - Psi) * np.sin(dp) / sh + 2 * Theta * ch * np.cos(dp),
            (Phi - Psi) * np.cos(dp) / sh + 2 * Theta * ch * np.sin(dp),
            (Phi + Psi) * np.cos(sp) / ch - 2 * Theta * sh * np.sin(sp),
        ],
        axis=-1,
    )
    return q, Q


def to_euler_canonical(
    q: Any, Q: Any, *, singular_tol: float = EULER_SINGULAR_TOL
) -> tuple[np.ndarray, np.ndarray]:
    """3-1-3 Euler angles and conjugate momenta from (q, Q) (eqs. 13 and 15).

    Parameters
    ----------
    q, Q : array_like, shape (..., 4)
        Canonical state (q unit, q·Q = 0).
    singular_tol : float
        Smallest sin ϑ accepted.

    Returns
    -------
    angles : ndarray, shape (..., 3)
        (φ, ϑ, ψ) with φ, ψ in (−π, π] and ϑ in (0, π).
    momenta : ndarray, shape (..., 3)
        (Φ, Θ, Ψ).

    Raises
    ------
    SingularityError
        If ϑ is within ~``singular_tol`` of 0 or π (b3 along ±s3): the node is undefined.
    """
    q = as_quaternion(q, "q")
    Q = as_quaternion(Q, "Q", nonzero=False)
    p0, p1, p2, p3 = np.moveaxis(q, -1, 0)
    P0, P1, P2, P3 = np.moveaxis(Q, -1, 0)
    s12 = np.sqrt(p1 * p1 + p2 * p2)
    s03 = np.sqrt(p0 * p0 + p3 * p3)
    sin_theta = 2 * s12 * s03
    if np.any(sin_theta < singular_tol):
        worst = float(np.min(sin_theta))
        raise SingularityError(
            f"q: the attitude has b3 along ±s3 (sin ϑ = {worst:.3g}), where the 3-1-3 angles and "
            f"their momenta are undefined; keep the state in (q, Q)"
        )
    # Eq. 13, written with atan2 of the cos/sin pairs given after eq. 14.
    phi = np.arctan2(p1 * p3 + p0 * p2, p0 * p1 - p2 * p3)
    theta = 2 * np.arctan2(s12, s03)
    psi = np.arctan2(p1 * p3 - p0 * p2, p0 * p1 + p2 * p3)
    # Eq. 15.
    Phi = 0.5 * (-p3 * P0 - p2 * P1 + p1 * P2 + p0 * P3)
    Theta = (-p0 * P0 + p1 * P1 + p2 * P2 - p3 * P3) / (4 * s12 * s03)
    Psi = 0.5 * (-p3 * P0 + p2 * P1 - p1 * P2 + p0 * P3)
    return np.stack([phi, theta, psi], axis=-1), np.stack([Phi, Theta, Psi], axis=-1)


def project_state(q: Any, Q: Any, *, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray, float]:
    """Project an initial state onto |q| = 1, q·Q = 0 when it is already close.

    The paper prints its momenta to six digits, so its initial states miss the constraint
    manifold by ~1e-7; integrating from there would carry the defect along forever.

    Parameters
    ----------
    q, Q : array_like, shape (4,)
    tol : float
        Largest accepted relative defect in |q| − 1 and in q·Q / |Q|.

    Returns
    -------
    q, Q : ndarray, shape (4,)
        Projected state: q/|q| and Q minus its component along q.
    correction : float
        Size of the correction, max(| |q| − 1 |, |q·Q| / max(|Q|, 1)).

    Raises
    ------
    AttitudeValueError
        If the defect exceeds ``tol``.
    """
    q = as_quaternion(q, "q0")
    Q = as_float_array(Q, "Q0", trailing=4)
    for name, a in (("q0", q), ("Q0", Q)):
        if a.shape != (4,):
            raise AttitudeValueError(
                f"{name}: expected one quaternion of shape (4,), got {a.shape}"
            )
    return _project(q, Q, tol)


def _project(
    q: np.ndarray, Q: np.ndarray, tol: float = 1e-6
) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`project_state` of validated float arrays of shape (4,) (a nonzero, finite q)."""
    # Norms and q·Q of copies scaled by a power of two (exact, so the results are those of the
    # unscaled formulas bit for bit wherever these do not overflow): a plain |Q| of
    # (1e155, 1e155, 0, 0) is inf, which made any q·Q look relatively 0.
    sq = _pow2(q)
    qs = q / sq
    nq = math.sqrt(float(qs.dot(qs))) * sq  # np.linalg.norm's own formula for 1-D arrays
    dn = abs(nq - 1.0)
    if dn > tol:
        raise AttitudeValueError(
            f"q0: |q0| = {nq!r} is not 1 (off by {dn:.3g} > {tol:g}); pass a unit quaternion "
            f"(attitude.quaternion.normalize) if that is what you mean"
        )
    qn = q / nq
    sQ = _pow2(Q)
    Qs = Q / sQ
    nQs = math.sqrt(float(Qs.dot(Qs)))  # |Q| / sQ (as np.linalg.norm)
    qQs = float(qn.dot(Qs))  # q·Q / sQ
    qQ = qQs * sQ
    dq = abs(qQs) / nQs if nQs * sQ >= 1.0 else abs(qQ)  # |q·Q| / max(|Q|, 1)
    if dq > tol:
        raise AttitudeValueError(
            f"Q0: q0·Q0 = {qQ:.3g} is not 0 (relative {dq:.3g} > {tol:g}); the momenta must be "
            f"tangent to the unit sphere, e.g. Q0 = 2 q0∘(0, g) "
            f"(attitude.canonical.momenta_from_body_angular_momentum)"
        )
    return qn, Q - qQ * qn, max(dn, dq)


def _pow2(x: np.ndarray) -> float:
    """A power of two within a factor 2 of max|x| (1.0 for x = 0): an exact scale for norms."""
    m = float(np.abs(x).max())
    if m == 0.0:
        return 1.0
    return math.ldexp(1.0, math.frexp(m)[1] - 1)
