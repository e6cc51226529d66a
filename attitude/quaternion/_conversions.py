"""Conversions between quaternions and every other attitude representation: rotation
matrices, axis and angle, rotation vectors, Euler angles of all twelve intrinsic sequences (with
gimbal lock), modified Rodrigues parameters and scipy rotations (:mod:`attitude.quaternion`: the
conventions).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from .._validation import as_float_array, as_vector
from ..errors import AttitudeTypeError, AttitudeValueError, SingularityError
from ._algebra import (
    FloatArray,
    _as_angle,
    _as_unit,
    _canonical,
    _direction3,
    _first_bad_index,
    _mul,
    _norm3,
    _stack,
    _wrap,
)

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation


__all__ = [
    "EULER_SEQUENCES",
    "MATRIX_TOL",
    "from_axis_angle",
    "from_euler",
    "from_matrix",
    "from_mrp",
    "from_rotation_vector",
    "from_scipy",
    "to_axis_angle",
    "to_euler",
    "to_matrix",
    "to_mrp",
    "to_rotation_vector",
    "to_scipy",
]


#: Default tolerance of :func:`from_matrix`: largest accepted Frobenius norm of ``RᵀR − I``.
MATRIX_TOL: float = 1e-9

#: The 12 intrinsic Euler sequences accepted by :func:`from_euler` and :func:`to_euler`.
EULER_SEQUENCES: tuple[str, ...] = (
    "121",
    "131",
    "212",
    "232",
    "313",
    "323",
    "123",
    "132",
    "213",
    "231",
    "312",
    "321",
)

# Gimbal lock in to_euler: the middle angle is treated as exactly singular when the sine (or
# cosine) of its half-angle in the symmetric form is below this, relative to |q|. Forcing the
# third angle to 0 there changes the represented rotation by at most ~2e-15 rad.
_GIMBAL_TOL = 4.0 * np.finfo(np.float64).eps


def _parse_seq(seq: Any, name: str = "seq") -> tuple[int, int, int]:
    if not isinstance(seq, str):
        raise AttitudeTypeError(
            f"{name}: expected a string of three axis digits such as '313' or '321', "
            f"got {seq!r} of type {type(seq).__name__}"
        )
    if seq not in EULER_SEQUENCES:
        raise AttitudeValueError(
            f"{name}: unknown Euler sequence {seq!r}; use one of the 12 intrinsic sequences "
            f"{', '.join(EULER_SEQUENCES)} (digits 1, 2, 3 = body x, y, z axes; for an extrinsic "
            "sequence 'ijk' with angles (a, b, c) use the intrinsic 'kji' with (c, b, a))"
        )
    i, j, k = (int(c) - 1 for c in seq)
    return i, j, k


def _levi_civita(i: int, j: int, k: int) -> int:
    return (i - j) * (j - k) * (k - i) // 2


def to_matrix(q: ArrayLike) -> FloatArray:
    """Active rotation matrix ``R`` with ``x_S = R x_B`` (Schwab eq. 7).

    ``R = [[w²+x²−y²−z², 2(xy−wz), 2(xz+wy)],
    [2(xy+wz), w²−x²+y²−z², 2(yz−wx)],
    [2(xz−wy), 2(yz+wx), w²−x²−y²+z²]]``.
    Its columns are the body axes in space components. The direction-cosine matrix (space →
    body, the matrix printed in Arribas et al. Sect. 2, Basilisk's ``[BN]``) is ``R.T``,
    i.e. ``np.swapaxes(to_matrix(q), -1, -2)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternions, scalar first.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rotation matrices.
    """
    q = _as_unit(q, "q")
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    rows = (
        (ww + xx - yy - zz, 2.0 * (xy - wz), 2.0 * (xz + wy)),
        (2.0 * (xy + wz), ww - xx + yy - zz, 2.0 * (yz - wx)),
        (2.0 * (xz - wy), 2.0 * (yz + wx), ww - xx - yy + zz),
    )
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def from_matrix(R: ArrayLike, *, tol: float = MATRIX_TOL) -> FloatArray:
    """Quaternion of an active rotation matrix ``R`` (``x_S = R x_B``), Markley's method.

    Of the four equivalent extractions (Arribas et al. Sect. 2 lists the squared components
    ``4p_i² = ...``), the one with the largest pivot among ``trace R``, ``R11``, ``R22``, ``R33``
    is used (Markley 2008, "Unit quaternion from rotation matrix", J. Guid. Control Dyn. 31,
    440; equivalent to Shepperd 1978), so every rotation, 180° included, is recovered to
    round-off. The result is :func:`canonical` (``w ≥ 0``).

    To convert a direction-cosine matrix ``C`` (space → body, ``x_B = C x_S``), pass
    ``np.swapaxes(C, -1, -2)``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices.
    tol : float, optional
        Largest accepted Frobenius norm of ``RᵀR − I`` (default :data:`MATRIX_TOL` = 1e-9).
        ``det R`` must also be positive.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions, scalar first, ``w ≥ 0``.

    Raises
    ------
    AttitudeValueError
        If ``R`` is not of shape (..., 3, 3), not finite, not orthogonal within ``tol``, or a
        reflection (``det R < 0``).
    """
    R = as_float_array(R, "R")
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise AttitudeValueError(f"R: expected shape (..., 3, 3), got shape {R.shape}")
    tol = float(tol)
    if not (np.isfinite(tol) and tol > 0):
        raise AttitudeValueError(f"tol: expected a positive finite number, got {tol!r}")
    RtR = np.swapaxes(R, -1, -2) @ R
    err = np.sqrt(np.sum((RtR - np.eye(3)) ** 2, axis=(-2, -1)))
    bad = err > tol
    if np.any(bad):
        idx = _first_bad_index(np.atleast_1d(bad))
        where = f" at index {idx}" if R.ndim > 2 else ""
        raise AttitudeValueError(
            f"R: not a rotation matrix{where}: ||RᵀR − I|| = {float(np.atleast_1d(err)[idx]):.3g}"
            f" exceeds tol = {tol:g}; orthonormalise it first or raise tol"
        )
    det = np.linalg.det(R)
    bad = det <= 0
    if np.any(bad):
        idx = _first_bad_index(np.atleast_1d(bad))
        where = f" at index {idx}" if R.ndim > 2 else ""
        raise AttitudeValueError(
            f"R: det R = {float(np.atleast_1d(det)[idx]):.3g}{where}: an improper orthogonal "
            "matrix (a reflection) is not a rotation"
        )
    r = R
    tr = r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2]
    # four candidates, each equal to 4 q_k · q (k = pivot component)
    c0 = _stack(
        1.0 + tr,
        r[..., 2, 1] - r[..., 1, 2],
        r[..., 0, 2] - r[..., 2, 0],
        r[..., 1, 0] - r[..., 0, 1],
    )
    c1 = _stack(
        r[..., 2, 1] - r[..., 1, 2],
        1.0 + 2.0 * r[..., 0, 0] - tr,
        r[..., 0, 1] + r[..., 1, 0],
        r[..., 0, 2] + r[..., 2, 0],
    )
    c2 = _stack(
        r[..., 0, 2] - r[..., 2, 0],
        r[..., 0, 1] + r[..., 1, 0],
        1.0 + 2.0 * r[..., 1, 1] - tr,
        r[..., 1, 2] + r[..., 2, 1],
    )
    c3 = _stack(
        r[..., 1, 0] - r[..., 0, 1],
        r[..., 0, 2] + r[..., 2, 0],
        r[..., 1, 2] + r[..., 2, 1],
        1.0 + 2.0 * r[..., 2, 2] - tr,
    )
    pivots = np.stack([tr, r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]], axis=-1)
    k = np.argmax(pivots, axis=-1)[..., None]
    q = np.where(k == 0, c0, np.where(k == 1, c1, np.where(k == 2, c2, c3)))
    q = q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    return _canonical(q)


# ----------------------------------------------------------------------------------------------
# axis-angle, rotation vector
# ----------------------------------------------------------------------------------------------


def from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> FloatArray:
    """Rotation by ``angle`` about ``axis``: ``q = (cos(angle/2), â sin(angle/2))``.

    Schwab eq. 9, Arribas et al. Theorem 1: right-handed, active (body → space).

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Rotation axes. Any non-zero vector: only its direction is used (it is divided by its
        length).
    angle : array_like, shape (...)
        Rotation angles, rad (astropy angle quantities are converted). Broadcasts with the
        leading dimensions of ``axis``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    AttitudeValueError
        If an axis is zero or inputs are not finite.
    """
    axis = as_vector(axis, "axis")
    angle = _as_angle(angle, "angle")
    unit_axis, zero = _direction3(axis)
    if np.any(zero):
        raise AttitudeValueError("axis: the zero vector has no direction; give a non-zero axis")
    half = 0.5 * angle[..., None]
    lead = np.broadcast_shapes(axis.shape[:-1], angle.shape)
    w = np.broadcast_to(np.cos(half), (*lead, 1))
    u = np.broadcast_to(np.sin(half) * unit_axis, (*lead, 3))
    return np.concatenate([w, u], axis=-1)


def to_axis_angle(q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Unit axis and angle in ``[0, π]`` of the body → space rotation ``q``.

    The angle is ``2 atan2(|u|, |w|)``, accurate for tiny and near-180° rotations. The sign of
    ``q`` is fixed first (:func:`canonical`), so the angle never exceeds π. For the identity
    (angle 0) the axis is undefined and ``(1, 0, 0)`` is returned.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axes.
    angle : ndarray, shape (...)
        Rotation angles in ``[0, π]``, rad.
    """
    q = _canonical(_as_unit(q, "q"))
    u = q[..., 1:]
    angle = 2.0 * np.arctan2(_norm3(u), q[..., 0])
    direction, zero = _direction3(u)
    axis = np.where(zero[..., None], np.array([1.0, 0.0, 0.0]), direction)
    return axis, angle


def from_rotation_vector(rotvec: ArrayLike) -> FloatArray:
    """Quaternion of the rotation vector ``θ â`` (rotation by ``θ = |rotvec|`` about ``â``).

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vectors of the active body → space rotation, rad. Any length (angles beyond π
        give quaternions with ``w < 0``).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions ``(cos(θ/2), sin(θ/2) â)``, accurate for tiny ``θ``.
    """
    rv = as_vector(rotvec, "rotvec")
    theta = _norm3(rv)[..., None]
    # sin(θ/2)/θ = ½ sinc(θ / 2π), exact at θ = 0
    return np.concatenate([np.cos(0.5 * theta), 0.5 * np.sinc(theta / (2.0 * np.pi)) * rv], axis=-1)


def to_rotation_vector(q: ArrayLike) -> FloatArray:
    """Rotation vector ``θ â`` of the body → space rotation ``q``, with ``θ ∈ [0, π]``.

    Same as scipy's ``Rotation.as_rotvec`` of :func:`to_scipy` ``(q)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions.

    Returns
    -------
    ndarray, shape (..., 3)
        Rotation vectors, rad, of length at most π.
    """
    q = _canonical(_as_unit(q, "q"))
    u = q[..., 1:]
    s = _norm3(u)
    w = q[..., 0]
    angle = 2.0 * np.arctan2(s, w)
    # θ/|u| → 2/w as |u| → 0 (w = 1 there for a unit q)
    factor = np.where(s > 0, angle / np.where(s > 0, s, 1.0), 2.0 / np.where(w > 0, w, 1.0))
    return factor[..., None] * u


# ----------------------------------------------------------------------------------------------
# Euler angles
# ----------------------------------------------------------------------------------------------


def _elementary(axis: int, angle: FloatArray) -> FloatArray:
    half = 0.5 * angle
    parts = [np.cos(half), np.zeros_like(half), np.zeros_like(half), np.zeros_like(half)]
    parts[axis + 1] = np.sin(half)
    return _stack(*parts)


def from_euler(angles: ArrayLike, seq: str = "313") -> FloatArray:
    """Quaternion of intrinsic Euler angles: ``q = q_i(a1)∘q_j(a2)∘q_k(a3)`` for ``seq = "ijk"``.

    Rotations about body axes, composed left to right (body → space). For ``"313"`` the angles
    are Arribas et al.'s ``(φ, ϑ, ψ)`` and the result is their eq. 12 exactly:
    ``(cos ϑ/2 cos (φ+ψ)/2, sin ϑ/2 cos (φ−ψ)/2, sin ϑ/2 sin (φ−ψ)/2, cos ϑ/2 sin (φ+ψ)/2)``.
    Equal to scipy's ``Rotation.from_euler("ZXZ", angles)`` (upper case = intrinsic) up to
    its scalar-last order.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``(a1, a2, a3)``, rad (astropy angle quantities are converted). Any values.
    seq : str, optional
        One of the 12 sequences in :data:`EULER_SEQUENCES` (digits 1, 2, 3 = body x, y, z).
        Default ``"313"``. For an extrinsic (space-axis) sequence ``"ijk"`` with angles
        ``(a, b, c)``, use the intrinsic ``"kji"`` with ``(c, b, a)``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions.

    Raises
    ------
    AttitudeTypeError
        If ``seq`` is not a string.
    AttitudeValueError
        If ``seq`` is not one of the 12 sequences or ``angles`` is bad.
    """
    i, j, k = _parse_seq(seq)
    a = as_float_array(angles, "angles", trailing=3, unit="rad")
    a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2]
    if i == k:
        # symmetric sequence i-j-i, m = third axis; closed form (eq. 12 for 3-1-3)
        m = 3 - i - j
        eps = _levi_civita(i, j, m)
        parts = [None] * 4
        parts[0] = np.cos(a2 / 2) * np.cos((a1 + a3) / 2)
        parts[i + 1] = np.cos(a2 / 2) * np.sin((a1 + a3) / 2)
        parts[j + 1] = np.sin(a2 / 2) * np.cos((a1 - a3) / 2)
        parts[m + 1] = eps * (np.sin(a2 / 2) * np.sin((a1 - a3) / 2))
        return _stack(*parts)
    return _mul(_mul(_elementary(i, a1), _elementary(j, a2)), _elementary(k, a3))


def to_euler(q: ArrayLike, seq: str = "313") -> FloatArray:
    """Intrinsic Euler angles of ``q``, the inverse of :func:`from_euler`.

    Direct method of Bernardes & Viollet (2022, PLoS ONE 17, e0276302), written for intrinsic
    sequences: an asymmetric sequence ``i-j-k`` is reduced to the symmetric ``i-j-i`` by
    right-multiplying with ``q_j(π/2)``. Every angle comes from ``atan2``, so there is no loss
    of accuracy near any angle. For ``"313"`` this is Arribas et al. eq. 13 with the quadrants
    of φ, ψ fixed by the signs in their sin/cos forms (after eq. 14).

    Ranges: ``a1, a3 ∈ (−π, π]``; ``a2 ∈ [0, π]`` for symmetric sequences (``"313"``:
    ϑ ∈ [0, π]), ``a2 ∈ [−π/2, π/2]`` for asymmetric ones.

    Gimbal lock (``a2 ∈ {0, π}`` symmetric, ``a2 = ±π/2`` asymmetric, to round-off): only
    ``a1 ± a3`` is defined. The choice made is ``a3 = 0``, with ``a1`` carrying the whole
    rotation about the locked axis; the round trip ``from_euler(to_euler(q))`` still gives the
    rotation of ``q`` (up to sign). No NaN, no warning. Near (not at) the lock ``a1`` and
    ``a3`` are individually ill-conditioned, but the rotation they represent is still exact to
    round-off.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions (either sign).
    seq : str, optional
        One of the 12 sequences in :data:`EULER_SEQUENCES`; default ``"313"``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(a1, a2, a3)`` in rad.
    """
    i, j, k = _parse_seq(seq)
    q = _as_unit(q, "q")
    symmetric = i == k
    if not symmetric:
        # q_k(a3) = r∘q_i(∓a3)∘r̃ with r = q_j(π/2), so q∘r = q_i(a1)∘q_j(a2 + π/2)∘q_i(±a3)
        r = np.zeros(4)
        r[0] = r[j + 1] = np.sqrt(0.5)
        q = _mul(q, r)
    m = 3 - i - j
    eps = _levi_civita(i, j, m)
    a, b = q[..., 0], q[..., i + 1]
    c, d = q[..., j + 1], eps * q[..., m + 1]
    h_ab = np.hypot(a, b)
    h_cd = np.hypot(c, d)
    a2 = 2.0 * np.arctan2(h_cd, h_ab)
    tplus = np.arctan2(b, a)  # (a1 + a3)/2
    tminus = np.arctan2(d, c)  # (a1 − a3)/2
    scale = np.hypot(h_ab, h_cd)
    lock0 = h_cd <= _GIMBAL_TOL * scale
    lockpi = h_ab <= _GIMBAL_TOL * scale
    a1 = np.where(lock0, 2.0 * tplus, np.where(lockpi, 2.0 * tminus, tplus + tminus))
    a3 = np.where(lock0 | lockpi, 0.0, tplus - tminus)
    if not symmetric:
        a2 = a2 - 0.5 * np.pi
        a3 = -eps * a3
    return _stack(_wrap(a1), a2, _wrap(a3)) + 0.0  # + 0.0 turns −0.0 into 0.0


def to_mrp(q: ArrayLike, shadow: bool = False) -> FloatArray:
    """Modified Rodrigues parameters ``σ_BN`` of the attitude, as Basilisk / Schaub & Junkins.

    In the Schaub–Junkins convention used by Basilisk, the Euler parameters ``β_BN`` of the
    body frame B relative to the inertial frame N are defined through the direction-cosine
    matrix ``[BN]`` (N components → B components) by the *transposed* (passive) matrix, the one
    printed in Arribas et al. Sect. 2. Hence ``β_BN`` equals our ``q`` component for component
    (scalar first), ``[BN] = to_matrix(q).T``, and

    ``σ_BN = vec(q) / (1 + w) = tan(θ/4) ê``,

    with ``(ê, θ)`` the axis and angle of ``q`` (the principal rotation carrying N onto B).
    Do not conjugate ``q`` first: that gives ``σ_NB = −σ_BN``.

    By default the sign of ``q`` is chosen with ``w ≥ 0`` so that ``|σ| ≤ 1`` (the short set,
    as Basilisk keeps it; at exactly 180° both ``±σ`` have ``|σ| = 1`` and the one from
    :func:`canonical` is returned). ``shadow=True`` returns the shadow set
    ``σ_s = −σ / |σ|²`` (``|σ_s| ≥ 1``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternions (body → space).
    shadow : bool, optional
        Return the shadow set instead of the short one.

    Returns
    -------
    ndarray, shape (..., 3)
        MRPs ``σ_BN``.

    Raises
    ------
    SingularityError
        If ``shadow=True`` and a rotation is the identity (its shadow set is at infinity).
    """
    q = _as_unit(q, "q")
    if not isinstance(shadow, (bool, np.bool_)):
        raise AttitudeTypeError(f"shadow: expected True or False, got {shadow!r}")
    qc = _canonical(q)
    w, u = qc[..., 0:1], qc[..., 1:]
    if not shadow:
        return u / (1.0 + w)
    sn = _norm3(u)
    bad = sn == 0
    if np.any(bad):
        raise SingularityError(
            "q: the shadow MRP set of the identity rotation is at infinity; use shadow=False"
        )
    # σ_s = −σ/|σ|² = −vec(q)(1 + w)/|vec q|² (= −vec(q)/(1 − w) for unit q, no cancellation)
    sn = sn[..., None]
    return -(u / sn) * ((1.0 + w) / sn)


def from_mrp(sigma: ArrayLike) -> FloatArray:
    """Attitude quaternion (body → space) from Basilisk-style MRPs ``σ_BN``.

    ``q = β_BN = ((1 − |σ|²), 2σ) / (1 + |σ|²)`` (see :func:`to_mrp` for why ``β_BN`` is our
    ``q``). Accepts either set, short (``|σ| ≤ 1``, gives ``w ≥ 0``) or shadow (``|σ| > 1``,
    gives ``w < 0``): both are the same rotation.

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        Modified Rodrigues parameters ``σ_BN``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions.
    """
    sg = as_vector(sigma, "sigma")
    s = _norm3(sg)[..., None]
    # with t = min(s, 1/s): w = ±(1 − t²)/(1 + t²), |vec| = 2t/(1 + t²); no overflow for huge σ
    big = s > 1.0
    t = np.where(big, 1.0 / np.where(big, s, 1.0), s)
    den = 1.0 + t * t
    w = np.where(big, -1.0, 1.0) * ((1.0 - t * t) / den)
    direction = sg / np.where(s > 0, s, 1.0)
    return np.concatenate([w, (2.0 * t / den) * direction], axis=-1)


def to_scipy(q: ArrayLike) -> Rotation:
    """The same active rotation as a :class:`scipy.spatial.transform.Rotation`.

    scipy stores quaternions scalar last: ``Rotation.from_quat(q[..., [1, 2, 3, 0]])``.
    ``to_scipy(q).apply(v) == rotate(q, v)`` and ``.as_matrix() == to_matrix(q)``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternions (body → space), scalar first.

    Returns
    -------
    scipy.spatial.transform.Rotation
        Of shape ``q.shape[:-1]`` (a single rotation for ``q`` of shape (4,)).
    """
    from scipy.spatial.transform import Rotation

    q = _as_unit(q, "q")
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])


def from_scipy(rotation: Rotation) -> FloatArray:
    """Scalar-first quaternion of a :class:`scipy.spatial.transform.Rotation`.

    Parameters
    ----------
    rotation : scipy.spatial.transform.Rotation
        Any rotation (single or stacked); it is taken as active (body → space), as scipy does.

    Returns
    -------
    ndarray, shape (..., 4)
        ``rotation.as_quat()[..., [3, 0, 1, 2]]`` (scipy's sign is kept).
    """
    from scipy.spatial.transform import Rotation

    if not isinstance(rotation, Rotation):
        raise AttitudeTypeError(
            f"rotation: expected a scipy.spatial.transform.Rotation, got "
            f"{type(rotation).__name__}; for a quaternion array use it directly, for a matrix "
            "use from_matrix"
        )
    return np.ascontiguousarray(np.asarray(rotation.as_quat(), dtype=np.float64)[..., [3, 0, 1, 2]])
