"""Control laws: each computes a body torque request (or a dipole request) at every tick."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._core.fsw_laws import CODES as LAW_CODES
from .._validation import as_float_array, as_scalar
from ..body import RigidBody
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "BDot",
    "ControlLaw",
    "MRPFeedback",
    "MomentumDumping",
    "QuaternionFeedback",
    "RateDamping",
    "positive_gain",
]


def positive_gain(
    x: Any, name: str, unit: str | None = None, *, allow_zero: bool = False, hint: str = ""
) -> float:
    """A gain from a plain number (in ``unit``) or a Quantity convertible to ``unit``
    (dimensionless when ``unit`` is None: a Quantity in other units is refused, never
    stripped of them)."""
    from astropy import units as u

    if isinstance(x, u.Quantity):
        want = u.Unit(unit) if unit else u.dimensionless_unscaled
        try:
            x = x.to_value(want, u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(
                f"{name}: units {x.unit} cannot be converted to {want}; give {name} in units "
                f"compatible with {want}, or a plain number in {want}"
            ) from None
    v = as_scalar(x, name)
    if not (v > 0 or (allow_zero and v == 0)) or not math.isfinite(v):
        what = "a finite number >= 0" if allow_zero else "a positive finite number"
        raise AttitudeValueError(f"{name}: the gain must be {what}, got {v!r}{hint}")
    return v


def _matrix_gain(x: Any, name: str, unit: str = "N m s") -> np.ndarray:
    """A gain given as a number (times the identity), 3 diagonal entries or a 3 × 3 matrix
    (plain numbers in ``unit``, or a Quantity convertible to it)."""
    a = as_float_array(x, name, unit=unit)
    if a.ndim == 0:
        m = float(a) * np.eye(3)
    elif a.shape == (3,):
        m = np.diag(a)
    elif a.shape == (3, 3):
        m = a.copy()
    else:
        raise AttitudeValueError(
            f"{name}: expected a number, 3 diagonal entries or a 3 x 3 matrix, got shape {a.shape}"
        )
    scale = float(np.max(np.abs(m)))
    sym = 0.5 * (m / scale + m.T / scale) if scale > 0 else m  # no overflow at 1e308
    if not np.all(np.linalg.eigvalsh(sym) > 0):
        raise AttitudeValueError(f"{name}: the gain matrix must be positive definite")
    return m


class ControlLaw:
    """Base class of the built-in laws."""

    #: Code of the law's compiled kernel (its line in attitude._core.fsw_laws.LAWS; 0: none).
    _kind: int = 0
    #: Actuators the law needs: "torque" (wheels, magnetorquers or an ideal torque), "dipole".
    needs: str = "torque"

    def _gains(self) -> tuple[float, np.ndarray, float, float, float]:
        """(K, P (3 × 3), K_I, integral limit, law type) for the kernel."""
        return 0.0, np.zeros((3, 3)), 0.0, 0.0, 0.0


@dataclass(frozen=True, init=False)
class MRPFeedback(ControlLaw):
    """MRP feedback, Basilisk's ``mrpFeedback`` (Schaub & Junkins, *Analytical Mechanics of
    Space Systems*, 4th ed., Sect. 8.4):

        L_r = −[K σ + P δω + P K_I z − (ω_r + K_I z) × (I ω + Σ h_s a) + I (ω × ω_r − ω̇_r)]

    σ = σ_BR the attitude error (MRP), δω = ω − ω_r, z = ∫ K σ dt + I δω the integral term
    (only with K_I > 0; each component of ∫ K σ dt limited to ``integral_limit``), h_s the
    wheels' axial momenta. Global asymptotic tracking for K, P > 0 (Schaub & Junkins).

    Parameters
    ----------
    K : float
        Attitude gain (N m).
    P : float, array_like (3,) or (3, 3)
        Rate gain (N m s); a number as in Basilisk, or a matrix.
    Ki : float or Quantity, optional
        Integral gain (1/s, >= 0); None or 0: no integral term (Basilisk's ``Ki = -1``; a
        negative Ki is refused).
    integral_limit : float or Quantity, optional
        Limit of each component of ∫ K σ dt (N m s; default: 0.1 × 2 / Ki as in Basilisk's
        scenario, unlimited without Ki).
    law_type : {0, 1}
        Basilisk's ``controlLawType``: 0 crosses the momentum with ω_r + K_I z, 1 with ω.
    """

    K: float
    P: np.ndarray
    Ki: float
    integral_limit: float
    law_type: int
    _kind = LAW_CODES["mrp_feedback"]

    def __init__(self, K: Any, P: Any, Ki: Any = None, integral_limit: Any = None,
                 law_type: int = 0):  # fmt: skip
        s = object.__setattr__
        s(self, "K", positive_gain(K, "K", "N m"))
        s(self, "P", _matrix_gain(P, "P"))
        # None is the kernel's -1 (Basilisk's "no integral term"); a negative Ki given by the
        # caller is refused: Basilisk's convention, not ours (docs: Ki=None)
        hint = "; use Ki=None for no integral term"
        ki = -1.0 if Ki is None else positive_gain(Ki, "Ki", "1 / s", allow_zero=True, hint=hint)
        s(self, "Ki", ki)
        if integral_limit is None:
            lim = 2.0 / ki * 0.1 if ki > 0 else math.inf
        else:
            lim = positive_gain(integral_limit, "integral_limit", "N m s")
        s(self, "integral_limit", lim)
        if law_type not in (0, 1):
            raise AttitudeValueError(f"law_type: expected 0 or 1, got {law_type!r}")
        s(self, "law_type", int(law_type))

    def _gains(self):
        return self.K, self.P, self.Ki, self.integral_limit, float(self.law_type)

    def __repr__(self) -> str:
        P = self.P[0, 0] if np.allclose(self.P, self.P[0, 0] * np.eye(3)) else self.P.tolist()
        ki = f", Ki={self.Ki!r}" if self.Ki > 0 else ""
        return f"MRPFeedback(K={self.K!r}, P={P!r}{ki})"


@dataclass(frozen=True, init=False)
class QuaternionFeedback(ControlLaw):
    """Quaternion feedback (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., Sect. 7.3):

        L_r = −K q_e − C δω + ω × (I ω + Σ h_s a) − I (ω × ω_r − ω̇_r)

    q_e the vector part of the error quaternion q̃_R∘q (the shorter rotation).

    Parameters
    ----------
    K : float
        Attitude gain (N m).
    C : float, array_like (3,) or (3, 3)
        Rate gain (N m s).
    """

    K: float
    C: np.ndarray
    _kind = LAW_CODES["quaternion_feedback"]

    def __init__(self, K: Any, C: Any):
        object.__setattr__(self, "K", positive_gain(K, "K", "N m"))
        object.__setattr__(self, "C", _matrix_gain(C, "C"))

    def _gains(self):
        return self.K, self.C, 0.0, 0.0, 0.0

    def __repr__(self) -> str:
        return f"QuaternionFeedback(K={self.K!r}, C={self.C.tolist()!r})"


@dataclass(frozen=True, init=False)
class RateDamping(ControlLaw):
    """Rate damping, L_r = −K_d (ω − ω_r) (ω_r of the guidance; zero without one).

    Parameters
    ----------
    K : float, array_like (3,) or (3, 3)
        Damping gain (N m s).
    """

    K: np.ndarray
    _kind = LAW_CODES["rate_damping"]

    def __init__(self, K: Any):
        object.__setattr__(self, "K", _matrix_gain(K, "K"))

    def _gains(self):
        return 0.0, self.K, 0.0, 0.0, 0.0

    def __repr__(self) -> str:
        return f"RateDamping(K={self.K.tolist()!r})"


def _check_earth_orbit(rp: float, mu: float) -> None:
    """Refuse an Earth orbit whose perigee radius ``rp`` (km) is inside the Earth (the orbit
    package only warns: :class:`orbit.errors.PerigeeInsideEarthWarning`)."""
    from orbit.keplerorbit import EARTH_MU, EARTH_MU_RTOL, EARTH_RADIUS

    if abs(mu - EARTH_MU) <= EARTH_MU_RTOL * EARTH_MU and not rp >= EARTH_RADIUS:
        raise AttitudeValueError(
            f"orbit: its perigee radius {rp:.1f} km is inside the Earth (equatorial radius "
            f"{EARTH_RADIUS} km): no spacecraft flies this orbit and its field and mean motion "
            "give no gain; check the orbit's a and e"
        )


@dataclass(frozen=True, init=False)
class BDot(ControlLaw):
    """B-dot detumbling with magnetorquers.

    ``normalized=False``: m = −k Ḃ_B (Stickler & Alfriend, *J. Spacecraft* 13, 1976);
    ``normalized=True``: m = −(k/|B|) ḃ, b = B/|B| the field's direction in body axes
    (Avanzini & Giulietti, "Magnetic detumbling of a rigid spacecraft", *J. Guidance* 35,
    2012, whose optimal gain :meth:`optimal_gain` is k = 2 n (1 + sin ξ_m) I_min). The
    derivatives are the change of the measured field from the last tick to this one over the
    period; the dipole is clipped to each rod's limit (nothing at the first tick of the mode).

    Parameters
    ----------
    gain : float or Quantity
        k: A m² s T⁻¹ for m = −k Ḃ; N m s for the normalized law (a Quantity in other units
        is refused).
    normalized : bool
        Which of the two laws.
    """

    gain: float
    normalized: bool
    _kind = LAW_CODES["bdot"]
    needs = "dipole"

    def __init__(self, gain: Any, normalized: bool = False):
        if not isinstance(normalized, (bool, np.bool_)):
            raise AttitudeTypeError("normalized: expected True or False")
        unit = "N m s" if normalized else "A m2 s / T"
        object.__setattr__(self, "gain", positive_gain(gain, "gain", unit))
        object.__setattr__(self, "normalized", bool(normalized))

    @staticmethod
    def optimal_gain(orbit: Any, inertia: Any) -> float:
        """Avanzini & Giulietti's gain of the normalized law, k = 2 n (1 + sin ξ_m) I_min
        (N m s): n the orbit's mean motion, ξ_m its inclination to the geomagnetic equator
        (the inclination plus or minus the dipole's tilt, the larger of the two: 9.6° for
        IGRF-14 at 2025), I_min the smallest principal moment."""
        if not hasattr(orbit, "to_state"):
            raise AttitudeTypeError("orbit: expected an orbit of the orbit package")
        lo = orbit.time_span[0]
        t0 = lo if math.isfinite(lo) else 0.0
        r, v = (np.asarray(x, dtype=np.float64).reshape(3) for x in orbit.to_state(t0))
        mu = float(orbit.mu)
        h = np.cross(r, v)
        inc = math.acos(max(-1.0, min(1.0, h[2] / np.linalg.norm(h))))
        rn = float(np.linalg.norm(r))
        a = 1.0 / (2.0 / rn - float(v @ v) / mu)  # vis-viva (osculating, km)
        e = np.linalg.norm(((v @ v) - mu / rn) * r - (r @ v) * v) / mu
        _check_earth_orbit(a * (1.0 - e), mu)
        n = math.sqrt(mu / a**3)
        tilt = math.radians(9.6)
        xi = max(abs(math.sin(inc + tilt)), abs(math.sin(inc - tilt)))
        body = inertia.body if hasattr(inertia, "body") else inertia  # a Spacecraft's body
        if hasattr(body, "inertia"):
            moments = np.asarray(body.inertia, dtype=np.float64)
        else:
            moments = as_float_array(inertia, "inertia", unit="kg m2")
            if moments.shape != (3,) or not np.all(moments > 0):
                raise AttitudeValueError(
                    "inertia: expected 3 positive principal moments (kg m²), a RigidBody or a "
                    f"Spacecraft, got {moments.tolist()!r}"
                )
            RigidBody(moments)  # its checks: the triangle inequalities of principal moments
        return 2.0 * n * (1.0 + xi) * float(np.min(moments))

    def _gains(self):
        return self.gain, np.zeros((3, 3)), 0.0, 0.0, 1.0 if self.normalized else 0.0

    def __repr__(self) -> str:
        tail = ", normalized=True" if self.normalized else ""
        return f"BDot(gain={self.gain!r}{tail})"


@dataclass(frozen=True, init=False)
class MomentumDumping:
    """Wheel momentum dumping with magnetorquers, the cross-product law (Camillo & Markley,
    AIAA 80-1773, 1980): m = k (h_w − h_ref) × B / |B|², whose torque m × B = −k (h_w − h_ref)
    perpendicular to B. Beside a wheel law, which holds the attitude: the magnetic torque then
    takes the momentum out of the wheels.

    Parameters
    ----------
    gain : float
        k (1/s).
    reference : array_like (3,), optional
        h_ref, the wheel momentum to keep in body axes (N m s; default 0).
    """

    gain: float
    reference: np.ndarray

    def __init__(self, gain: Any, reference: Any = None):
        object.__setattr__(self, "gain", positive_gain(gain, "gain", "1 / s"))
        r = np.zeros(3) if reference is None else as_float_array(reference, "reference",
                                                                 unit="kg m2 / s")  # fmt: skip
        if r.shape != (3,):
            raise AttitudeValueError(f"reference: expected 3 body-axis components, got {r.shape}")
        object.__setattr__(self, "reference", r)

    def __repr__(self) -> str:
        return f"MomentumDumping(gain={self.gain!r})"
