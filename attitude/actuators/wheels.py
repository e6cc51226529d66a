"""Reaction wheels: :class:`ReactionWheel` and the usual four-wheel :func:`pyramid`.

A wheel is a balanced rotor spinning about a body-fixed axis a (unit, body axes) with axial
inertia J; its motor applies the torque u to the rotor and −u to the body. The spacecraft with
wheels is a gyrostat (docs/actuators.md, :mod:`attitude._core.gyrostat`): the state carries
each wheel's axial angular momentum h = J (a·ω + Ω), Ω the wheel's speed relative to the body,
which changes at the rate u + f(Ω) (f the bearing friction torque).

The model is Basilisk's balanced wheel (``reactionWheelStateEffector`` with ``BalancedWheels``):
the same friction law (Coulomb, viscous, static with a Stribeck speed, linear below a
limit-cycle speed) and the same command limits (motor torque, dead band, power, and the cut at
the speed limit of a command that would spin the wheel further).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .._validation import as_float_array, as_scalar
from ..errors import AttitudeTypeError, AttitudeValueError
from ._common import limit, nonnegative, optional_name, speeds_value, unit_axis

__all__ = ["ISOTROPIC_ELEVATION", "ReactionWheel", "pyramid", "wheel_record"]

#: Elevation of the spin axes above the plane of a four-wheel pyramid for which Σ a aᵀ is
#: isotropic (2 cos²ε = 4 sin²ε): arctan(1/√2) = 35.26°.
ISOTROPIC_ELEVATION = math.atan(1.0 / math.sqrt(2.0))

#: Basilisk's default limit-cycle speed (``RWConfigPayload.omegaLimitCycle``), rad/s.
DEFAULT_LIMIT_CYCLE = 1e-4


@dataclass(frozen=True, init=False)
class ReactionWheel:
    """A reaction wheel (balanced rotor) on a body-fixed spin axis.

    Parameters
    ----------
    axis : array_like, shape (3,)
        Spin axis a in body axes (normalised; a warning if |a| is more than 1e-6 from 1).
    inertia : float or Quantity
        Axial moment of inertia J (kg m²).
    max_torque : float or Quantity
        Motor torque limit (N m); a command beyond it is clipped (default: none).
    max_speed : float or Quantity
        Speed limit relative to the body (rad/s; a Quantity such as
        ``6000 * u.cycle / u.min``, i.e. rpm, is converted): at a boundary where
        |Ω| >= max_speed a command that would spin the wheel further is cut to zero, as
        Basilisk does (default: none).
    speed : float or Quantity
        Initial speed Ω relative to the body (rad/s, or a Quantity such as
        ``100 * u.cycle / u.min``).
    min_torque : float or Quantity
        Commands below this magnitude are not applied (N m; Basilisk's ``u_min``).
    max_power : float or Quantity
        Motor power limit (W): |u Ω| is clipped to it (Basilisk's ``P_max``; default none).
    coulomb_friction, static_friction : float or Quantity
        Coulomb and static friction torques f_c, f_s (N m).
    viscous_friction : float or Quantity
        Viscous friction coefficient c_v (N m s).
    stribeck_speed : float or Quantity, optional
        Stribeck speed β (rad/s): with it, a wheel starting from rest feels the static friction
        f_s decaying to f_c (Basilisk's ``betaStatic``); None: no Stribeck regime.
    limit_cycle_speed : float or Quantity
        Below this speed the friction is linear in Ω (Basilisk's ``omegaLimitCycle``,
        default 1e-4 rad/s; 0 turns it off).
    name : str, optional
        Label in results (default ``wheel<k>``).
    """

    axis: np.ndarray
    inertia: float
    max_torque: float
    max_speed: float
    speed: float
    min_torque: float
    max_power: float
    coulomb_friction: float
    static_friction: float
    viscous_friction: float
    stribeck_speed: float | None
    limit_cycle_speed: float
    name: str | None

    def __init__(
        self,
        axis: Any,
        inertia: Any,
        *,
        max_torque: Any = math.inf,
        max_speed: Any = math.inf,
        speed: Any = 0.0,
        min_torque: Any = 0.0,
        max_power: Any = math.inf,
        coulomb_friction: Any = 0.0,
        static_friction: Any = 0.0,
        viscous_friction: Any = 0.0,
        stribeck_speed: Any = None,
        limit_cycle_speed: Any = DEFAULT_LIMIT_CYCLE,
        name: str | None = None,
    ):
        s = object.__setattr__
        s(self, "axis", unit_axis(axis, "axis"))
        J = limit(inertia, "inertia", "kg m2", "axial moment of inertia")
        if not math.isfinite(J):
            raise AttitudeValueError("inertia: the axial moment of inertia must be finite")
        s(self, "inertia", J)
        s(self, "max_torque", limit(max_torque, "max_torque", "N m", "torque limit"))
        s(self, "max_speed", limit(max_speed, "max_speed", "rad / s", "speed limit"))
        s(self, "speed", as_scalar(speeds_value(speed, "speed"), "speed"))
        s(self, "min_torque", nonnegative(min_torque, "min_torque", "N m", "dead band"))
        s(self, "max_power", limit(max_power, "max_power", "W", "power limit"))
        s(
            self,
            "coulomb_friction",
            nonnegative(coulomb_friction, "coulomb_friction", "N m", "Coulomb friction torque"),
        )
        s(
            self,
            "static_friction",
            nonnegative(static_friction, "static_friction", "N m", "static friction torque"),
        )
        s(
            self,
            "viscous_friction",
            nonnegative(
                viscous_friction, "viscous_friction", "N m s", "viscous friction coefficient"
            ),
        )
        if stribeck_speed is None:
            beta = None
        else:
            beta = limit(stribeck_speed, "stribeck_speed", "rad / s", "Stribeck speed")
            if not math.isfinite(beta):
                raise AttitudeValueError("stribeck_speed: must be finite (or None for none)")
        s(self, "stribeck_speed", beta)
        s(
            self,
            "limit_cycle_speed",
            nonnegative(limit_cycle_speed, "limit_cycle_speed", "rad / s", "limit-cycle speed"),
        )
        s(self, "name", optional_name(name, "wheel"))
        if self.min_torque >= self.max_torque:
            raise AttitudeValueError(
                f"min_torque: {self.min_torque!r} is not below max_torque {self.max_torque!r}: "
                "no command could ever be applied"
            )

    @property
    def momentum_capacity(self) -> float:
        """J × max_speed: the largest axial momentum relative to the body (N m s; inf if no
        speed limit)."""
        return self.inertia * self.max_speed

    def with_speed(self, speed: Any) -> ReactionWheel:
        """The same wheel starting at another speed (rad/s, or a Quantity)."""
        new = replace(self)
        object.__setattr__(new, "speed", as_scalar(speeds_value(speed, "speed"), "speed"))
        return new

    def friction(self, speed: Any, stribeck: bool = False) -> np.ndarray:
        """The friction torque on the wheel at relative speeds ``speed`` (N m; the compiled
        kernel's values), in the Coulomb (default) or the Stribeck regime."""
        from .._core import actuators as _ka

        om = as_float_array(speeds_value(speed, "speed"), "speed")
        rec = wheel_record(self)
        rec[_ka.WHEEL.STRIBECK] = 1.0 if (stribeck and self.stribeck_speed is not None) else 0.0
        sc = np.zeros(_ka.SC.WHEELS + _ka.WHEEL.SIZE)
        sc[_ka.SC.WHEELS :] = rec
        flat = om.reshape(-1)
        out = np.array([_ka.wheel_friction(sc, _ka.SC.WHEELS, float(w)) for w in flat])
        return out.reshape(om.shape)

    def __repr__(self) -> str:
        extra = []
        for key, default in (
            ("max_torque", math.inf),
            ("max_speed", math.inf),
            ("speed", 0.0),
            ("min_torque", 0.0),
            ("max_power", math.inf),
            ("coulomb_friction", 0.0),
            ("static_friction", 0.0),
            ("viscous_friction", 0.0),
            ("stribeck_speed", None),
            ("limit_cycle_speed", DEFAULT_LIMIT_CYCLE),
            ("name", None),
        ):
            v = getattr(self, key)
            if v != default:
                extra.append(f"{key}={v!r}")
        tail = "".join(", " + e for e in extra)
        return f"ReactionWheel(axis={self.axis.tolist()}, inertia={self.inertia!r}{tail})"


def pyramid(
    inertia: Any,
    *,
    elevation: Any = ISOTROPIC_ELEVATION,
    axis: Any = (0.0, 0.0, 1.0),
    speeds: Sequence[Any] | None = None,
    **wheel: Any,
) -> tuple[ReactionWheel, ...]:
    """Four identical wheels in the usual pyramid about ``axis``.

    The spin axes are a_k = cos ε (cos α_k e₁ + sin α_k e₂) + sin ε e₃ with α_k = 0°, 90°,
    180°, 270°, where e₃ is the pyramid axis and (e₁, e₂) complete it (for the default
    e₃ = z: e₁ = x, e₂ = y). The default elevation ε = arctan(1/√2) = 35.26° makes Σ a_k a_kᵀ
    = (4/3) 1, so the four wheels give the same momentum capacity about every body axis
    (Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*,
    2014, Sect. 7.2.1). Any three of the four axes are independent: the pyramid survives the
    loss of one wheel.

    Parameters
    ----------
    inertia : float or Quantity
        Axial inertia of each wheel (kg m²).
    elevation : float or Quantity
        ε, the angle of the spin axes above the plane normal to the pyramid axis (rad, or an
        angle Quantity); 0 < ε < 90°.
    axis : array_like, shape (3,)
        The pyramid axis e₃ in body axes.
    speeds : sequence of 4 floats or Quantities, optional
        Initial speeds of the four wheels (rad/s).
    **wheel
        Further :class:`ReactionWheel` parameters shared by the four (``max_torque``,
        ``max_speed``, friction...).

    Returns
    -------
    tuple of ReactionWheel
        The four wheels, named ``wheel1`` ... ``wheel4``.
    """
    from astropy import units as u

    if isinstance(elevation, u.Quantity):
        try:
            elevation = elevation.to_value(u.rad)
        except u.UnitConversionError:
            raise AttitudeValueError(
                f"elevation: units {elevation.unit} are not an angle"
            ) from None
    eps = as_scalar(elevation, "elevation")
    if not 0.0 < eps < 0.5 * math.pi:
        raise AttitudeValueError(
            f"elevation: must lie strictly between 0 and 90 degrees, got {math.degrees(eps):g}°"
        )
    e3 = unit_axis(axis, "axis")
    # a right-handed (e1, e2, e3); for e3 = z this is (x, y, z)
    trial = np.array([1.0, 0.0, 0.0]) if abs(e3[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = trial - e3 * float(trial @ e3)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e3, e1)
    if speeds is None:
        speeds = [0.0] * 4
    if isinstance(speeds, u.Quantity):
        speeds = list(speeds) if not speeds.isscalar else [speeds]
    try:
        if isinstance(speeds, (str, bytes, dict)):
            raise TypeError
        n_speeds = len(speeds)
    except TypeError:
        raise AttitudeTypeError(
            f"speeds: expected 4 initial speeds (rad/s), got {type(speeds).__name__}"
        ) from None
    if n_speeds != 4:
        raise AttitudeValueError(f"speeds: expected 4 initial speeds, got {n_speeds}")
    out = []
    for k in range(4):
        a = math.radians(90.0 * k)
        v = math.cos(eps) * (math.cos(a) * e1 + math.sin(a) * e2) + math.sin(eps) * e3
        v = v / np.linalg.norm(v)
        out.append(ReactionWheel(v, inertia, speed=speeds[k], name=f"wheel{k + 1}", **wheel))
    return tuple(out)


def wheel_record(w: ReactionWheel) -> np.ndarray:
    """The wheel's record of the spacecraft block (:mod:`attitude._core.actuators` layout),
    held slots zero."""
    from .._core import actuators as _ka

    beta = w.stribeck_speed
    lc = w.limit_cycle_speed
    slope_c = slope_s = 0.0
    if lc > 0.0:
        # Basilisk's frictionForceAtLimitCycle / omegaLimitCycle in each regime
        slope_c = (w.coulomb_friction + w.viscous_friction * lc) / lc
        if beta is not None:
            x = lc / beta
            f = (
                math.sqrt(2.0 * math.e)
                / math.sqrt(2.0)
                * (w.static_friction - w.coulomb_friction)
                * math.exp(-0.5 * x * x)
                * x
                + w.coulomb_friction * math.tanh(10.0 * x)
                + w.viscous_friction * lc
            )
            slope_s = f / lc
    has = (
        w.coulomb_friction > 0
        or w.viscous_friction > 0
        or (beta is not None and w.static_friction > 0)
    )
    return _ka.WHEEL.pack(
        axis=w.axis,
        j=w.inertia,
        invj=1.0 / w.inertia,
        fc=w.coulomb_friction,
        fs=w.static_friction,
        beta=-1.0 if beta is None else beta,
        cv=w.viscous_friction,
        lc=lc,
        slope_c=slope_c,
        slope_s=slope_s,
        umax=w.max_torque,
        omax=w.max_speed,
        umin=w.min_torque,
        pmax=w.max_power,
        omega_before=w.speed,
        friction=1.0 if has else 0.0,
    )
