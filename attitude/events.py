"""Events: the moments a run should record, or stop at.

An event is a scalar function g(t, q, ω) of the time, the attitude (body → space) and the body
angular velocity; it **occurs** where g changes sign along the run. Pass events to
:func:`attitude.propagate` (``events=[...]``), :func:`attitude.propagate_ensemble` or a
scenario's ``[events]`` table:

=====================================  ======================================================
``PointingExceeds(frame, axis, angle)``  pointing error of body ``axis`` from the same axis of a
                                       reference frame (:mod:`attitude.frames`) exceeds
                                       ``angle`` (``axis=None``: the total attitude error
                                       angle of q̃_R∘q); g = error − angle
``RateExceeds(rate)``                  |ω| exceeds ``rate``; g = |ω| − rate
``EclipseEntry(orbit)``                the spacecraft enters Earth's shadow (penumbra by
                                       default, ``shadow="umbra"``); conical shadow of
                                       :mod:`orbit.sun`, g = c − (a + b) (falling)
``EclipseExit(orbit)``                 it leaves it (the same g, rising)
``AngleToSun(axis, angle)``            the angle between body ``axis`` and the Sun crosses
                                       ``angle``; g = angle(axis, Sun) − angle
``Custom(g)`` or a plain function      your g(t, q, omega) (numba-compilable, like a
                                       ``CustomTorque``; compiled into the user cache)
=====================================  ======================================================

Each has a ``direction`` (``"rising"``: g goes from negative to positive along the run,
``"falling"``, ``"both"``), a ``terminal`` flag (the run ends at the first occurrence, cleanly:
status ``"event"``, the state at the event is the last sample) and a ``name`` (its label in
results). Angles and rates accept astropy Quantities (``5 * u.deg``, ``0.1 * u.deg / u.s``).

How events are found (docs/events.md): after every accepted step, g is sampled at the step's
end and at ``samples − 1`` points inside it on the integrator's dense output (DOP853's
7th-order interpolant), and every sign change is refined by Brent's method on that
interpolant to 4 ulp(t) + 1e-12 s. The event time is then as accurate as the interpolant:
|δt| ≈ |δg| / |ġ| with δg the interpolant's error in g (of the order of the integration
tolerance). Two sign changes closer than a sample spacing inside one step can be missed (raise
``samples`` or lower ``max_step``). For the fixed-step methods (``nosquish``, ``splitting``) g is
sampled at the end of every step and the state at a trial time is one step of the method from
the step's start.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from orbit._layout import Appender

from ._core import events as _ke
from ._user_kernels import compile_failure
from ._validation import as_scalar
from .errors import AttitudeTypeError, AttitudeValueError
from .frames import Frame, as_axis

__all__ = [
    "AngleToSun",
    "Custom",
    "EclipseEntry",
    "EclipseExit",
    "Event",
    "EventSet",
    "PointingExceeds",
    "RateExceeds",
    "build",
]

#: Default number of sub-intervals of each step where g is sampled.
SAMPLES = 8

_DIRECTIONS = {"rising": _ke.RISING, "falling": _ke.FALLING, "both": _ke.BOTH}
_SHADOWS = ("penumbra", "umbra")


def _direction(direction: Any) -> str:
    if not isinstance(direction, str) or direction not in _DIRECTIONS:
        raise AttitudeValueError(
            f"direction: expected 'rising', 'falling' or 'both', got {direction!r}"
        )
    return direction


def _angle(x: Any, name: str) -> float:
    v = as_scalar(x, name, unit="rad")
    if not 0.0 < v < math.pi:
        raise AttitudeValueError(
            f"{name}: expected an angle between 0 and 180 degrees (rad, or a Quantity such as "
            f"5 * u.deg), got {v!r} rad"
        )
    return v


class Event:
    """Base class of the events (see the module docstring)."""

    kind: str = "event"
    _code: int = -1

    def __init__(
        self,
        direction: str = "both",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        self.direction = _direction(direction)
        if not isinstance(terminal, (bool, np.bool_)):
            raise AttitudeTypeError(f"terminal: expected True or False, got {terminal!r}")
        self.terminal = bool(terminal)
        if name is not None and (not isinstance(name, str) or not name.isidentifier()):
            raise AttitudeValueError(
                f"name: expected a short identifier such as 'pointing_5deg', got {name!r}"
            )
        self.name = name or self.kind
        if (
            isinstance(samples, bool)
            or not isinstance(samples, (int, np.integer))
            or not 1 <= samples <= 1000
        ):
            raise AttitudeValueError(
                f"samples: expected an integer from 1 to 1000 (points per step), got {samples!r}"
            )
        self.samples = int(samples)

    # -- what a run needs -----------------------------------------------------------------------
    @property
    def orbits(self) -> list[Any]:
        """Orbits the event reads (their epochs must be the run's)."""
        return []

    @property
    def needs_epoch(self) -> bool:
        return False

    def check_times(self, t: np.ndarray) -> None:
        for o in self.orbits:
            if hasattr(o, "check_times"):
                try:
                    o.check_times(t, "t")
                except ValueError as exc:
                    raise AttitudeValueError(f"events: {self.name}: {exc}") from None

    def _numbers(self, ctx: _Context, at: int) -> tuple[list[float], list[np.ndarray]]:
        """(the block's numbers after kind/direction/terminal, trailing data arrays)."""
        raise NotImplementedError  # pragma: no cover

    def describe(self) -> str:
        extra = ", terminal" if self.terminal else ""
        return f"{self.name}: {self._describe()} ({self.direction}{extra})"

    def _describe(self) -> str:
        return self.kind

    def _passes(self) -> str:
        """How g's quantity passes its threshold in this event's direction."""
        return {"rising": ">", "falling": "<"}.get(self.direction, "crosses")

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.describe()}>"


class Custom(Event):
    """A user event function ``g(t, q, omega) -> float``.

    ``q`` is the attitude (length-4 array, body → space), ``omega`` the body angular velocity
    (length-3 array, body axes). Numba-compilable (a plain function is jitted for you); it is
    compiled into the user cache with the run's other user code
    (:mod:`attitude._user_kernels`), never into the package's cache.
    """

    kind = "custom"
    _code = _ke.KIND_USER

    def __init__(
        self,
        g: Callable,
        *,
        direction: str = "both",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        from .potentials import _arity, _compile_user

        _arity(g, "g", (3,), "g(t, q, omega)")
        fn = _compile_user(g, "g")
        fname = getattr(getattr(fn, "py_func", fn), "__name__", "custom")
        if name is None and not fname.isidentifier():
            fname = "custom"
        super().__init__(direction, terminal, name or fname, samples)
        try:
            v = float(fn(0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3)))
        except Exception as exc:
            raise AttitudeTypeError(
                f"g: must be a numba-compilable function g(t, q, omega) returning a number; "
                f"calling it failed: {compile_failure(exc)}"
            ) from None
        if math.isnan(v):
            raise AttitudeValueError("g: returned NaN at t = 0, q = identity, omega = 0")
        self.function = fn

    def _describe(self) -> str:
        return f"custom g(t, q, omega) {getattr(self.function, '__name__', '')}".rstrip()

    def _numbers(self, ctx, at):
        k = ctx.user.index(self.function) if self.function in ctx.user else len(ctx.user)
        if k == len(ctx.user):
            ctx.user.append(self.function)
        return [float(k)], []


class PointingExceeds(Event):
    """The pointing error from a reference frame exceeds ``angle``.

    Parameters
    ----------
    frame : attitude.frames.Frame
        The reference attitude (``frames.lvlh(orbit)``, ``frames.target(...)``, ...).
    axis : str, array_like (3,) or None
        Body axis whose direction is compared with the frame's same axis (the angle between
        q∘a∘q̃ and q_R∘a∘q̃_R); None: the total rotation angle of the error q̃_R∘q.
    angle : float or Quantity
        Threshold [rad, or an angle Quantity].
    direction : str
        Default ``"rising"`` (the error grows past the threshold).
    """

    kind = "pointing_exceeds"
    _code = _ke.KIND_POINTING

    def __init__(
        self,
        frame: Frame,
        axis: Any,
        angle: Any,
        *,
        direction: str = "rising",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        super().__init__(direction, terminal, name, samples)
        if not isinstance(frame, Frame):
            raise AttitudeTypeError(
                f"frame: expected a reference frame from attitude.frames (lvlh(orbit), ...), "
                f"got {type(frame).__name__}"
            )
        self.frame = frame
        self.axis = None if axis is None else as_axis(axis, "axis")
        self.angle = _angle(angle, "angle")

    @property
    def orbits(self):
        return [self.frame.orbit] if self.frame.orbit is not None else []

    @property
    def needs_epoch(self) -> bool:
        return self.frame.needs_epoch

    def _describe(self) -> str:
        ax = "attitude" if self.axis is None else f"axis {np.round(self.axis, 12).tolist()}"
        return (
            f"{ax} error from {self.frame.describe()} {self._passes()} "
            f"{math.degrees(self.angle):.6g} deg"
        )

    def _numbers(self, ctx, at):
        frame_at = at + 6
        mode = 1.0 if self.axis is None else 0.0
        ax = np.zeros(3) if self.axis is None else self.axis
        d = self.frame.kernel_data(ctx.t_min, ctx.t_max)
        return [self.angle, mode, *ax, float(frame_at)], [d]


class RateExceeds(Event):
    """|ω| exceeds ``rate`` (rad per time unit of the body, or a Quantity such as deg/s)."""

    kind = "rate_exceeds"
    _code = _ke.KIND_RATE

    def __init__(
        self,
        rate: Any,
        *,
        direction: str = "rising",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        super().__init__(direction, terminal, name, samples)
        r = as_scalar(rate, "rate", unit="rad / s")
        if not r > 0:
            raise AttitudeValueError(f"rate: must be positive, got {r!r}")
        self.rate = r

    def _describe(self) -> str:
        return f"|omega| {self._passes()} {self.rate:.6g} rad/s"

    def _numbers(self, ctx, at):
        return [self.rate], []


class _Eclipse(Event):
    _sign = 0

    def __init__(
        self,
        orbit: Any,
        *,
        shadow: str = "penumbra",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        super().__init__("falling" if self._sign < 0 else "rising", terminal, name, samples)
        if not hasattr(orbit, "kernel_data"):
            raise AttitudeTypeError(
                f"orbit: expected an orbit (orbit.KeplerOrbit, ...), got {type(orbit).__name__}"
            )
        if getattr(orbit, "epoch", None) is None:
            raise AttitudeValueError(
                f"orbit: {self.kind} needs the Sun's position, so a date: build the orbit with an "
                "epoch (e.g. orbit.KeplerOrbit(..., epoch='2024-03-20T12:00:00'))"
            )
        if not isinstance(shadow, str) or shadow not in _SHADOWS:
            raise AttitudeValueError(f"shadow: expected 'penumbra' or 'umbra', got {shadow!r}")
        self.orbit = orbit
        self.shadow = shadow

    @property
    def orbits(self):
        return [self.orbit]

    @property
    def needs_epoch(self) -> bool:
        return True

    def _describe(self) -> str:
        return f"{self.shadow} boundary (conical shadow) on {self.orbit.describe()}"

    def _numbers(self, ctx, at):
        from orbit.sun import R_EARTH, R_SUN

        od = np.asarray(self.orbit.kernel_data(), dtype=np.float64)
        sd = ctx.sun_table(self.orbit.epoch)
        orbit_at = at + 5
        return (
            [1.0 if self.shadow == "umbra" else 0.0, R_EARTH, R_SUN, orbit_at, orbit_at + od.size],
            [od, sd],
        )


class EclipseEntry(_Eclipse):
    """The spacecraft enters Earth's shadow (penumbra, or ``shadow="umbra"``)."""

    kind = "eclipse_entry"
    _code = _ke.KIND_ECLIPSE
    _sign = -1


class EclipseExit(_Eclipse):
    """The spacecraft leaves Earth's shadow (penumbra, or ``shadow="umbra"``)."""

    kind = "eclipse_exit"
    _code = _ke.KIND_ECLIPSE
    _sign = 1


class AngleToSun(Event):
    """The angle between body ``axis`` and the Sun direction crosses ``angle``.

    The Sun is seen from the spacecraft when ``orbit`` is given, else from the geocentre (a
    parallax below 5e-5 rad in low orbits); either way the run needs an epoch.
    """

    kind = "angle_to_sun"
    _code = _ke.KIND_SUN_ANGLE

    def __init__(
        self,
        axis: Any,
        angle: Any,
        *,
        orbit: Any = None,
        direction: str = "both",
        terminal: bool = False,
        name: str | None = None,
        samples: int = SAMPLES,
    ):
        super().__init__(direction, terminal, name, samples)
        self.axis = as_axis(axis, "axis")
        self.angle = _angle(angle, "angle")
        if orbit is not None and not hasattr(orbit, "kernel_data"):
            raise AttitudeTypeError(f"orbit: expected an orbit, got {type(orbit).__name__}")
        if orbit is not None and getattr(orbit, "epoch", None) is None:
            raise AttitudeValueError(
                "orbit: AngleToSun sees the Sun from the orbit, at the orbit's dates, so the "
                "orbit needs an epoch (build it with epoch='2024-03-20T12:00:00'), or leave "
                "orbit out (the Sun seen from the geocentre at the run's epoch)"
            )
        self.orbit = orbit

    @property
    def orbits(self):
        return [self.orbit] if self.orbit is not None else []

    @property
    def needs_epoch(self) -> bool:
        return True

    def _describe(self) -> str:
        where = "spacecraft" if self.orbit is not None else "geocentre"
        return (
            f"angle(axis {np.round(self.axis, 12).tolist()}, Sun from the {where}) = "
            f"{math.degrees(self.angle):.6g} deg"
        )

    def _numbers(self, ctx, at):
        arrays = []
        orbit_at = 0.0
        nxt = at + 6
        if self.orbit is not None:
            od = np.asarray(self.orbit.kernel_data(), dtype=np.float64)
            arrays.append(od)
            orbit_at = float(nxt)
            nxt += od.size
        ep = self.orbit.epoch if self.orbit is not None else ctx.epoch
        arrays.append(ctx.sun_table(ep))
        return [self.angle, *self.axis, orbit_at, float(nxt)], arrays


# ---------------------------------------------------------------------------------------------
# the events of one run
# ---------------------------------------------------------------------------------------------


@dataclass
class _Context:
    t_min: float
    t_max: float
    epoch: Any
    user: list = field(default_factory=list)
    _suns: dict = field(default_factory=dict)

    def sun_table(self, epoch: Any) -> np.ndarray:
        from orbit.sun import SunTable

        key = (float(epoch.tai.jd1), float(epoch.tai.jd2))
        if key not in self._suns:
            self._suns[key] = SunTable(epoch, self.t_min, self.t_max).kernel_data()
        return self._suns[key]


@dataclass
class EventSet:
    """The validated events of one run, as compiled-kernel data."""

    events: tuple[Event, ...]
    labels: list[str]
    data: np.ndarray  # evd (attitude._core.events layout)
    user_functions: tuple  # the compiled user g functions, in the order of their numbers
    epoch: Any  # the time origin the events need (astropy Time) or None

    @property
    def n(self) -> int:
        return len(self.events)

    @property
    def terminal(self) -> bool:
        return any(e.terminal for e in self.events)

    def describe(self) -> str:
        """One line: ``0: <event> | 1: <event> | ...`` (for attrs and ``attitude info``)."""
        return " | ".join(f"{i}: {e.describe()}" for i, e in enumerate(self.events))


def _as_events(events: Any) -> list[Event]:
    if isinstance(events, (Event, Callable)) and not isinstance(events, (list, tuple)):
        events = [events]
    if not isinstance(events, Sequence) or isinstance(events, str):
        raise AttitudeTypeError(
            f"events: expected a list of events (attitude.events.PointingExceeds(...), ..., "
            f"or functions g(t, q, omega)), got {type(events).__name__}"
        )
    out: list[Event] = []
    for i, e in enumerate(events):
        if isinstance(e, Event):
            out.append(e)
        elif callable(e):
            out.append(Custom(e))
        else:
            raise AttitudeTypeError(
                f"events[{i}]: expected an attitude.events event or a function g(t, q, omega), "
                f"got {type(e).__name__}"
            )
    if not out:
        raise AttitudeValueError("events: the list is empty; give at least one event or None")
    return out


def build(events: Any, t: np.ndarray, epoch: Any = None) -> EventSet:
    """Validate ``events`` for a run over the times ``t`` with time origin ``epoch``.

    Parameters
    ----------
    events : list of Event or callables
    t : ndarray, shape (m,)
        The run's output times [s since the epoch].
    epoch : astropy Time, optional
        The run's epoch; the events' orbits must have the same one.

    Returns
    -------
    EventSet
    """
    from orbit.timescales import format_epoch, same_epoch

    evs = _as_events(events)
    run_epoch = epoch
    for e in evs:
        for o in e.orbits:
            oe = getattr(o, "epoch", None)
            if oe is None:
                continue
            if run_epoch is None:
                run_epoch = oe
            elif not same_epoch(oe, run_epoch):
                raise AttitudeValueError(
                    f"events: {e.name} reads an orbit with epoch {format_epoch(oe)}, but the run's "
                    f"time origin is {format_epoch(run_epoch)}; one run has one time origin"
                )
    for e in evs:
        if e.needs_epoch and run_epoch is None:
            raise AttitudeValueError(
                f"events: {e.name} needs the Sun's position, so a date: give propagate(..., "
                "epoch='2024-03-20T12:00:00') or an orbit with an epoch"
            )
        e.check_times(t)
    t_min, t_max = float(np.min(t)), float(np.max(t))
    ctx = _Context(t_min, t_max, run_epoch)
    n = len(evs)
    out = Appender(np.zeros(_ke.EV.SIZE + n))  # the header, then an offset per event
    offsets = []
    for e in evs:
        numbers, arrays = e._numbers(ctx, out.size + _ke.EVB.DATA)
        block = _ke.EVB.pack(kind=e._code, direction=_DIRECTIONS[e.direction], terminal=e.terminal)
        numbers = np.asarray(numbers, dtype=np.float64)
        offsets.append(out.append(np.concatenate([block, numbers, *arrays])))
    data = _ke.EV.pack_into(out.array(), 0, n=n, nsub=max(e.samples for e in evs))
    data[_ke.EV.OFFSETS : _ke.EV.OFFSETS + n] = offsets
    labels: list[str] = []
    for e in evs:
        name, k = e.name, 2
        while name in labels:
            name, k = f"{e.name}_{k}", k + 1
        labels.append(name)
    return EventSet(tuple(evs), labels, data, tuple(ctx.user), run_epoch)
