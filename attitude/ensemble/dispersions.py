"""Monte Carlo dispersions of a nominal initial state and body (the ``[ensemble]`` table)."""

from __future__ import annotations

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
__all__ = ["DISTRIBUTIONS", "OUTPUTS", "Dispersed", "Dispersions", "disperse"]
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
    output: str = "samples"
    every: int = 1
    percentiles: tuple[float, ...] | None = None
    max_output_size: float = MAX_OUTPUT_SIZE
    key: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self.key = np.random.SeedSequence(self.seed).generate_state(2, np.uint64)

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
        params = np.array(np.broadcast_to(self.params, (stop - start, self.params.shape[0])))
        params[:, 0:3] = inert
        y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
        return params, y0, inert, corr

    def member_vars(self, start: int, stop: int) -> dict[str, tuple]:
        """The members' drawn initial states and the errors applied (``name: (dims, values,
        attrs)``; ``units`` "rate"/"momentum" are replaced by the output's units)."""
        q, Q, _ = self.disp.sample(self.q0, self.Q0, self.inertia0, start, stop)
        dtheta, domega, eps = self.disp.draws(start, stop)
        out = initial_state_vars(q, Q)
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
            {
                "units": "rate",
                "long_name": "body-rate error applied: omega = omega_nominal + domega",
            },
        )
        out["dispersion_inertia"] = (
            ("member", "axis"),
            eps,
            {
                "units": "1",
                "long_name": "relative inertia error applied: I = I_nominal (1 + eps)",
            },
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

    def nominal_params(self, inertia: np.ndarray | None = None) -> np.ndarray:
        """The compiled loop's parameter row (P,) of the nominal body and potential."""
        params = np.array(self.params, dtype=np.float64)
        params[0:3] = self.inertia0 if inertia is None else inertia
        return params
