"""The quaternion algebra on ``(..., 4)`` arrays: product, conjugate, norm, inverse, the
canonical sign, the rotation of vectors, the angle between two attitudes and their spherical
interpolation; the checks of quaternions and vectors the conversions share
(:mod:`attitude.quaternion`: the conventions).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import as_float_array, as_quaternion, as_vector
from ..errors import AttitudeValueError

__all__ = [
    "UNIT_NORM_TOL",
    "angle_between",
    "canonical",
    "conjugate",
    "inverse",
    "multiply",
    "norm",
    "normalize",
    "rotate",
    "rotate_inverse",
    "slerp",
]


FloatArray = NDArray[np.float64]

#: Largest accepted deviation ``| |q| − 1 |`` of a quaternion that must represent a rotation.
UNIT_NORM_TOL: float = 1e-6


def _stack(*parts: Any) -> FloatArray:
    """Stack broadcast components along a new last axis."""
    parts = np.broadcast_arrays(*parts)
    return np.stack(parts, axis=-1).astype(np.float64, copy=False)


def _norm3(v: FloatArray) -> FloatArray:
    """Length of (..., 3) vectors without underflow or overflow of the squares."""
    return np.hypot(np.hypot(v[..., 0], v[..., 1]), v[..., 2])


def _direction3(v: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Unit vectors along non-zero (..., 3) ``v`` and a mask of zero vectors.

    ``v`` is first divided by its largest component, so the result is unit to round-off even
    for subnormal components (where the norm itself would carry few significant bits).
    """
    m = np.max(np.abs(v), axis=-1)
    zero = m == 0
    vs = v / np.where(zero, 1.0, m)[..., None]
    return vs / np.where(zero, 1.0, _norm3(vs))[..., None], zero


def _norm4(q: FloatArray) -> FloatArray:
    """Norm of (..., 4) quaternions without underflow or overflow of the squares."""
    return np.hypot(np.hypot(q[..., 0], q[..., 1]), np.hypot(q[..., 2], q[..., 3]))


def _first_bad_index(mask: np.ndarray) -> tuple[int, ...]:
    return tuple(int(i) for i in np.argwhere(mask)[0])


def _as_nonzero(q: Any, name: str) -> FloatArray:
    """Finite (..., 4) array with no all-zero quaternion (tiny non-zero ones are accepted)."""
    arr = as_quaternion(q, name, nonzero=False)
    zero = np.all(arr == 0.0, axis=-1)
    if np.any(zero):
        idx = _first_bad_index(np.atleast_1d(zero))
        where = f" (at index {idx})" if arr.ndim > 1 else ""
        raise AttitudeValueError(
            f"{name}: the zero quaternion does not represent a rotation{where}"
        )
    return arr


def _as_unit(q: Any, name: str) -> FloatArray:
    """Validate a quaternion that must be of unit norm within :data:`UNIT_NORM_TOL`."""
    arr = as_quaternion(q, name)
    n = np.sqrt(np.sum(arr * arr, axis=-1))
    bad = np.abs(n - 1.0) > UNIT_NORM_TOL
    if np.any(bad):
        idx = _first_bad_index(np.atleast_1d(bad))
        val = float(np.atleast_1d(n)[idx])
        where = f" at index {idx}" if arr.ndim > 1 else ""
        raise AttitudeValueError(
            f"{name}: expected a unit quaternion (| |{name}| - 1 | <= {UNIT_NORM_TOL:g}), got "
            f"|{name}| = {val!r}{where}; call attitude.quaternion.normalize({name}) first if "
            "the norm has drifted"
        )
    return arr


def _as_angle(x: Any, name: str) -> FloatArray:
    """Finite float array of angles in radians (astropy angles are converted)."""
    return as_float_array(x, name, unit="rad")


def _mul(a: FloatArray, b: FloatArray) -> FloatArray:
    """Hamilton product of validated arrays (Schwab eq. 2)."""
    a0, a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    b0, b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    # grouped as (a0 b + b0 a) + a × b, so that q̃∘q and q∘q̃ have exactly zero vector part
    return _stack(
        a0 * b0 - (a1 * b1 + a2 * b2 + a3 * b3),
        (a0 * b1 + a1 * b0) + (a2 * b3 - a3 * b2),
        (a0 * b2 + a2 * b0) + (a3 * b1 - a1 * b3),
        (a0 * b3 + a3 * b0) + (a1 * b2 - a2 * b1),
    )


def _conj(q: FloatArray) -> FloatArray:
    out = -q
    out[..., 0] = q[..., 0]
    return out


def _canonical(q: FloatArray) -> FloatArray:
    """Flip signs so that w > 0, or w == 0 and the first non-zero of (x, y, z) is > 0."""
    sign = np.ones(q.shape[:-1])
    undecided = np.ones(q.shape[:-1], dtype=bool)
    for k in range(4):
        c = q[..., k]
        sign = np.where(undecided & (c < 0), -1.0, sign)
        undecided &= c == 0
    return q * sign[..., None]


def _rotate(q: FloatArray, v: FloatArray) -> FloatArray:
    """q∘v∘q̃ written out (Schwab eq. 6): (w² − u·u) v + 2 w (u × v) + 2 (u·v) u."""
    w = q[..., 0:1]
    u = q[..., 1:]
    u, v = np.broadcast_arrays(u, v)
    uv = np.sum(u * v, axis=-1, keepdims=True)
    uu = np.sum(u * u, axis=-1, keepdims=True)
    return (w * w - uu) * v + 2.0 * w * np.cross(u, v) + 2.0 * uv * u


def _wrap(a: FloatArray) -> FloatArray:
    """Wrap angles into (−π, π]."""
    a = np.where(a > np.pi, a - 2.0 * np.pi, a)
    return np.where(a <= -np.pi, a + 2.0 * np.pi, a)


def multiply(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Hamilton product ``a∘b``.

    ``a∘b = (a0 b0 − a·b, a0 b + b0 a + a × b)`` (Schwab eq. 2; Arribas et al. Sect. 2), so
    ``i∘j = k``. With attitudes, ``multiply(q_AB, q_BC)`` is the attitude ``q_AC`` (frame C
    components to frame A components): rotations compose left to right about body axes.

    Parameters
    ----------
    a, b : array_like, shape (..., 4)
        Quaternions, scalar first; leading dimensions broadcast. Need not be unit.

    Returns
    -------
    ndarray, shape (..., 4)
        The product.
    """
    return _mul(as_quaternion(a, "a", nonzero=False), as_quaternion(b, "b", nonzero=False))


def conjugate(q: ArrayLike) -> FloatArray:
    """Conjugate ``q̃ = (w, −x, −y, −z)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, scalar first.

    Returns
    -------
    ndarray, shape (..., 4)
        The conjugates. For a unit quaternion this is the inverse rotation.
    """
    return _conj(as_quaternion(q, "q", nonzero=False))


def norm(q: ArrayLike) -> FloatArray:
    """Euclidean norm ``|q| = sqrt(w² + x² + y² + z²)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, scalar first.

    Returns
    -------
    ndarray, shape (...)
        The norms (a 0-d array for a single quaternion).
    """
    return _norm4(as_quaternion(q, "q", nonzero=False))


def normalize(q: ArrayLike) -> FloatArray:
    """Scale to unit norm, ``q / |q|``.

    This is the explicit way to bring a quaternion whose norm has drifted back onto the unit
    sphere; nothing else in the package renormalises silently.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternions, scalar first.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions (same sign as ``q``).

    Raises
    ------
    AttitudeValueError
        If any quaternion is zero or non-finite.
    """
    q = _as_nonzero(q, "q")
    return q / _norm4(q)[..., None]


def inverse(q: ArrayLike) -> FloatArray:
    """Multiplicative inverse ``q⁻¹ = q̃ / |q|²`` (Schwab, after eq. 2).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternions, scalar first.

    Returns
    -------
    ndarray, shape (..., 4)
        ``q⁻¹`` with ``q∘q⁻¹ = q⁻¹∘q = 1``. Equal to :func:`conjugate` for unit quaternions.
    """
    q = _as_nonzero(q, "q")
    n = _norm4(q)[..., None]
    return _conj(q) / n / n


def canonical(q: ArrayLike) -> FloatArray:
    """Fix the sign of ``q`` so that ``w ≥ 0``; ``q`` and ``−q`` are the same attitude.

    Ties (``w == 0``, a rotation by exactly 180°) are broken by making the first non-zero of
    ``x, y, z`` positive, so the result is unique.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternions, scalar first (need not be unit).

    Returns
    -------
    ndarray, shape (..., 4)
        ``q`` or ``−q``.
    """
    return _canonical(_as_nonzero(q, "q"))


# ----------------------------------------------------------------------------------------------
# rotation of vectors, matrices
# ----------------------------------------------------------------------------------------------


def rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Body → space: ``x_S = q∘(0, v)∘q̃`` (Arribas et al. Theorem 1; Schwab eqs. 5–6).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternions (body → space), scalar first.
    v : array_like, shape (..., 3)
        Body components of vectors; leading dimensions broadcast with those of ``q``.

    Returns
    -------
    ndarray, shape (..., 3)
        Space components, equal to ``to_matrix(q) @ v``.

    Raises
    ------
    AttitudeValueError
        If ``q`` is not a unit quaternion within :data:`UNIT_NORM_TOL`, or inputs are bad.
    """
    return _rotate(_as_unit(q, "q"), as_vector(v, "v"))


def rotate_inverse(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Space → body: ``x_B = q̃∘(0, v)∘q``, the inverse of :func:`rotate`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternions (body → space), scalar first.
    v : array_like, shape (..., 3)
        Space components of vectors.

    Returns
    -------
    ndarray, shape (..., 3)
        Body components, equal to ``to_matrix(q).T @ v`` (the DCM times ``v``).
    """
    return _rotate(_conj(_as_unit(q, "q")), as_vector(v, "v"))


def angle_between(q1: ArrayLike, q2: ArrayLike) -> FloatArray:
    """Rotation angle between two attitudes, in ``[0, π]``.

    ``2 atan2(|vec(q̃1∘q2)|, |scalar(q̃1∘q2)|)``: invariant under ``q → −q`` of either argument
    and accurate to round-off for tiny angles (unlike ``2 arccos|q1·q2|``).

    Parameters
    ----------
    q1, q2 : array_like, shape (..., 4)
        Unit quaternions; leading dimensions broadcast.

    Returns
    -------
    ndarray, shape (...)
        Angles, rad.
    """
    r = _mul(_conj(_as_unit(q1, "q1")), _as_unit(q2, "q2"))
    u = r[..., 1:]
    return 2.0 * np.arctan2(_norm3(u), np.abs(r[..., 0]))


def slerp(q1: ArrayLike, q2: ArrayLike, s: ArrayLike) -> FloatArray:
    """Spherical linear interpolation along the shortest path from ``q1`` (s=0) to ``q2`` (s=1).

    ``q(s) = q1∘(q̃1∘q2')^s`` with ``q2' = ±q2`` chosen so that ``q1·q2' ≥ 0``; the angle
    from ``q1`` grows linearly in ``s``. At ``s = 1`` the result is ``q2'`` (which may be
    ``−q2``: the same attitude). Numerically safe for nearly equal or equal quaternions.
    Values of ``s`` outside [0, 1] extrapolate along the same great circle.

    Parameters
    ----------
    q1, q2 : array_like, shape (..., 4)
        Unit quaternions.
    s : array_like, shape (...)
        Interpolation parameters; broadcast with the leading dimensions of ``q1`` and ``q2``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions.
    """
    q1 = _as_unit(q1, "q1")
    q2 = _as_unit(q2, "q2")
    s = as_float_array(s, "s")
    r = _mul(_conj(q1), q2)
    r = np.where(r[..., :1] < 0, -r, r)  # shortest path: scalar part of q̃1∘q2 ≥ 0
    u = r[..., 1:]
    sn = _norm3(u)
    half = np.arctan2(sn, r[..., 0])  # half the rotation angle, in [0, π/2]
    sh = s * half
    # sin(s·half)/|u| → s as |u| → 0 (|u| = sin(half) for unit r)
    f = np.where(sn > 0, np.sin(sh) / np.where(sn > 0, sn, 1.0), s)
    lead = np.broadcast_shapes(sh.shape, u.shape[:-1])
    step = np.concatenate(
        [
            np.broadcast_to(np.cos(sh)[..., None], (*lead, 1)),
            np.broadcast_to(f[..., None] * u, (*lead, 3)),
        ],
        axis=-1,
    )
    return _mul(q1, step)
