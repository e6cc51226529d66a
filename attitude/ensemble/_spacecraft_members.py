"""Ensemble members with actuators: validated spacecraft, commands, software and sensor seeds.

A member of a spacecraft ensemble is what one ``propagate(spacecraft, q0, Q0, t, potential,
commands=..., software=...)`` runs: its spacecraft (shared, or one per member: dispersed
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
from ..body import RigidBody
from ..errors import AttitudeTypeError, AttitudeValueError
from ..spacecraft import Spacecraft

__all__ = ["CraftMembers", "member_seeds"]


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
        return body.has_actuators
    if isinstance(body, Sequence) and not isinstance(body, (str, bytes)) and body:
        return any(isinstance(b, Spacecraft) and b.has_actuators for b in body)
    return False


@dataclass
class _Structure:
    """What every member must share: the shape of the results (the wheel, magnetorquer,
    thruster, command and tick dimensions and their labels)."""

    counts: tuple[int, int, int]
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
        return _Structure(craft.counts, craft.units, tuple(map(tuple, craft.names())), soft)

    def differences(self, other: _Structure) -> str:
        if self.counts != other.counts:
            return f"actuators (wheels, magnetorquers, thrusters) {other.counts} != {self.counts}"
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
            y0[r] = _holds.initial_state(craft, qp, Qp)
            inertia[r] = craft.body.inertia
            row = pot._params(craft.body.inertia)
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
        prog = self.program
        if prog is None:
            scheds = [(run.hold_t, run.hold_u) for run in runs]
            hold_at = np.zeros(c + 1, dtype=np.int64)
            hold_at[1:] = np.cumsum([h[0].shape[0] for h in scheds])
            ncmd = runs[0].hold_u.shape[1]
            hold_t = np.ascontiguousarray(np.concatenate([h[0] for h in scheds]))
            hold_u = np.ascontiguousarray(
                np.concatenate([h[1] for h in scheds]).reshape(-1, ncmd), dtype=np.float64
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
            if id(p) not in fws:
                fws[id(p)] = (size, size + p.fw.shape[0])
                parts.append(p.fw)
                size += p.fw.shape[0]
            fw_at[r] = fws[id(p)]
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
