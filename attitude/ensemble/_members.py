"""Ensemble members: validated inputs (states, bodies, potentials), produced chunk by chunk."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validation import as_float_array
from ..body import RigidBody, inertia_rows
from ..errors import AttitudeTypeError, AttitudeValueError
from ..potentials import Potential, as_potential

#: Largest relative defect of an initial state that is projected (as in propagate).
PROJECTION_TOL = 1e-6


# ------------------------------------------------------------------------------------------------
# members: validated inputs, produced chunk by chunk
# ------------------------------------------------------------------------------------------------


class _Members:
    """Validated member inputs; :meth:`block` gives the compiled-kernel rows of a chunk.

    Keeps the caller's arrays (no per-member copies beyond one chunk).
    """

    def __init__(self, q, Q, inertia, params, n):
        self.q = q  # (N, 4) or (4,)
        self.Q = Q  # (N, 4) or (4,)
        self.inertia = inertia  # (N, 3) or (3,)
        self.params = params  # (N, P) or (P,): inertia columns overwritten per member
        self.n = n

    @property
    def per_member_inertia(self) -> bool:
        return self.inertia.ndim == 2

    @property
    def shared_inertia(self) -> np.ndarray | None:
        return None if self.inertia.ndim == 2 else self.inertia

    def _rows(self, a, start, stop):
        return a[start:stop] if a.ndim == 2 else np.broadcast_to(a, (stop - start, a.shape[-1]))

    def block(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(params (C, P), y0 (C, 8), inertia (C, 3), max projection) of members start:stop."""
        q = self._rows(self.q, start, stop)
        Q = self._rows(self.Q, start, stop)
        qp, Qp, corr = _project(q, Q, start)
        inertia = np.ascontiguousarray(self._rows(self.inertia, start, stop))
        params = np.array(self._rows(self.params, start, stop), dtype=np.float64, order="C")
        params[:, 0:3] = inertia
        y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
        return params, y0, inertia, corr

    def nominal_params(self, inertia: np.ndarray | None = None) -> np.ndarray:
        """The parameter row (P,) of the nominal run: the potential all members share, with
        the members' shared body or ``inertia`` (the nominal body of dispersed members)."""
        if self.params.ndim != 1:
            raise AttitudeValueError(
                "nominal: the members have their own potentials, so no one nominal run "
                "exists; give reference= instead (a propagate result of the nominal case on "
                "the same times, or quaternions)"
            )
        if inertia is None and self.inertia.ndim != 1:
            raise AttitudeValueError(
                "nominal: the members have their own inertia (dispersed bodies); give the "
                "nominal body too: nominal=(q0, Q0, body) (attitude.ensemble.disperse returns "
                "it as .nominal), or reference= (a propagate result of the nominal case)"
            )
        params = np.array(self.params, dtype=np.float64)
        params[0:3] = self.inertia if inertia is None else inertia
        return params

    def member_vars(self, start: int, stop: int) -> dict[str, tuple]:
        """Per-member inputs stored in the output: ``name: (dims, values, attrs)``.

        The initial states as given, before the projection onto |q| = 1, q·Q = 0 (as
        :func:`initial_state_vars`); ``units`` "momentum" is replaced by the output's unit.
        """
        return initial_state_vars(self._rows(self.q, start, stop), self._rows(self.Q, start, stop))


def initial_state_vars(q: np.ndarray, Q: np.ndarray) -> dict[str, tuple]:
    """``initial_q``, ``initial_Q`` (member, component): a member's initial state as given or
    drawn, before the projection that every run applies; re-running from it reproduces the
    member bit for bit (attitude.ensemble.rerun_member)."""
    note = (
        "as given or drawn, before the projection onto |q| = 1, q.Q = 0 that every run applies "
        "(largest: initial_projection)"
    )
    return {
        "initial_q": (
            ("member", "component"),
            np.array(q, dtype=np.float64, order="C"),
            {"units": "1", "long_name": f"initial attitude quaternion, {note}"},
        ),
        "initial_Q": (
            ("member", "component"),
            np.array(Q, dtype=np.float64, order="C"),
            {"units": "momentum", "long_name": f"initial conjugate momenta, {note}"},
        ),
    }


def _project(q: np.ndarray, Q: np.ndarray, offset: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Members' states projected onto |q| = 1, q·Q = 0 (canonical.project_state, row-wise).

    Norms and q·Q are taken of rows scaled by a power of two (exact: the unscaled results bit
    for bit wherever those do not overflow), so |Q| up to 1.8e308 is checked correctly.
    """
    sq = _pow2_rows(q)
    qs = q / sq[:, None]
    nq = np.sqrt(np.sum(qs * qs, axis=1)) * sq
    dn = np.abs(nq - 1.0)
    if np.any(dn > PROJECTION_TOL):
        i = int(np.argmax(dn > PROJECTION_TOL))
        raise AttitudeValueError(
            f"q0: member {offset + i}: |q0| = {float(nq[i])!r} is not 1 (off by {dn[i]:.3g} > "
            f"{PROJECTION_TOL:g}); pass unit quaternions (attitude.quaternion.normalize)"
        )
    if np.any(np.all(q == 0.0, axis=1)):  # pragma: no cover - caught by the norm check
        raise AttitudeValueError("q0: the zero quaternion does not represent a rotation")
    qn = q / nq[:, None]
    sQ = _pow2_rows(Q)
    Qs = Q / sQ[:, None]
    qQs = np.sum(qn * Qs, axis=1)
    nQs = np.sqrt(np.sum(Qs * Qs, axis=1))
    qQ = qQs * sQ
    big = nQs * sQ >= 1.0
    dq = np.abs(qQ)  # |q·Q| / max(|Q|, 1)
    dq[big] = np.abs(qQs[big]) / nQs[big]
    if np.any(dq > PROJECTION_TOL):
        i = int(np.argmax(dq > PROJECTION_TOL))
        raise AttitudeValueError(
            f"Q0: member {offset + i}: q0·Q0 = {qQ[i]:.3g} is not 0 (relative {dq[i]:.3g} > "
            f"{PROJECTION_TOL:g}); the momenta must be tangent to the unit sphere, e.g. "
            f"Q0 = 2 q0∘(0, g0) (attitude.canonical.momenta_from_body_angular_momentum)"
        )
    corr = float(max(np.max(dn, initial=0.0), np.max(dq, initial=0.0)))
    return qn, Q - qQ[:, None] * qn, corr


def _pow2_rows(x: np.ndarray) -> np.ndarray:
    """Per row, a power of two within a factor 2 of max|x| (an exact scale; 1 for 0 rows)."""
    m = np.max(np.abs(x), axis=1)
    e = np.frexp(m)[1]
    return np.where(m > 0.0, np.ldexp(1.0, e - 1), 1.0)


def _body_units(body: Any) -> str | None:
    """The unit system of the members' bodies (None: dimensionless), as ``_member_inertia``."""
    if isinstance(body, RigidBody):
        return body.units
    if isinstance(body, (list, tuple)) and body and isinstance(body[0], RigidBody):
        return body[0].units
    from astropy import units as u

    return "kg m^2" if isinstance(body, u.Quantity) else None


def _member_states(
    q0: Any, Q0: Any, units: str | None = None
) -> tuple[np.ndarray, np.ndarray, int]:
    """States (N, 4) or (4,) and N; Q0 may be a Quantity (kg m² s⁻¹) for bodies with units."""
    q = as_float_array(q0, "q0", trailing=4)
    # Q has units of angular momentum: a Quantity is accepted when the bodies have units (as in
    # propagate); converted to SI
    Q = as_float_array(Q0, "Q0", trailing=4, unit=None if units is None else "kg m2 / s")
    for name, a in (("q0", q), ("Q0", Q)):
        if a.ndim not in (1, 2):
            raise AttitudeValueError(
                f"{name}: expected shape (N, 4) (one row per member), got shape {a.shape}"
            )
    if q.ndim == 1 and Q.ndim == 1:
        raise AttitudeValueError(
            "q0, Q0: both have shape (4,), so the ensemble size N is unknown; give q0 or Q0 "
            "with shape (N, 4) (or use attitude.propagate for a single member)"
        )
    n = q.shape[0] if q.ndim == 2 else Q.shape[0]
    if q.ndim == 2 and Q.ndim == 2 and q.shape[0] != Q.shape[0]:
        raise AttitudeValueError(
            f"q0, Q0: q0 has {q.shape[0]} members (rows) but Q0 has {Q.shape[0]}; give one row "
            "per member in both (or a single (4,) row to share)"
        )
    if n == 0:
        raise AttitudeValueError(
            "q0, Q0: the ensemble is empty (N = 0 members); give at least one row"
        )
    return q, Q, n


def _member_inertia(body: Any, n: int) -> tuple[np.ndarray, str | None]:
    """Inertia (3,) shared or (N, 3) per member, and the unit label of the bodies."""
    arr, unit = inertia_rows(body, "body", "member")  # each row checked as a RigidBody
    if arr.ndim == 2 and arr.shape[0] != n:
        raise AttitudeValueError(
            f"body: {arr.shape[0]} rows of inertia for {n} members (the rows of q0/Q0); give "
            "one row per member, or a single body for all"
        )
    return arr, unit


def _member_potentials(potential: Any, n: int, inertia: np.ndarray):
    """(template Potential, params (P,) or (N, P), per-member potential list or None)."""
    if isinstance(potential, (list, tuple)):
        pots = list(potential)
        if len(pots) != n:
            raise AttitudeValueError(
                f"potential: {len(pots)} potentials for {n} members; give one per member or a "
                "single potential for all"
            )
        for i, p in enumerate(pots):
            if not isinstance(p, Potential):
                raise AttitudeTypeError(
                    f"potential[{i}]: expected an attitude.potentials.Potential, got "
                    f"{type(p).__name__}"
                )
            if p._user_terms():
                raise AttitudeTypeError(
                    f"potential[{i}]: per-member potentials must be built-in (TorqueFree, "
                    f"HeavyTop, GravityGradient, or sums of them); a {type(p).__name__} holds "
                    "compiled code, so give one for all members (its numbers can live in the "
                    "function)"
                )
            kinds = [t._kind for t in p.terms]
            if kinds != [t._kind for t in pots[0].terms]:
                raise AttitudeValueError(
                    f"potential[{i}]: all members need the same kind of potential; member 0 "
                    f"has {' + '.join(pots[0].term_names())}, member {i} has "
                    f"{' + '.join(p.term_names())}"
                )
        ref = inertia if inertia.ndim == 1 else inertia[0]
        rows = [p._params(ref) for p in pots]
        # Rows of different lengths (orbits of different types): padded, the kernels read a
        # block by its own type code and size.
        params = np.zeros((n, max(r.shape[0] for r in rows)))
        for i, r in enumerate(rows):
            params[i, : r.shape[0]] = r
        return pots[0], params, pots
    pot = as_potential(potential)
    if inertia.ndim == 1:
        pot = pot.bind(RigidBody(inertia))
    elif getattr(pot, "inertia", None) is not None:
        raise AttitudeValueError(
            "potential: this GravityGradient was built for one body (inertia=...), but the "
            "members have their own inertia; give GravityGradient(orbit) without inertia"
        )
    ref = inertia if inertia.ndim == 1 else inertia[0]
    return pot, pot._params(ref), None


def _ensemble_method(method: str, pot: Potential, pots: Any, events: Any) -> str:
    """The method of every member: ``"auto"`` is ``"taylor"`` if each member's potential picks
    it (:func:`attitude.propagate.choose_method`), else ``"dop853"``; ``"taylor"`` is checked:
    built-in potentials it expands, no events (as ``propagate``)."""
    from ..propagate import AUTO, choose_method
    from ..taylor import check_potential

    every = pots if pots is not None else (pot,)
    if method == AUTO:
        picks = {choose_method(AUTO, p, events=events) for p in every}
        return "taylor" if picks == {"taylor"} else "dop853"
    if method != "taylor":
        return method
    if events is not None:
        raise AttitudeValueError(
            "events: method='taylor' does not locate events (neither does "
            "propagate(method='taylor')); use method='dop853' for an ensemble with events"
        )
    for p in every:
        check_potential(p)
    return method
