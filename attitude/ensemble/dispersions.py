"""Monte Carlo dispersions of a nominal initial state and body (the ``[ensemble]`` table)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..errors import AttitudeValueError
from ._members import _project, initial_state_vars
from ._plan import MAX_OUTPUT_SIZE, OUTPUTS

# ------------------------------------------------------------------------------------------------
# dispersions: the [ensemble] table of a scenario
# ------------------------------------------------------------------------------------------------

DISTRIBUTIONS = ("normal", "uniform")
__all__ = [
    "DISTRIBUTIONS",
    "OUTPUTS",
    "Dispersed",
    "DispersedSpacecraft",
    "Dispersions",
    "disperse",
    "disperse_spacecraft",
]
#: Normal inertia errors are truncated at this many standard deviations (so every member is
#: a rigid body; checked for the worst case before any work).
INERTIA_TRUNCATION = 3.0
#: Uniform draws per member (3 attitude, 3 rate, 3 inertia; padded to whole Philox blocks).
_DRAWS = 12


@dataclass
class Dispersions:
    """Monte Carlo dispersions about a scenario's nominal initial state.

    Member ``i`` (0-based) of the ensemble is

    * attitude ``q_i = q0 ∘ exp(δθ_i / 2)``: a small rotation ``δθ_i`` (rotation vector, body
      axes, rad) applied in the body frame;
    * body rate ``ω_i = ω0 + δω_i`` with ω0 = g0 / I the nominal body angular velocity and
      ``δω_i`` per body axis (rad per time unit);
    * inertia ``I_i = I ∘ (1 + ε_i)``, per axis, relative;
    * momenta ``Q_i = 2 q_i ∘ (0, I_i ω_i)``.

    Each error has a distribution per axis: ``"normal"`` (the value is the standard
    deviation; inertia errors truncated at ±3σ) or ``"uniform"`` (the value is the
    half-width). The draws of member ``i`` come from a counter-based generator (Philox) at
    position ``i``: they do not depend on the ensemble size or on the chunking, so the first
    1000 members of a 10⁶-member run are those of a 1000-member run with the same seed.

    The table's output options are kept here too: ``output``, ``every``, ``percentiles`` and
    ``max_output_size`` (bytes, ``math.inf``: no limit) of
    :func:`attitude.ensemble.propagate_ensemble`.
    """

    size: int
    seed: int = 0
    chunk: int | None = None
    attitude_error: float = 0.0
    attitude_distribution: str = "normal"
    rate_error: float = 0.0
    rate_distribution: str = "normal"
    inertia_error: float = 0.0
    inertia_distribution: str = "normal"
    position_error: float = 0.0
    velocity_error: float = 0.0
    mass_error: float = 0.0
    output: str = "samples"
    every: int = 1
    percentiles: tuple[float, ...] | None = None
    max_output_size: float = MAX_OUTPUT_SIZE
    key: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self.key = np.random.SeedSequence(self.seed).generate_state(2, np.uint64)

    @property
    def disperses_orbit(self) -> bool:
        """Whether the members' orbits or masses differ (a spacecraft carrying its orbit)."""
        return bool(self.position_error or self.velocity_error or self.mass_error)

    def uniforms(self, start: int, stop: int) -> np.ndarray:
        """The (stop − start, 12) uniform draws in (0, 1) of members start..stop−1."""
        bg = np.random.Philox(key=self.key, counter=start * (_DRAWS // 4))
        u = np.random.Generator(bg).random((stop - start, _DRAWS))
        return u + 2.0**-54  # k 2⁻⁵³ + 2⁻⁵⁴: strictly inside (0, 1), symmetric about ½

    @staticmethod
    def _transform(u: np.ndarray, width: float, dist: str, truncate: float | None = None):
        if width == 0.0:
            return np.zeros_like(u)
        if dist == "uniform":
            return width * (2.0 * u - 1.0)
        from scipy.special import ndtr, ndtri

        if truncate is None:
            return width * ndtri(u)
        lo = ndtr(-truncate)
        return width * ndtri(lo + u * (1.0 - 2.0 * lo))

    def max_inertia_error(self) -> float:
        """Largest relative inertia error any member can get."""
        if self.inertia_distribution == "uniform":
            return self.inertia_error
        return INERTIA_TRUNCATION * self.inertia_error

    def check_body(self, inertia: np.ndarray, where: str = "ensemble.inertia_error") -> None:
        """Raise unless every dispersed inertia is a rigid body (worst case, before any work)."""
        eps = self.max_inertia_error()
        if eps >= 1.0:
            raise AttitudeValueError(
                f"{where}: a relative error up to {eps:g} can make a moment of inertia zero or "
                "negative; use a smaller error"
            )
        for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            if (inertia[a] + inertia[b]) * (1.0 - eps) < inertia[c] * (1.0 + eps):
                raise AttitudeValueError(
                    f"{where}: with relative errors up to {eps:g} some members would violate "
                    f"the triangle inequality I{a + 1} + I{b + 1} >= I{c + 1} (the body "
                    f"{inertia.tolist()} is too close to it); use a smaller error"
                    + (" or inertia_distribution = 'uniform'" if eps > self.inertia_error else "")
                )

    def draws(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The errors applied to members start..stop−1.

        Returns
        -------
        dtheta : ndarray, shape (C, 3)
            Attitude error rotation vectors (body axes, rad): q_i = q0 ∘ exp(δθ_i / 2).
        domega : ndarray, shape (C, 3)
            Body-rate errors (rad per time unit): ω_i = ω0 + δω_i.
        eps : ndarray, shape (C, 3)
            Relative inertia errors: I_i = I ∘ (1 + ε_i).
        """
        u = self.uniforms(start, stop)
        dtheta = self._transform(u[:, 0:3], self.attitude_error, self.attitude_distribution)
        domega = self._transform(u[:, 3:6], self.rate_error, self.rate_distribution)
        eps = self._transform(
            u[:, 6:9], self.inertia_error, self.inertia_distribution, INERTIA_TRUNCATION
        )
        return dtheta, domega, eps

    def sample(
        self, q0: np.ndarray, Q0: np.ndarray, inertia: np.ndarray, start: int, stop: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Initial states and inertia of members start..stop−1 about the nominal (q0, Q0, I).

        Returns
        -------
        q : ndarray, shape (C, 4)
        Q : ndarray, shape (C, 4)
        inertia : ndarray, shape (C, 3)
        """
        from ..quaternion import from_rotation_vector, multiply

        dtheta, domega, eps = self.draws(start, stop)
        # Nominal body rate ω0 = g0 / I, g0 = ½ vec(q̃0∘Q0) (Arribas et al. eq. 17).
        w = multiply(q0 * np.array([1.0, -1.0, -1.0, -1.0]), Q0)
        omega0 = 0.5 * w[1:] / inertia
        q = multiply(q0, from_rotation_vector(dtheta))
        inert = inertia * (1.0 + eps)
        g = inert * (omega0 + domega)
        Q = 2.0 * multiply(q, np.concatenate([np.zeros((g.shape[0], 1)), g], axis=1))
        return q, Q, inert

    def attrs(self) -> dict[str, Any]:
        """Global attrs recording the dispersions (internal units: rad, rad per time unit)."""
        return {
            "ensemble_seed": np.int64(self.seed),
            "ensemble_attitude_error": float(self.attitude_error),
            "ensemble_attitude_distribution": self.attitude_distribution,
            "ensemble_rate_error": float(self.rate_error),
            "ensemble_rate_distribution": self.rate_distribution,
            "ensemble_inertia_error": float(self.inertia_error),
            "ensemble_inertia_distribution": self.inertia_distribution,
            **(
                {
                    "ensemble_position_error": float(self.position_error),
                    "ensemble_velocity_error": float(self.velocity_error),
                    "ensemble_mass_error": float(self.mass_error),
                }
                if self.disperses_orbit
                else {}
            ),
            "ensemble_sampling": (
                "member i: Philox(SeedSequence(seed)) at counter 3 i; q_i = q0 o exp(dtheta/2) "
                "(body axes), omega_i = omega0 + domega, I_i = I (1 + eps) (normal: truncated "
                "at 3 sigma), Q_i = 2 q_i o (0, I_i omega_i)"
            ),
        }


class Dispersed(NamedTuple):
    """Ensemble members drawn by :func:`disperse`, in the arguments of
    :func:`~attitude.ensemble.propagate_ensemble`::

        d = disperse(body, q0, Q0, 1000, attitude_error=1 * u.deg, inertia_error=0.05)
        ds = propagate_ensemble(d.inertia, d.q, d.Q, t, potential, nominal=d.nominal)

    Attributes
    ----------
    inertia : RigidBody, or Quantity / ndarray, shape (N, 3)
        The members' principal moments (kg m² for a body with units, plain numbers for a
        dimensionless one); the nominal body itself when ``inertia_error`` is 0.
    q : ndarray, shape (N, 4)
        Initial attitudes, q_i = q0∘exp(δθ_i/2).
    Q : ndarray, shape (N, 4)
        Initial momenta, Q_i = 2 q_i∘(0, I_i ω_i) (kg m² s⁻¹ for a body with units).
    nominal : tuple (q0, Q0, RigidBody)
        The nominal state (projected onto |q| = 1, q·Q = 0) and body: ``nominal=`` of
        ``propagate_ensemble`` (the reference of the pointing error).
    errors : dict of ndarray, shape (N, 3)
        The errors applied: ``"attitude"`` (δθ, rad, body axes), ``"rate"`` (δω, rad/s or rad
        per time unit), ``"inertia"`` (ε, relative).
    """

    inertia: Any
    q: np.ndarray
    Q: np.ndarray
    nominal: tuple
    errors: dict


def disperse(
    body: Any,
    q0: Any,
    Q0: Any,
    size: int,
    *,
    attitude_error: Any = 0.0,
    rate_error: Any = 0.0,
    inertia_error: float = 0.0,
    seed: int = 0,
    attitude_distribution: str = "normal",
    rate_distribution: str = "normal",
    inertia_distribution: str = "normal",
    start: int = 0,
) -> Dispersed:
    """Monte Carlo dispersions about a nominal state and body: the ``[ensemble]`` table of a
    scenario (docs/ensemble.md), from Python.

    Member ``i`` gets q_i = q0∘exp(δθ_i/2) (δθ_i a small rotation in body axes),
    ω_i = ω0 + δω_i (ω0 = g0/I the nominal body rate), I_i = I (1 + ε_i) per axis and
    Q_i = 2 q_i∘(0, I_i ω_i). Each error is normal (the value is the standard deviation) or
    uniform (the half-width) per axis; **normal inertia errors are truncated at ±3σ**
    (:data:`INERTIA_TRUNCATION`) and the worst case is checked before drawing, so every member
    is a rigid body (an untruncated 5 % normal draw puts a thin body's moments across a
    triangle inequality and aborts the run). The draws of member i are the Philox generator at
    counter 3i (key from ``SeedSequence(seed)``): the same members as a scenario with the same
    table and seed, whatever ``size``.

    Parameters
    ----------
    body : RigidBody, array_like or Quantity, shape (3,)
        The nominal body.
    q0, Q0 : array_like, shape (4,)
        The nominal initial state (Q0 in kg m² s⁻¹ for a body with units; a Quantity is
        converted); projected onto |q| = 1, q·Q = 0 first (within 1e-6), as a scenario's.
    size : int
        Number of members N.
    attitude_error : float or Quantity
        Per body axis (an angle: plain numbers are rad).
    rate_error : float or Quantity
        Per body axis (a rate: plain numbers are rad/s, or rad per time unit for a
        dimensionless body).
    inertia_error : float
        Relative, per axis (0.05 for 5 %).
    seed : int
        The scenario's ``seed``.
    attitude_distribution, rate_distribution, inertia_distribution : {"normal", "uniform"}
    start : int
        Index of the first member (members start .. start + size − 1: a slice of a larger
        ensemble).

    Returns
    -------
    Dispersed
        ``inertia``, ``q``, ``Q``, ``nominal`` and ``errors``.

    Raises
    ------
    AttitudeValueError
        Bad values (naming the parameter), or an inertia error whose worst case is not a
        rigid body (use a smaller error, or a uniform distribution).
    """
    from astropy import units as u

    from .._validation import as_float_array, as_int, as_rate
    from ..body import RigidBody, inertia_rows
    from ..canonical import project_state

    moments, units = inertia_rows(body, "body")
    if moments.shape != (3,):
        raise AttitudeValueError(
            f"body: the nominal body (3 principal moments), got shape {moments.shape}"
        )
    nominal_body = body if isinstance(body, RigidBody) else RigidBody(moments, units)
    size = as_int(size, "size")
    start = as_int(start, "start", low=0)
    seed = as_int(seed, "seed", low=0)
    q = as_float_array(q0, "q0", trailing=4, ndim=1)
    Q = as_float_array(Q0, "Q0", trailing=4, ndim=1, unit=None if units is None else "kg m2 / s")
    qn, Qn, _ = project_state(q, Q)
    if isinstance(attitude_error, u.Quantity):
        try:
            attitude_error = attitude_error.to_value(u.rad)
        except u.UnitConversionError:
            raise AttitudeValueError(
                f"attitude_error: units {attitude_error.unit} are not an angle"
            ) from None
    att = float(as_float_array(attitude_error, "attitude_error", ndim=0))
    rate = float(as_rate(rate_error, "rate_error", dimensional=units is not None, trailing=None))
    ie = float(as_float_array(inertia_error, "inertia_error", ndim=0))
    for name, v in (("attitude_error", att), ("rate_error", rate), ("inertia_error", ie)):
        if not v >= 0:
            raise AttitudeValueError(f"{name}: must be >= 0 (a standard deviation or half-width)")
    dists = {
        "attitude_distribution": attitude_distribution,
        "rate_distribution": rate_distribution,
        "inertia_distribution": inertia_distribution,
    }
    for key, d in dists.items():
        if d not in DISTRIBUTIONS:
            raise AttitudeValueError(
                f"{key}: expected one of {', '.join(map(repr, DISTRIBUTIONS))}, got {d!r}"
            )
    disp = Dispersions(
        size=start + size, seed=seed, attitude_error=att, rate_error=rate, inertia_error=ie,
        **dists,
    )  # fmt: skip
    disp.check_body(moments, "inertia_error")
    qs, Qs, inert = disp.sample(qn, Qn, moments, start, start + size)
    dtheta, domega, eps = disp.draws(start, start + size)
    if ie == 0:
        bodies: Any = nominal_body
    else:
        bodies = inert * u.Unit(units) if units is not None else inert
    return Dispersed(
        bodies, qs, Qs, (qn, Qn, nominal_body),
        {"attitude": dtheta, "rate": domega, "inertia": eps},
    )  # fmt: skip


def dispersion_vars(disp: Dispersions, start: int, stop: int) -> dict[str, tuple]:
    """The errors applied to members start..stop−1 and their draw counters, as variables
    (``name: (dims, values, attrs)``; ``units`` "rate" is replaced by the output's rate unit)."""
    dtheta, domega, eps = disp.draws(start, stop)
    out: dict[str, tuple] = {}
    out["dispersion_attitude"] = (
        ("member", "axis"),
        dtheta,
        {
            "units": "rad",
            "long_name": "attitude error applied: rotation vector in body axes, "
            "q = q_nominal o exp(dtheta / 2)",
        },
    )
    out["dispersion_rate"] = (
        ("member", "axis"),
        domega,
        {"units": "rate", "long_name": "body-rate error applied: omega = omega_nominal + domega"},
    )
    out["dispersion_inertia"] = (
        ("member", "axis"),
        eps,
        {"units": "1", "long_name": "relative inertia error applied: I = I_nominal (1 + eps)"},
    )
    counter = (np.arange(start, stop, dtype=np.int64)) * (_DRAWS // 4)
    out["member_draw_counter"] = (
        ("member",),
        counter,
        {
            "units": "1",
            "long_name": "Philox counter of the member's draws (key from "
            "SeedSequence(ensemble_seed); 3 x member index)",
        },
    )
    return out


class _Sampled:
    """Members drawn chunk by chunk from :class:`Dispersions` (memory: one chunk)."""

    def __init__(self, disp: Dispersions, q0, Q0, inertia, params):
        self.disp = disp
        self.q0 = q0
        self.Q0 = Q0
        self.inertia0 = inertia
        self.params = params
        self.n = disp.size
        self.shared_inertia = inertia if disp.inertia_error == 0 else None

    def block(self, start: int, stop: int):
        q, Q, inert = self.disp.sample(self.q0, self.Q0, self.inertia0, start, stop)
        qp, Qp, corr = _project(q, Q, start)
        params = np.array(
            np.broadcast_to(self.params, (stop - start, self.params.shape[0])), order="C"
        )  # (a copy of a broadcast is Fortran-ordered: the compiled loops take C order)
        params[:, 0:3] = inert
        y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
        return params, y0, inert, corr

    def member_vars(self, start: int, stop: int) -> dict[str, tuple]:
        """The members' drawn initial states and the errors applied (``name: (dims, values,
        attrs)``; ``units`` "rate"/"momentum" are replaced by the output's units)."""
        q, Q, _ = self.disp.sample(self.q0, self.Q0, self.inertia0, start, stop)
        out = initial_state_vars(q, Q)
        out.update(dispersion_vars(self.disp, start, stop))
        return out

    def nominal_params(self, inertia: np.ndarray | None = None) -> np.ndarray:
        """The compiled loop's parameter row (P,) of the nominal body and potential."""
        params = np.array(self.params, dtype=np.float64)
        params[0:3] = self.inertia0 if inertia is None else inertia
        return params


# ------------------------------------------------------------------------------------------------
# dispersions of spacecraft with actuators and flight software
# ------------------------------------------------------------------------------------------------

#: The gains of each built-in control law that ``gain_error`` disperses (each by its own
#: factor 1 + ε).
LAW_GAINS = {
    "MRPFeedback": ("K", "P"),
    "QuaternionFeedback": ("K", "C"),
    "RateDamping": ("K",),
    "BDot": ("gain",),
}
#: The noise parameters of each sensor that ``sensor_noise_error`` disperses.
SENSOR_NOISES = {
    "gyro": ("arw", "rrw"),
    "star_tracker": ("noise",),
    "magnetometer": ("noise",),
    "sun_sensor": ("noise",),
}


def _copy_with(obj: Any, **changes: Any) -> Any:
    """A copy of a frozen actuator, law or sensor with some attributes changed (values already
    valid: the worst case is checked before drawing)."""
    new = object.__new__(type(obj))
    for k, v in vars(obj).items():
        object.__setattr__(new, k, v)
    for k, v in changes.items():
        object.__setattr__(new, k, v)
    return new


def _laws(software: Any) -> list[tuple[int, Any]]:
    """(mode index, built-in law) of every mode whose law has gains to disperse."""
    out = []
    for k, (_, mode) in enumerate(software.modes):
        law = mode.control[0] if isinstance(mode.control, tuple) else mode.control
        if type(law).__name__ in LAW_GAINS:
            out.append((k, law))
    return out


class DispersedSpacecraft(NamedTuple):
    """Ensemble members drawn by :func:`disperse_spacecraft`, in the arguments of
    :func:`~attitude.ensemble.propagate_ensemble`::

        d = disperse_spacecraft(craft, q0, omega0, 1000, software=fsw, inertia_error=0.05,
                                rate_error=1e-3, gain_error=0.1, seed=1)
        ds = propagate_ensemble(d.spacecraft, d.q, d.Q, t, software=d.software, seed=2)

    Attributes
    ----------
    spacecraft : list of N Spacecraft
        The members' spacecraft (body inertia and actuator parameters dispersed).
    q : ndarray, shape (N, 4)
        Initial attitudes, q_i = q0∘exp(δθ_i/2).
    Q : ndarray, shape (N, 4)
        Initial momenta of body and wheels (kg m² s⁻¹ for a body with units) from ω_i and the
        member's wheel speeds.
    software : list of N FlightSoftware, or None
        The members' flight software (gains and sensor noise dispersed; the sensors' seeds are
        the ensemble's, drawn by ``propagate_ensemble(seed=...)``).
    errors : dict of ndarray, shape (N, ...)
        The errors applied (``"attitude"``, ``"rate"``, ``"inertia"``, ``"wheel_inertia"``,
        ``"wheel_speed"``, ``"wheel_max_torque"``, ``"magnetorquer_max_dipole"``,
        ``"thruster_max_thrust"``, ``"gain"``, ``"sensor_noise"``, ``"gyro_bias"``: the ones
        the spacecraft and software have).
    """

    spacecraft: list
    q: np.ndarray
    Q: np.ndarray
    software: list | None
    errors: dict


def disperse_spacecraft(
    spacecraft: Any,
    q0: Any,
    omega0: Any,
    size: int,
    *,
    software: Any = None,
    seed: int = 0,
    attitude_error: Any = 0.0,
    rate_error: Any = 0.0,
    inertia_error: float = 0.0,
    wheel_inertia_error: float = 0.0,
    wheel_speed_error: Any = 0.0,
    wheel_max_torque_error: float = 0.0,
    magnetorquer_max_dipole_error: float = 0.0,
    thruster_max_thrust_error: float = 0.0,
    gain_error: float = 0.0,
    sensor_noise_error: float = 0.0,
    gyro_bias_error: Any = 0.0,
    distribution: str = "normal",
    start: int = 0,
) -> DispersedSpacecraft:
    """Monte Carlo dispersions of a spacecraft with actuators and its flight software
    (docs/ensemble.md, "Spacecraft with actuators and flight software").

    Member ``i`` gets, about the nominal spacecraft, state and software:

    * attitude q_i = q0∘exp(δθ_i/2) (δθ_i in body axes, rad), body rate ω_i = ω0 + δω_i
      (rad/s), wheel speeds Ω_k + δΩ_k (rad/s);
    * relative errors ε (value × (1 + ε)) of the body's principal moments (per axis), each
      wheel's axial inertia and motor torque limit, each magnetorquer's dipole limit, each
      thruster's thrust, each gain of the software's built-in control laws (:data:`LAW_GAINS`:
      one factor per gain, the matrix gains scaled as a whole) and each sensor's noise
      densities (:data:`SENSOR_NOISES`, one factor per sensor);
    * an absolute error of the gyro's bias per axis (rad/s).

    Each error is ``"normal"`` (the value is the standard deviation; relative errors truncated
    at ±3σ, :data:`INERTIA_TRUNCATION`, and their worst case checked before drawing) or
    ``"uniform"`` (the half-width). Member i's draws are the Philox generator at counter
    i·D/4 (D the draws per member, a multiple of 4; key from ``SeedSequence(seed)``), one
    slot per error whether dispersed or not: they do not depend on ``size`` or on which
    errors are zero. Q_i = 2 q_i∘(0, g_i) with g_i = I_i ω_i + Σ J_k Ω_k a_k the total
    momentum (:func:`attitude.canonical.momenta_from_angular_velocity`).

    Parameters
    ----------
    spacecraft : Spacecraft
        The nominal spacecraft.
    q0 : array_like, shape (4,)
        The nominal initial attitude (normalised).
    omega0 : array_like or Quantity, shape (3,)
        The nominal body angular velocity (rad/s).
    size : int
    software : FlightSoftware, optional
        The nominal flight software (needed for ``gain_error``, ``sensor_noise_error``,
        ``gyro_bias_error``).
    seed : int
    attitude_error, rate_error, wheel_speed_error, gyro_bias_error : float or Quantity
        Absolute, per axis or per wheel (rad, rad/s).
    inertia_error, wheel_inertia_error, wheel_max_torque_error, magnetorquer_max_dipole_error,
    thruster_max_thrust_error, gain_error, sensor_noise_error : float
        Relative (0.05 for 5 %).
    distribution : {"normal", "uniform"}
    start : int
        Index of the first member (a slice of a larger ensemble).

    Returns
    -------
    DispersedSpacecraft

    Raises
    ------
    AttitudeValueError
        A dispersion of a parameter the spacecraft or software does not have (wheel errors
        without wheels, a torque limit that is infinite, gains without a built-in law, a gyro
        bias without a gyro...), a relative error whose worst case makes a value zero or
        negative, or a body whose dispersed inertia is not a rigid body.
    """
    from astropy import units as u

    from .._validation import as_float_array, as_int, as_rate
    from ..canonical import momenta_from_angular_velocity
    from ..errors import AttitudeTypeError
    from ..quaternion import from_rotation_vector, multiply, normalize
    from ..software import FlightSoftware
    from ..spacecraft import Spacecraft

    if not isinstance(spacecraft, Spacecraft):
        raise AttitudeTypeError(
            f"spacecraft: expected an attitude.Spacecraft, got {type(spacecraft).__name__}"
        )
    if software is not None and not isinstance(software, FlightSoftware):
        raise AttitudeTypeError(
            f"software: expected an attitude.FlightSoftware, got {type(software).__name__}"
        )
    size = as_int(size, "size")
    start = as_int(start, "start", low=0)
    seed = as_int(seed, "seed", low=0)
    if distribution not in DISTRIBUTIONS:
        raise AttitudeValueError(
            f"distribution: expected one of {', '.join(map(repr, DISTRIBUTIONS))}, "
            f"got {distribution!r}"
        )
    dim = not spacecraft.body.is_dimensionless
    q0 = normalize(as_float_array(q0, "q0", trailing=4, ndim=1))
    w0 = as_rate(omega0, "omega0", dimensional=dim, trailing=None)
    if np.shape(w0) != (3,):
        raise AttitudeValueError(f"omega0: expected 3 body-axis components, got {np.shape(w0)}")

    def absolute(x, name, unit):
        if isinstance(x, u.Quantity):
            try:
                x = x.to_value(unit, u.dimensionless_angles())
            except u.UnitConversionError:
                raise AttitudeValueError(f"{name}: units {x.unit} are not {unit}") from None
        v = float(as_float_array(x, name, ndim=0))
        if not v >= 0 or not math.isfinite(v):
            raise AttitudeValueError(f"{name}: must be >= 0 (a standard deviation or half-width)")
        return v

    att = absolute(attitude_error, "attitude_error", u.rad)
    rate = absolute(rate_error, "rate_error", u.rad / u.s)
    wsp = absolute(wheel_speed_error, "wheel_speed_error", u.rad / u.s)
    gb = absolute(gyro_bias_error, "gyro_bias_error", u.rad / u.s)
    rel = {
        "inertia_error": inertia_error,
        "wheel_inertia_error": wheel_inertia_error,
        "wheel_max_torque_error": wheel_max_torque_error,
        "magnetorquer_max_dipole_error": magnetorquer_max_dipole_error,
        "thruster_max_thrust_error": thruster_max_thrust_error,
        "gain_error": gain_error,
        "sensor_noise_error": sensor_noise_error,
    }
    worst = INERTIA_TRUNCATION if distribution == "normal" else 1.0
    for name, v in list(rel.items()):
        v = absolute(v, name, u.one)
        rel[name] = v
        if v * worst >= 1.0:
            raise AttitudeValueError(
                f"{name}: a relative error up to {v * worst:g} can make a value zero or "
                "negative; use a smaller error"
            )
    # what the spacecraft and software have
    nw, nm, nt = spacecraft.counts
    laws = _laws(software) if software is not None else []
    gains = [(k, law, g) for k, law in laws for g in LAW_GAINS[type(law).__name__]]
    sensors = tuple(software.sensors or ()) if software is not None else ()
    noisy = [j for j, s in enumerate(sensors) if s.kind in SENSOR_NOISES]
    gyros = [j for j, s in enumerate(sensors) if s.kind == "gyro"]

    def lacks(name, v, cond, what):
        if v > 0 and cond:
            raise AttitudeValueError(f"{name}: {what}; give 0 (or leave it out)")

    lacks(
        "wheel_inertia_error", rel["wheel_inertia_error"], nw == 0, "the spacecraft has no wheels"
    )
    lacks("wheel_speed_error", wsp, nw == 0, "the spacecraft has no wheels")
    lacks("wheel_max_torque_error", rel["wheel_max_torque_error"], nw == 0,
          "the spacecraft has no wheels")  # fmt: skip
    lacks("wheel_max_torque_error", rel["wheel_max_torque_error"],
          any(math.isinf(w.max_torque) for w in spacecraft.wheels),
          "a wheel has no torque limit (max_torque = inf) to disperse")  # fmt: skip
    lacks("magnetorquer_max_dipole_error", rel["magnetorquer_max_dipole_error"], nm == 0,
          "the spacecraft has no magnetorquers")  # fmt: skip
    lacks("thruster_max_thrust_error", rel["thruster_max_thrust_error"], nt == 0,
          "the spacecraft has no thrusters")  # fmt: skip
    lacks("gain_error", rel["gain_error"], not gains,
          "no flight software with a built-in control law (software=, attitude.control) "
          "whose gains could be dispersed")  # fmt: skip
    lacks("sensor_noise_error", rel["sensor_noise_error"], not noisy,
          "no flight software with noisy sensors (software=, attitude.sensors)")  # fmt: skip
    lacks(
        "gyro_bias_error", gb, not gyros, "no flight software with a gyro (attitude.sensors.Gyro)"
    )
    if rel["inertia_error"] > 0:
        chk = Dispersions(size=1, inertia_error=rel["inertia_error"],
                          inertia_distribution=distribution)  # fmt: skip
        chk.check_body(np.asarray(spacecraft.body.inertia, dtype=float), "inertia_error")
    # the draws: one slot per error, whatever is dispersed
    slots = [("attitude", 3), ("rate", 3), ("inertia", 3), ("wheel_inertia", nw),
             ("wheel_speed", nw), ("wheel_max_torque", nw), ("magnetorquer_max_dipole", nm),
             ("thruster_max_thrust", nt), ("gain", len(gains)), ("sensor_noise", len(sensors)),
             ("gyro_bias", 3 * len(gyros))]  # fmt: skip
    n_draws = sum(k for _, k in slots)
    n_draws += -n_draws % 4
    key = np.random.SeedSequence(seed).generate_state(2, np.uint64)
    bg = np.random.Philox(key=key, counter=start * (n_draws // 4))
    uu = np.random.Generator(bg).random((size, n_draws)) + 2.0**-54
    widths = {
        "attitude": (att, None), "rate": (rate, None), "wheel_speed": (wsp, None),
        "gyro_bias": (gb, None), "inertia": (rel["inertia_error"], INERTIA_TRUNCATION),
        "wheel_inertia": (rel["wheel_inertia_error"], INERTIA_TRUNCATION),
        "wheel_max_torque": (rel["wheel_max_torque_error"], INERTIA_TRUNCATION),
        "magnetorquer_max_dipole": (rel["magnetorquer_max_dipole_error"], INERTIA_TRUNCATION),
        "thruster_max_thrust": (rel["thruster_max_thrust_error"], INERTIA_TRUNCATION),
        "gain": (rel["gain_error"], INERTIA_TRUNCATION),
        "sensor_noise": (rel["sensor_noise_error"], INERTIA_TRUNCATION),
    }  # fmt: skip
    errors: dict[str, np.ndarray] = {}
    at = 0
    for name, k in slots:
        width, trunc = widths[name]
        errors[name] = Dispersions._transform(uu[:, at : at + k], width, distribution, trunc)
        at += k
    errors["gyro_bias"] = errors["gyro_bias"].reshape(size, len(gyros), 3)
    # the members
    from ..body import RigidBody

    body = spacecraft.body
    q = multiply(q0, from_rotation_vector(errors["attitude"]))
    crafts, sws, Qs = [], [] if software is not None else None, np.empty((size, 4))
    for i in range(size):
        b = body
        if rel["inertia_error"] > 0:
            b = RigidBody(np.asarray(body.inertia) * (1.0 + errors["inertia"][i]),
                          units=body.units)  # fmt: skip
        wheels = [
            _copy_with(w, inertia=w.inertia * (1.0 + errors["wheel_inertia"][i, k]),
                       speed=w.speed + errors["wheel_speed"][i, k],
                       max_torque=w.max_torque * (1.0 + errors["wheel_max_torque"][i, k]))
            for k, w in enumerate(spacecraft.wheels)
        ]  # fmt: skip
        mags = [
            _copy_with(m, max_dipole=m.max_dipole * (1.0 + errors["magnetorquer_max_dipole"][i, k]))
            for k, m in enumerate(spacecraft.magnetorquers)
        ]
        thr = [
            _copy_with(x, max_thrust=x.max_thrust * (1.0 + errors["thruster_max_thrust"][i, k]))
            for k, x in enumerate(spacecraft.thrusters)
        ]
        craft = Spacecraft(
            b, wheels, mags, thr, spacecraft.orbit,
            center_of_mass=spacecraft.center_of_mass, field=spacecraft.field,
        )  # fmt: skip
        crafts.append(craft)
        Qs[i] = momenta_from_angular_velocity(q[i], w0 + errors["rate"][i], craft)
        if software is not None:
            sws.append(_software_member(software, gains, sensors, gyros, errors, i))
    return DispersedSpacecraft(crafts, q, Qs, sws, errors)


def _software_member(software, gains, sensors, gyros, errors, i):
    """Member ``i``'s flight software: the laws' gains and the sensors' noise scaled, the
    gyros' biases shifted (the rest, and the objects not dispersed, shared)."""
    import copy

    from ..software._software import Mode

    new = copy.copy(software)
    if gains:
        modes = list(software.modes)
        scaled: dict[int, dict[str, Any]] = {}
        for j, (k, _, g) in enumerate(gains):
            scaled.setdefault(k, {})[g] = 1.0 + errors["gain"][i, j]
        for k, factors in scaled.items():
            cond, mode = modes[k]
            law = mode.control[0] if isinstance(mode.control, tuple) else mode.control
            law = _copy_with(law, **{g: getattr(law, g) * f for g, f in factors.items()})
            control = (law, *mode.control[1:]) if isinstance(mode.control, tuple) else law
            modes[k] = (cond, Mode(mode.guidance, control, mode.allocation, mode.name))
        new.modes = modes
    if sensors:
        out = []
        for j, s in enumerate(sensors):
            changes: dict[str, Any] = {}
            f = 1.0 + errors["sensor_noise"][i, j]
            for name in SENSOR_NOISES.get(s.kind, ()):
                v = getattr(s, name)
                changes[name] = tuple(x * f for x in v) if isinstance(v, tuple) else v * f
            if j in gyros:
                changes["bias"] = s.bias + errors["gyro_bias"][i, gyros.index(j)]
            out.append(_copy_with(s, **changes) if changes else s)
        new.sensors = tuple(out)
    return new
