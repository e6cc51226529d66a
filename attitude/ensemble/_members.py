"""Ensemble members: validated inputs (states, bodies, potentials; spacecraft, commands,
software and sensor seeds), produced chunk by chunk for the compiled loops.

:class:`_Members` holds rigid-body members (rows of states, inertia and potential parameters).

:class:`CraftMembers` holds members with actuators or flight software. A member of a
spacecraft ensemble is what one ``propagate(spacecraft, q0, Q0, t, potential, commands=...,
software=...)`` runs: its spacecraft (shared, or one per member: dispersed
inertia, wheels, magnetorquers, thrusters), its initial state, and its command source (an
open-loop :class:`~attitude.CommandSchedule` or a :class:`~attitude.FlightSoftware`, shared or
one per member: dispersed gains, sensors). The single run's own preparation
(:func:`attitude._holds.prepare`: the spacecraft block, the schedule's arrays, the software's
program) is made once per distinct (spacecraft, commands, software) and shared by the members
that have them; :meth:`CraftMembers.block` lays a chunk's members out for the compiled loops
(:mod:`attitude._core.spacecraft_ensemble`).

Sensor seeds: member i's noisy sensors draw from the streams of
``SeedSequence(seed).spawn(N)[i].generate_state(n_sensors, uint64) >> 1`` (one seed per sensor,
in the order of the software's sensors; the ``>> 1`` keeps them in int64 for the results), so
the members' noise is independent, reproducible from the one ensemble ``seed``, and member i's
does not depend on N or the chunking. :func:`member_seeds` gives them; a member re-runs alone
with ``software.with_sensor_seeds(seeds)``.
"""

from __future__ import annotations

import secrets
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _holds, _interrupt
from .._core import fsw as _kf
from .._core import holds as _kh
from .._validation import as_float_array
from ..body import RigidBody, inertia_rows
from ..errors import AttitudeTypeError, AttitudeValueError
from ..potentials import Potential, as_potential
from ..spacecraft import Spacecraft

__all__ = ["CraftMembers", "initial_state_vars", "member_seeds"]

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

    def block(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(params (C, P), y0 (C, 8), inertia (C, 3), max projection) of members start:stop."""
        q = _rows(self.q, start, stop)
        Q = _rows(self.Q, start, stop)
        qp, Qp, corr = _project(q, Q, start)
        inertia = np.ascontiguousarray(_rows(self.inertia, start, stop))
        params = np.array(_rows(self.params, start, stop), dtype=np.float64, order="C")
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
        return initial_state_vars(_rows(self.q, start, stop), _rows(self.Q, start, stop))


def _rows(a: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Rows start:stop of per-member rows (N, k), or a shared row (k,) broadcast to them."""
    return a[start:stop] if a.ndim == 2 else np.broadcast_to(a, (stop - start, a.shape[-1]))


def check_states(q: np.ndarray, Q: np.ndarray, n: int) -> None:
    """Every member's initial state checked before any work (the exact projection of each
    chunk is made when it runs); the error names the first bad member."""
    for start in range(0, n, 65536):
        stop = min(n, start + 65536)
        _project(_rows(q, start, stop), _rows(Q, start, stop), start)


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


# ------------------------------------------------------------------------------------------------
# members with actuators or flight software
# ------------------------------------------------------------------------------------------------


#: Elements NaN-filled per call when the tick records are allocated (8 MB: milliseconds).
FILL_BLOCK = 1 << 20


def nan_records(c: int, n_rows: int, width: int) -> np.ndarray:
    """The members' tick records, shape (c, n_rows, width), NaN, filled in blocks of
    :data:`FILL_BLOCK` elements: one ``np.full`` of every tick of a long ensemble (GBs)
    was a C call of seconds in which Ctrl-C waited (2.3 s for 8 members × 3e5 ticks)."""
    rec = np.empty((c, n_rows, width))
    rows = max(1, FILL_BLOCK // max(1, width))
    for r in range(c):
        for i in range(0, n_rows, rows):
            rec[r, i : i + rows] = np.nan
        _interrupt.check()  # (a request whose KeyboardInterrupt was swallowed)
    return rec


def member_seeds(seed: int, members: np.ndarray, n_sensors: int) -> np.ndarray:
    """The sensor seeds (len(members), n_sensors) int64 of ``members`` of an ensemble with this
    ``seed``: ``SeedSequence(seed).spawn(N)[i].generate_state(n_sensors, uint64) >> 1``."""
    out = np.zeros((members.shape[0], n_sensors), dtype=np.int64)
    if n_sensors == 0:
        return out
    for r, i in enumerate(members):
        ss = np.random.SeedSequence(seed, spawn_key=(int(i),))
        out[r] = (ss.generate_state(n_sensors, np.uint64) >> np.uint64(1)).astype(np.int64)
    return out


def _one_or_list(x: Any, n: int | None, name: str, cls: type, what: str) -> Any:
    """``x`` as one object of ``cls`` (shared), a list of ``n`` of them, or None."""
    if x is None or isinstance(x, cls):
        return x
    if isinstance(x, (str, bytes)) or not isinstance(x, Sequence):
        raise AttitudeTypeError(
            f"{name}: expected {what} (shared by every member) or a sequence of one per member, "
            f"got {type(x).__name__}"
        )
    items = list(x)
    if n is not None and len(items) != n:
        raise AttitudeValueError(
            f"{name}: {len(items)} given for {n} members (the rows of q0/Q0); give one per "
            "member, or a single one for all"
        )
    for i, item in enumerate(items):
        if not isinstance(item, cls):
            raise AttitudeTypeError(f"{name}[{i}]: expected {what}, got {type(item).__name__}")
    return items


def as_crafts(body: Any, software: Any) -> Any:
    """The members' spacecraft: one Spacecraft or a list (a RigidBody, or a list of them, is a
    spacecraft without actuators: the flight software's torque is then an ideal one)."""
    if isinstance(body, RigidBody):
        return Spacecraft(body)
    if isinstance(body, Spacecraft):
        return body
    if isinstance(body, Sequence) and not isinstance(body, (str, bytes)) and body:
        items = list(body)
        if all(isinstance(b, (Spacecraft, RigidBody)) for b in items):
            return [b if isinstance(b, Spacecraft) else Spacecraft(b) for b in items]
    raise AttitudeTypeError(
        "bodies_or_body: with commands= or software= the members are attitude.Spacecraft (one "
        "for all, or a sequence of one per member), or RigidBody (an ideal control torque); "
        f"got {type(body).__name__}"
    )


def is_spacecraft_ensemble(body: Any, commands: Any, software: Any) -> bool:
    """Whether ``propagate_ensemble`` runs spacecraft with actuators or flight software."""
    if commands is not None or software is not None:
        return True
    if isinstance(body, Spacecraft):
        return body.has_actuators or body.coupled
    if isinstance(body, Sequence) and not isinstance(body, (str, bytes)) and body:
        return any(isinstance(b, Spacecraft) and (b.has_actuators or b.coupled) for b in body)
    return False


@dataclass
class _Structure:
    """What every member must share: the shape of the results (the wheel, magnetorquer,
    thruster, command and tick dimensions and their labels)."""

    counts: tuple[int, int, int]
    coupled: bool  # the orbit in the state (a spacecraft with a mass on a NumericalOrbit)
    units: str | None
    names: tuple
    software: tuple | None  # (period, phase, record_every, mode names, sensor kinds, estimator)

    @staticmethod
    def of(craft: Spacecraft, sw: Any) -> _Structure:
        soft = None
        if sw is not None:
            soft = (
                sw.period,
                sw.phase,
                sw.record_every,
                tuple(sw.mode_names),
                tuple(x.kind for x in (sw.sensors or ())),
                sw.estimator is not None,
            )
        return _Structure(craft.counts, craft.coupled, craft.units,
                          tuple(map(tuple, craft.names())), soft)  # fmt: skip

    def differences(self, other: _Structure) -> str:
        if self.counts != other.counts:
            return f"actuators (wheels, magnetorquers, thrusters) {other.counts} != {self.counts}"
        if self.coupled != other.coupled:
            return "orbit: carried in the state (a mass on a NumericalOrbit) in one, not the other"
        if self.units != other.units:
            a, b = other.units or "dimensionless", self.units or "dimensionless"
            return f"unit system {a} != {b}"
        if self.names != other.names:
            return "actuator names"
        if (self.software is None) != (other.software is None):
            return "flight software present in one, absent in the other"
        if self.software != other.software:
            a, b = self.software, other.software
            for label, x, y in zip(
                ("period", "phase", "record_every", "modes", "sensors", "estimator"), a, b,
                strict=True,
            ):  # fmt: skip
                if x != y:
                    return f"software {label} {y!r} != {x!r}"
        return ""


class CraftMembers:
    """Validated members with actuators; :meth:`block` lays out a chunk for compiled code.

    Parameters
    ----------
    crafts : Spacecraft or list of N Spacecraft
    q, Q : ndarray, shape (N, 4) or (4,)
        Validated initial states (not projected yet).
    n : int
    commands, software : one, a list of N, or None
    seed : int or None
        The ensemble seed of the sensors (drawn here when None and some sensor is noisy).
    span : ndarray, shape (2,)
        The run's first and last time.
    potential : Potential
        The prepared model shared by the members.
    method : str
    """

    def __init__(
        self, crafts, q, Q, n, commands, software, seed, span, potential, method, samples=None
    ):
        self.crafts = crafts
        self.samples = samples  # the stored times (where the default recording takes its ticks)
        self.q = q
        self.Q = Q
        self.n = n
        self.commands = commands
        self.software = software
        self.span = span
        self.potential = potential
        self.method = method
        self._runs: dict[tuple[int, int, int], Any] = {}
        self.extra_vars: Any = None  # (start, stop) -> {name: (dims, values, attrs)}, or None
        self.events: Any = None  # attitude.events.EventSet located in every member, or None
        first = None
        for i, (c, cmd, sw) in enumerate(self._distinct()):
            struct = _Structure.of(c, sw)
            if first is None:
                first = struct
            else:
                diff = first.differences(struct)
                if diff:
                    raise AttitudeValueError(
                        f"bodies_or_body: every member needs the same structure (the result's "
                        f"dimensions); member {i} differs from member 0 in its {diff}"
                    )
            self._prepare(c, cmd, sw)
        self.structure = first
        run0 = self.run(0)
        self.n_state = run0.n_state
        self.n_rec = run0.n_rec
        self.program = run0.program
        sensors = () if run0.program is None else run0.program.sensors
        self.sensor_kinds = tuple(x.kind for x in sensors)
        if sensors and seed is None:
            seed = secrets.randbits(63)
        self.seed = seed

    # -- the members' objects ---------------------------------------------------------------
    @staticmethod
    def _pick(x: Any, i: int) -> Any:
        return x[i] if isinstance(x, list) else x

    def member(self, i: int) -> tuple[Spacecraft, Any, Any]:
        """(spacecraft, commands, software) of member ``i`` (the software before reseeding)."""
        return (
            self._pick(self.crafts, i),
            self._pick(self.commands, i),
            self._pick(self.software, i),
        )

    def _distinct(self):
        """(spacecraft, commands, software) of every member, each combination once."""
        seen = set()
        for i in range(self.n):
            c, cmd, sw = self.member(i)
            key = (id(c), id(cmd), id(sw))
            if key not in seen:
                seen.add(key)
                yield c, cmd, sw
            if not any(isinstance(x, list) for x in (self.crafts, self.commands, self.software)):
                return

    def _prepare(self, craft: Spacecraft, commands: Any, software: Any) -> None:
        key = (id(craft), id(commands), id(software))
        if key in self._runs:
            return
        if software is not None and software.python_step is not None:
            raise AttitudeValueError(
                "software: your own Python step function runs between compiled calls of one "
                "run; an ensemble runs its members in parallel compiled code: write the law "
                "with attitude.control, or loop over attitude.propagate"
            )
        craft.check_orbit(getattr(self.potential, "orbit", None))
        if self.method == "taylor":
            _holds.check_taylor(craft, self.potential)
        q0 = np.array([1.0, 0.0, 0.0, 0.0])
        run, _ = _holds.prepare(
            craft, q0, np.zeros(4), self.span, commands, software, samples=self.samples
        )
        if craft.coupled:  # the environment tables follow the model's orbit's path
            from .._coupling import follow_path

            run.sc = follow_path(run.sc, getattr(self.potential, "orbit", None))
        self._runs[key] = run

    def run(self, i: int) -> Any:
        """The single run's preparation (``attitude._holds.SpacecraftRun``) of member ``i``."""
        c, cmd, sw = self.member(i)
        return self._runs[(id(c), id(cmd), id(sw))]

    def seeds(self, start: int, stop: int) -> np.ndarray:
        """Sensor seeds (stop − start, n_sensors) of members start..stop−1."""
        return member_seeds(self.seed or 0, np.arange(start, stop), len(self.sensor_kinds))

    def member_software(self, i: int) -> Any:
        """What member ``i``'s single run is given as ``software=`` (its sensors reseeded)."""
        sw = self._pick(self.software, i)
        if sw is None or not self.sensor_kinds:
            return sw
        return sw.with_sensor_seeds([int(s) for s in self.seeds(i, i + 1)[0]])

    # -- the ticks -------------------------------------------------------------------------------
    def tick_times(self) -> np.ndarray:
        """The times of the recorded ticks (shared by every member): t_k = T0 + k·period for
        T0 + k·period < t_end, those in effect at the stored samples or every
        ``record_every``-th (the compiled loop's own arithmetic)."""
        return np.zeros(0) if self.program is None else self.program.tick_times()

    # -- a chunk for the compiled loops ----------------------------------------------------------
    def block(self, start: int, stop: int) -> dict[str, Any]:
        """The arrays of members start..stop−1 (layout of
        :mod:`attitude._core.spacecraft_ensemble`), their runs and inputs."""
        from ..canonical import _project
        from ..sensors._models import stream_state

        c = stop - start
        pot = self.potential
        rows = lambda a: a[start:stop] if a.ndim == 2 else np.broadcast_to(a, (c, 4))  # noqa: E731
        q, Q = rows(self.q), rows(self.Q)
        runs = [self.run(i) for i in range(start, stop)]
        n = self.n_state
        y0 = np.empty((c, n))
        corr = 0.0
        inertia = np.empty((c, 3))
        params = None
        for r in range(c):
            qp, Qp, dc = _project(q[r], Q[r])
            corr = max(corr, dc)
            craft = runs[r].spacecraft
            state = _holds.initial_state(craft, qp, Qp)
            inertia[r] = craft.body.inertia
            row = pot._params(craft.body.inertia)
            if craft.coupled:  # the orbit in the state; the model's orbit copies made live
                from .._coupling import attach, initial_orbit_state, orbit_tokens

                state = np.concatenate([state, initial_orbit_state(craft, float(self.span[0]))])
                attach(row, runs[r].sc, craft, orbit_tokens(craft, pot))
            y0[r] = state
            if params is None:
                params = np.zeros((c, row.shape[0]))
            params[r] = row
        # the spacecraft blocks, one after the other (each member writes its own)
        blocks = [run.sc for run in runs]
        sc_at = np.zeros(c + 1, dtype=np.int64)
        sc_at[1:] = np.cumsum([b.shape[0] for b in blocks])
        sc0 = np.ascontiguousarray(np.concatenate(blocks))
        out: dict[str, Any] = {
            "runs": runs,
            "params": np.ascontiguousarray(params),
            "sc0": sc0,
            "sc_at": sc_at,
            "y0": y0,
            "inertia": inertia,
            "q": np.array(q, dtype=np.float64),
            "Q": np.array(Q, dtype=np.float64),
            "projection": corr,
            "potential": pot,
        }
        hs = np.zeros((c, _kh.HS.SIZE))
        hs[:, _kh.HS.SAMPLES_ONLY] = 1.0  # rows on the shared samples only
        prog = self.program
        if prog is None:
            scheds = [(run.hold_t, run.hold_u) for run in runs]
            hold_at = np.zeros(c + 1, dtype=np.int64)
            hold_at[1:] = np.cumsum([h[0].shape[0] for h in scheds])
            ncmd = runs[0].hold_u.shape[1]
            hold_t = np.ascontiguousarray(np.concatenate([h[0] for h in scheds]))
            hold_u = np.ascontiguousarray(
                np.concatenate([h[1] for h in scheds]).reshape(hold_t.shape[0], ncmd),
                dtype=np.float64,
            )
            out["src"] = (hs, hold_t, hold_u, hold_at, np.zeros(ncmd))
            return out
        # flight software: programs shared, states (and the sensors' streams) per member
        fws: dict[int, tuple[int, int]] = {}
        parts = []
        size = 0
        fw_at = np.zeros((c, 2), dtype=np.int64)
        states = []
        seeds = self.seeds(start, stop)
        for r, run in enumerate(runs):
            p = run.program
            # a member carrying its orbit writes it into its program's live copies: its own
            key = (id(p), r if run.coupled else -1)
            if key not in fws:
                fws[key] = (size, size + p.fw.shape[0])
                parts.append(p.fw)
                size += p.fw.shape[0]
            fw_at[r] = fws[key]
            fs = p.fresh_state()
            if p.sensors:
                ss = np.concatenate(
                    [stream_state(x.with_seed(int(s))) for x, s in zip(p.sensors, seeds[r],
                                                                       strict=True)]
                )  # fmt: skip
                at = int(p.fw[_kf.FW.SS])
                fs[at : at + ss.size] = ss
            states.append(fs)
        fs_at = np.zeros(c + 1, dtype=np.int64)
        fs_at[1:] = np.cumsum([s.shape[0] for s in states])
        n_rows = self.tick_times().shape[0] + 1  # one spare row (unrecorded ticks write nothing)
        rec = nan_records(c, n_rows, prog.rec_width)
        out["src"] = (
            hs,
            np.ascontiguousarray(np.concatenate(parts)),
            fw_at,
            np.ascontiguousarray(np.concatenate(states)),
            fs_at,
            np.zeros((c, max(prog.n_cmd, 3))),
            rec,
            np.zeros((c, 1), dtype=np.int64),
        )
        out["seeds"] = seeds
        return out
