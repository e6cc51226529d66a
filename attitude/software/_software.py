"""The flight software: :class:`FlightSoftware` and its :class:`Mode` s, and the program the
compiled loop runs (:func:`program`, the layout of :mod:`attitude._core.fsw`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, NamedTuple

import numpy as np

from orbit._layout import Appender

from .._core import fsw as _kf
from .._core import fsw_step as _kstep
from .._core import sensors as _ks
from .._core.fsw_layout import ES, FW, MB
from .._validation import as_float_array, as_int, as_scalar, refuse_class
from ..body import RigidBody
from ..control import ControlLaw, MomentumDumping, WheelAllocation
from ..errors import AttitudeTypeError, AttitudeValueError
from ._guidance import Slew, as_guidance
from ._modes import Condition, as_condition

__all__ = ["FlightSoftware", "MeasurementIndex", "Measurements", "Mode", "Program", "program"]


def _period(x: Any) -> float:
    """Seconds from a number (s), a time Quantity or a frequency Quantity (Hz)."""
    from astropy import units as u

    if isinstance(x, u.Quantity):
        if x.unit.is_equivalent(u.Hz):
            f = float(x.to_value(u.Hz))
            if not f > 0 or not math.isfinite(f):
                raise AttitudeValueError(f"period: a rate must be positive, got {x}")
            return 1.0 / f
        try:
            x = x.to_value(u.s)
        except u.UnitConversionError:
            raise AttitudeTypeError(
                f"period: expected seconds or a rate in Hz, got units {x.unit}"
            ) from None
    v = as_scalar(x, "period")
    if not v > 0 or not math.isfinite(v):
        raise AttitudeValueError(f"period: the tick interval must be positive, got {v!r} s")
    return v


#: The largest ``record_every`` (tick indices are exact in the program's float64 words).
MAX_RECORD_EVERY = 2**53


def _record_every(x: Any, period: float) -> int | None:
    """None (the ticks in effect at the output samples), or record every k-th tick: from an
    integer k or a time interval (a Quantity in s, a whole multiple of the period)."""
    from astropy import units as u

    if x is None or (isinstance(x, str) and x.strip().lower() == "samples"):
        return None
    hint = (
        "give None or 'samples' (the ticks in effect at the output samples, the default), an "
        "integer k (every k-th tick; 1: every tick) or an interval such as 60 * u.s"
    )
    if isinstance(x, str):
        raise AttitudeValueError(f"record_every: {x!r} is not a recording choice; {hint}")
    if isinstance(x, u.Quantity):
        try:
            s = float(x.to_value(u.s))
        except (u.UnitConversionError, TypeError, ValueError):
            raise AttitudeTypeError(f"record_every: expected a time, got {x}; {hint}") from None
        k = s / period
        if not (math.isfinite(k) and k >= 0.5):
            raise AttitudeValueError(
                f"record_every: {x} is shorter than the period ({period:g} s) or not finite"
            )
        kr = round(k)
        if abs(k - kr) > 1e-9 * k:
            raise AttitudeValueError(
                f"record_every: {x} is not a whole number of periods ({period:g} s): give "
                f"{kr * period:g} s or {kr} (ticks)"
            )
        x = kr
    k = as_int(x, "record_every")
    if k > MAX_RECORD_EVERY:
        raise AttitudeValueError(
            f"record_every: {k} ticks is beyond {MAX_RECORD_EVERY} (2^53): no run has that many "
            "ticks; give None to record at the output samples"
        )
    return k


def tick_count(t0: float, period: float, t_end: float) -> int:
    """The number of ticks of a run: t_k = t0 + k·period < t_end, k = 0, 1, ... (the compiled
    loop's own arithmetic, :func:`attitude._core.fsw.fsw_boundary`)."""
    if not t0 < t_end:
        return 0
    k = max(1, math.ceil((t_end - t0) / period))
    while k > 1 and t0 + (k - 1) * period >= t_end:
        k -= 1
    while t0 + k * period < t_end:
        k += 1
    return k


def ticks_at(t0: float, period: float, n_ticks: int, t: Any, block: int = 1 << 20) -> np.ndarray:
    """Indices (increasing, int64) of the ticks in effect at the times ``t`` (increasing): for
    each, the last tick t_k <= t of the run's ``n_ticks``; times before the first tick have
    none."""
    out = []
    last = -1
    for i in range(0, len(t), block):
        ts = np.asarray(t[i : i + block], dtype=np.float64)
        k = np.floor((ts - t0) / period)
        k = np.clip(np.nan_to_num(k, nan=-1.0), -1.0, float(n_ticks - 1)).astype(np.int64)
        k = np.where(t0 + k * period > ts, k - 1, k)  # the floor's round-off, both ways
        k = np.where((k + 1 < n_ticks) & (t0 + (k + 1) * period <= ts), k + 1, k)
        k = np.unique(k[k > last])
        if k.size:
            out.append(k)
            last = int(k[-1])
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _is_compiled(fn: Any) -> bool:
    """Whether ``fn`` is a numba-compiled function (``numba.njit``): your compiled step."""
    if not hasattr(fn, "py_func"):
        return False
    from numba.core.registry import CPUDispatcher

    return isinstance(fn, CPUDispatcher)


def _builtin_law(law: ControlLaw) -> ControlLaw:
    """``law`` if it is one of the built-in laws the compiled loop has a kernel for; a
    subclass of one (its own code would never run) or of ControlLaw (it has no kernel: it
    compiled to zero torque) is refused, naming what works."""
    builtin = [c for c in type(law).__mro__ if c.__module__ == ControlLaw.__module__]
    if type(law) is not builtin[0] or law._kind == 0:
        raise AttitudeTypeError(
            f"control: {type(law).__name__} subclasses {builtin[0].__name__}; the compiled loop "
            "runs the built-in laws' kernels only (MRPFeedback, QuaternionFeedback, "
            "RateDamping, BDot), so a subclass's own code would never run: give a built-in "
            "law, or write yours as a function step(t, measurements) -> commands (Python, or "
            "numba.njit to compile it into the loop; docs/flight_software.md, 'Your own "
            "software')"
        )
    return law


def _control(x: Any) -> tuple[Any, MomentumDumping | None, Callable | None]:
    """(law, dumping, Python step) from a law, (law, MomentumDumping), a callable or None."""
    if x is None:
        return None, None, None
    refuse_class(x, "control")  # a class is callable: it would pass for your own step
    if isinstance(x, ControlLaw):
        return _builtin_law(x), None, None
    if isinstance(x, MomentumDumping):
        return None, x, None
    if isinstance(x, (tuple, list)):
        for c in x:
            refuse_class(c, "control")
        laws = [c for c in x if isinstance(c, ControlLaw)]
        dumps = [c for c in x if isinstance(c, MomentumDumping)]
        if len(laws) + len(dumps) != len(x) or len(laws) > 1 or len(dumps) > 1:
            raise AttitudeTypeError(
                "control: a sequence combines one control law with one MomentumDumping"
            )
        return (_builtin_law(laws[0]) if laws else None), (dumps[0] if dumps else None), None
    if callable(x):
        return None, None, x
    raise AttitudeTypeError(
        f"control: expected a law of attitude.control (MRPFeedback, QuaternionFeedback, "
        f"RateDamping, BDot), a MomentumDumping beside one, your own step(t, measurements) "
        f"function, or None; got {type(x).__name__}"
    )


@dataclass(frozen=True)
class Mode:
    """One mode of the flight software: its guidance, control law and allocation.

    Parameters
    ----------
    guidance : Frame or Slew, optional
        The reference attitude (none: the inertial identity, zero rate; what rate damping and
        B-dot need).
    control : ControlLaw, (ControlLaw, MomentumDumping), callable or None
        The law; a Python callable ``step(t, measurements) -> commands`` is your own software
        (docs/flight_software.md).
    allocation : WheelAllocation, optional
        How a torque request is spread over the wheels (default: the pseudo-inverse).
    name : str, optional
        Label in results (default ``mode<k>``).
    """

    guidance: Any = None
    control: Any = None
    allocation: Any = None
    name: str | None = None

    def __post_init__(self):
        object.__setattr__(self, "guidance", as_guidance(self.guidance))
        _control(self.control)
        refuse_class(self.allocation, "allocation")
        if self.allocation is not None and not isinstance(self.allocation, WheelAllocation):
            raise AttitudeTypeError(
                f"allocation: expected an attitude.control.WheelAllocation, got "
                f"{type(self.allocation).__name__}"
            )
        if self.name is not None and (not isinstance(self.name, str) or not self.name):
            raise AttitudeTypeError("name: expected a non-empty string")


class Measurements(NamedTuple):
    """What your own software sees at a tick (the truth until sensors are given).

    Body axes; SI (rad/s, T, km and km/s for the orbit). ``field``, ``sun``, ``r``, ``v`` are
    None when the spacecraft has no orbit (``sun`` also without an epoch).
    """

    t: float
    q: np.ndarray  # (4,) attitude, body to space
    omega: np.ndarray  # (3,) body rate, rad/s
    q_ref: np.ndarray  # (4,) the guidance's reference attitude
    omega_ref: np.ndarray  # (3,) the reference rate in body axes
    sigma_error: np.ndarray  # (3,) attitude error σ_BR (MRP)
    omega_error: np.ndarray  # (3,) rate error ω − ω_r
    wheel_speeds: np.ndarray  # (n_w,) relative to the body, rad/s
    wheel_momenta: np.ndarray  # (n_w,) axial momenta h, N m s
    field: np.ndarray | None  # (3,) geomagnetic field, T
    sun: np.ndarray | None  # (3,) unit vector to the Sun
    r: np.ndarray | None  # (3,) position, km, space axes (GCRS)
    v: np.ndarray | None  # (3,) velocity, km/s, space axes


class MeasurementIndex(IntEnum):
    """Where each measurement sits in the array ``m`` of your compiled ``step(t, m)``.

    ``m[MeasurementIndex.Q : MeasurementIndex.Q + 4]`` is the attitude, and so on (the fields of
    :class:`Measurements`; vectors of 3 unless noted); the n_w wheel speeds start at
    ``WHEEL_SPEEDS``, the n_w wheel momenta at ``WHEEL_SPEEDS + n_w``. NaN where unavailable (no
    orbit: field, Sun, r, v). numba reads the members as constants.
    """

    T = _kstep.MEAS.T
    Q = _kstep.MEAS.Q  # 4
    OMEGA = _kstep.MEAS.OMEGA
    Q_REF = _kstep.MEAS.Q_REF  # 4
    OMEGA_REF = _kstep.MEAS.OMEGA_REF
    SIGMA_ERROR = _kstep.MEAS.SIGMA_ERROR
    OMEGA_ERROR = _kstep.MEAS.OMEGA_ERROR
    FIELD = _kstep.MEAS.FIELD
    SUN = _kstep.MEAS.SUN
    R = _kstep.MEAS.R
    V = _kstep.MEAS.V
    WHEEL_SPEEDS = _kstep.MEAS.WHEEL_SPEEDS


class FlightSoftware:
    """Flight software running at its own task rate inside the propagation.

    At each tick t_k = t₀ + phase + k·period the software reads its measurements (the true
    state; noisy sensors and an estimator plug in here), the guidance gives the reference
    attitude, rate and acceleration, the control law a torque (or dipole) request, the
    allocation the actuator commands (clipped by the actuators' limits), and those are held
    until the next tick (zero-order hold); with ``delay = d`` the command computed at t_k acts
    from t_{k+d}. The integrator restarts at every tick, so the dynamics between ticks keep
    the method's accuracy. By default the semantics are those of Basilisk's reaction-wheel
    scenario: u_k computed from the state at t_k acts on [t_k, t_{k+1}).

    Parameters
    ----------
    period : float or Quantity
        The tick interval (s), or a rate (Hz).
    guidance : Frame or Slew, optional
        Reference attitude of the (single) mode.
    control : law, (law, MomentumDumping), callable or None
        Control law of the (single) mode (:mod:`attitude.control`), or your own Python
        ``step(t, measurements) -> commands`` (:class:`Measurements`; commands: the raw
        actuator commands (n_wheels + n_magnetorquers + n_thrusters), or a dict with
        ``wheel_torque``, ``dipole``, ``thrust``, or for a spacecraft without actuators the
        body torque (3,)).
    allocation : WheelAllocation, optional
    sensors, estimator : optional
        The measurements' sensors and the attitude estimator (:mod:`attitude.sensors`,
        :mod:`attitude.estimation`); None: the truth.
    modes : sequence of (condition, Mode or FlightSoftware), optional
        Modes visited in order, e.g. detumble → Sun-safe → pointing: the software starts in the
        first, and moves on to mode i + 1 at the first tick where its condition holds
        (:mod:`attitude.software` conditions, or the events ``RateExceeds`` and
        ``PointingExceeds``). The active mode is recorded. Instead of ``guidance``,
        ``control`` and ``allocation``.
    delay : int
        Whole ticks between a command's computation and its application (latency).
    phase : float or Quantity
        Time of the first tick after the run's start (s, default 0).
    inertia : array_like (3,) or (3, 3), optional
        The software's model of the spacecraft's inertia (kg m²; default the true one):
        what the laws' gyroscopic and feed-forward terms use; its principal moments must meet
        the triangle inequalities, as :class:`attitude.RigidBody`'s.
    record_every : None, int or Quantity
        What the result records of the ticks (the ``tick`` variables): None (default) the
        ticks in effect at the run's output samples (the last tick at or before each sample:
        its mode, reference, errors, requests, commands, measurements and estimate), so the
        result's size follows the samples asked for; an integer k every k-th tick (1: every
        tick, tick-level telemetry: ~200 bytes a tick in memory with three wheels; stream it
        to a file for long runs, ``propagate(..., on_chunk=writer.append)`` or the
        ``attitude run`` command); a time interval (e.g. ``60 * u.s``, a whole number of
        periods).
    burns : sequence of Burn, optional
        Thruster burns (orbit manoeuvres) the software commands while its modes control the
        attitude (:class:`attitude.software.Burn`).
    """

    def __init__(
        self,
        period: Any,
        guidance: Any = None,
        control: Any = None,
        allocation: Any = None,
        sensors: Any = None,
        estimator: Any = None,
        modes: Sequence[tuple[Any, Any]] | None = None,
        delay: int = 0,
        *,
        phase: Any = 0.0,
        inertia: Any = None,
        record_every: Any = None,
        burns: Sequence[Any] = (),
    ):
        self.period = _period(period)
        from ._burns import Burn

        if isinstance(burns, Burn):
            burns = (burns,)
        if not isinstance(burns, Sequence) or not all(isinstance(b, Burn) for b in burns):
            raise AttitudeTypeError("burns: a list of attitude.software.Burn")
        self.burns = tuple(burns)
        self.delay = as_int(delay, "delay", low=0)
        ph = as_float_array(phase, "phase", unit="s")
        if ph.shape != () or not 0.0 <= float(ph) < math.inf:
            raise AttitudeValueError(f"phase: expected a time >= 0 s, got {phase!r}")
        self.phase = float(ph)
        self.record_every = _record_every(record_every, self.period)
        self.inertia = None
        if inertia is not None:
            a = as_float_array(inertia, "inertia", unit="kg m2")
            if a.shape == (3,):
                a = np.diag(a)
            if a.shape != (3, 3) or not np.allclose(a, a.T) or np.any(np.linalg.eigvalsh(a) <= 0):
                raise AttitudeValueError(
                    "inertia: expected 3 principal moments or a symmetric positive definite 3 x 3"
                )
            RigidBody(np.linalg.eigvalsh(a))  # its checks: the triangle inequalities
            self.inertia = a
        refuse_class(estimator, "estimator")
        if sensors is not None or estimator is not None:
            from ..sensors import as_sensor_set

            self.sensors = as_sensor_set(sensors)
        else:
            self.sensors = None
        self.estimator = estimator
        if modes is None:
            self.modes: list[tuple[Condition | None, Mode]] = [
                (None, Mode(guidance, control, allocation))
            ]
        else:
            if guidance is not None or control is not None or allocation is not None:
                raise AttitudeValueError(
                    "modes: give guidance, control and allocation per mode, not beside modes"
                )
            if isinstance(modes, (str, bytes)) or not isinstance(modes, Sequence) or not modes:
                raise AttitudeTypeError("modes: expected a non-empty list of (condition, Mode)")
            out = []
            for i, item in enumerate(modes):
                if not isinstance(item, (tuple, list)) or len(item) != 2:
                    raise AttitudeTypeError(f"modes[{i}]: expected a pair (condition, Mode)")
                cond, mode = item
                refuse_class(cond, f"modes[{i}] condition")
                refuse_class(mode, f"modes[{i}]")
                if isinstance(mode, FlightSoftware):
                    if len(mode.modes) != 1:
                        raise AttitudeValueError(f"modes[{i}]: a software with modes of its own")
                    mode = mode.modes[0][1]
                if not isinstance(mode, Mode):
                    raise AttitudeTypeError(
                        f"modes[{i}]: expected a Mode (or a FlightSoftware), got "
                        f"{type(mode).__name__}"
                    )
                out.append((as_condition(cond) if i else None, mode))
            self.modes = out
        self.python_step = None
        self.compiled_step = None
        steps = [_control(m.control)[2] for _, m in self.modes]
        if any(s is not None for s in steps):
            if len(self.modes) != 1:
                raise AttitudeValueError(
                    "modes: your own step(t, measurements) runs the whole software; it does not "
                    "mix with modes of built-in laws"
                )
            if _is_compiled(steps[0]):
                self.compiled_step = steps[0]
            else:
                self.python_step = steps[0]

    def with_sensor_seeds(self, seeds: Sequence[int]) -> FlightSoftware:
        """The same software whose sensors draw from the streams of ``seeds`` (one integer per
        sensor, in the order of ``self.sensors``): what an ensemble member runs
        (:func:`attitude.ensemble.propagate_ensemble` draws the seeds from its ``seed``)."""
        import copy

        sensors = self.sensors or ()
        if len(seeds) != len(sensors):
            raise AttitudeValueError(
                f"seeds: {len(seeds)} seeds for the software's {len(sensors)} sensors"
            )
        new = copy.copy(self)
        new.sensors = tuple(x.with_seed(s) for x, s in zip(sensors, seeds, strict=True))
        if self.sensors is None:
            new.sensors = None
        return new

    @property
    def mode_names(self) -> list[str]:
        return [m.name or f"mode{i}" for i, (_, m) in enumerate(self.modes)]

    def describe(self) -> str:
        parts = [f"period {self.period:g} s"]
        if self.delay:
            parts.append(f"delay {self.delay} ticks")
        for i, (cond, m) in enumerate(self.modes):
            law = (
                m.control
                if not callable(m.control) or isinstance(m.control, ControlLaw)
                else (
                    f"{'compiled' if _is_compiled(m.control) else 'python'} "
                    f"{getattr(m.control, '__name__', 'step')}"
                )
            )
            g = m.guidance.describe() if m.guidance is not None else "none"
            c = f" when {type(cond).__name__}" if cond is not None else ""
            parts.append(f"{self.mode_names[i]}{c}: guidance {g}, control {law!r}")
        return "; ".join(parts)

    def __repr__(self) -> str:
        return f"FlightSoftware({self.describe()})"


@dataclass
class Program:
    """The compiled loop's view of a flight software for one run."""

    fw: np.ndarray
    fs_size: int
    n_cmd: int
    rec_width: int
    python_step: Callable | None = None
    compiled_step: Callable | None = None  # a numba function step(t, m) -> commands
    mode_names: list[str] = field(default_factory=list)
    ideal: bool = False
    frames: dict = field(default_factory=dict)
    ss0: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the sensors' initial state
    sensors: tuple = ()
    estimator: Any = None
    n_ticks: int = 0  # ticks of the run
    recorded: np.ndarray | None = None  # the indices of the recorded ticks (None: every k-th)

    @property
    def record_every(self) -> int | None:
        """Every k-th tick recorded, or None: the ticks at the output samples."""
        k = int(self.fw[FW.RECORD_EVERY])
        return k if self.recorded is None and k > 0 else None

    @property
    def n_recorded(self) -> int:
        """The number of tick records the run makes."""
        if self.recorded is not None:
            return int(self.recorded.shape[0])
        return -(-self.n_ticks // int(self.fw[FW.RECORD_EVERY]))

    def tick_times(self) -> np.ndarray:
        """The times of the recorded ticks, t_k = t0 + k·period (the compiled loop's own
        arithmetic)."""
        t0, per = float(self.fw[FW.T0]), float(self.fw[FW.PERIOD])
        if self.recorded is not None:
            k = self.recorded
        else:
            k = np.arange(0, self.n_ticks, int(self.fw[FW.RECORD_EVERY]), dtype=np.int64)
        return t0 + k * per

    def fresh_state(self) -> np.ndarray:
        """The software state ``fs`` at the start of a run (the sensors' streams seeded)."""
        fs = np.zeros(self.fs_size)
        if self.ss0.size:
            at = int(self.fw[FW.SS])
            fs[at : at + self.ss0.size] = self.ss0
        return fs


def _frame_data(frame: Any, start: float, stop: float) -> np.ndarray:
    h = _kf.DOMEGA_STEP
    return np.asarray(frame.kernel_data(start - 2 * h, stop + 2 * h), dtype=np.float64)


def _law_checks(where: str, law: Any, dump: Any, al: Any, counts: tuple, gpinv: Any) -> None:
    """Refuse a mode's law, dumping or allocation the spacecraft's actuators cannot serve."""
    nw, nm, nt = counts
    ideal = nw + nm + nt == 0
    if law is not None:
        if law.needs == "dipole" and not nm:
            raise AttitudeValueError(
                f"{where}: {type(law).__name__} commands magnetorquers; the spacecraft has "
                "none (Spacecraft(..., magnetorquers=[Magnetorquer(axis, max_dipole), ...]))"
            )
        if law.needs == "torque" and not ideal and not nw and not nm:
            raise AttitudeValueError(
                f"{where}: {type(law).__name__} requests a body torque; thrusters alone are "
                "commanded by a CommandSchedule or your own step function"
            )
        if law.needs == "torque" and nw and gpinv is None:
            raise AttitudeValueError(
                f"{where}: the wheels' axes do not span the three body axes: no wheel "
                "allocation can produce every torque"
            )
    if dump is not None and (not nm or not nw):
        raise AttitudeValueError(
            f"{where}: MomentumDumping unloads wheels with magnetorquers; the spacecraft "
            f"has {nw} wheels and {nm} magnetorquers"
        )
    if al is not None:
        if not nw:
            raise AttitudeValueError(f"{where}: a WheelAllocation needs wheels")
        if al.null_speeds is not None and al.null_speeds.shape != (nw,):
            raise AttitudeValueError(
                f"{where}: null_speeds has {al.null_speeds.size} entries for {nw} wheels"
            )


def _mode_block(cond: Any, mode: Mode, out: Appender, span: tuple[float, float]) -> np.ndarray:
    """The mode's block (:data:`attitude._core.fsw_layout.MB`); its frames and tables
    appended to ``out``."""
    m: dict[str, Any] = {}
    if cond is not None:
        m.update(cond=cond._kind, cond_x=cond.threshold)
        if cond.frame is not None:
            m["cond_frame"] = out.append(_frame_data(cond.frame, *span))
            if cond.axis is not None:
                m["cond_axis"] = cond.axis
    g = mode.guidance
    if isinstance(g, Slew):
        m.update(guid=_kf.GUID_SLEW, guid_frame=out.append(_frame_data(g.target, *span)))
        m.update(slew_rate=g.max_rate, slew_acc=g.max_accel)
    elif g is not None:
        m.update(guid=_kf.GUID_FRAME, guid_frame=out.append(_frame_data(g, *span)))
    law, dump, _step = _control(mode.control)
    if law is not None:
        K, P, Ki, lim, lt = law._gains()
        m.update(ctrl=law._kind, k=K, p=P, ki=Ki, ilim=lim, lawtype=lt)
    if dump is not None:
        m.update(dump=dump.gain, dump_ref=dump.reference)
    al = mode.allocation
    if al is not None:
        m["null"] = al.null_gain
        if al.null_speeds is not None:
            m["null_speeds"] = out.append(al.null_speeds)
    return MB.pack(**m)


def program(
    software: FlightSoftware, craft: Any, t0: float, t_end: float, samples: Any = None
) -> Program:
    """Validate ``software`` against the spacecraft and build its compiled program
    (``samples``: the run's output times, where the default recording takes its ticks)."""
    nw, nm, nt = craft.counts
    ncmd = nw + nm + nt
    ideal = ncmd == 0
    n_ticks = tick_count(t0 + software.phase, software.period, t_end)
    recorded = None
    if software.record_every is None:
        recorded = ticks_at(t0 + software.phase, software.period, n_ticks,
                            np.array([t0, t_end]) if samples is None else samples)  # fmt: skip
        if recorded.shape[0] == n_ticks:  # every tick is in effect at a sample
            recorded = None
    inertia = software.inertia if software.inertia is not None else np.diag(craft.body.inertia)
    h: dict[str, Any] = dict(
        period=software.period,
        t0=t0 + software.phase,
        delay=software.delay,
        nmodes=len(software.modes),
        ncmd=ncmd,
        ideal=1.0 if ideal else 0.0,
        record_every=(
            software.record_every
            if software.record_every is not None
            else (1 if recorded is None else 0)
        ),
        external=software.python_step is not None or software.compiled_step is not None,
        inertia=inertia,
    )
    out = Appender(np.zeros(FW.SIZE))
    gpinv = None
    if nw:
        G = craft.wheel_axes.T  # 3 × n
        if np.linalg.matrix_rank(G) == 3:
            gpinv = G.T @ np.linalg.inv(G @ G.T)  # n × 3
            h["gpinv"] = out.append(gpinv)
            h["nullp"] = out.append(np.eye(nw) - gpinv @ G)
    if nm:
        A = np.array([m.axis for m in craft.magnetorquers]).T  # 3 × n_m
        h["napinv"] = out.append(np.linalg.pinv(A))
    if recorded is not None:
        h.update(record_table=out.append(recorded), record_n=recorded.shape[0])
    modes_at = h["modes"] = out.append(np.zeros(len(software.modes)))
    offsets = []
    for i, (cond, mode) in enumerate(software.modes):
        where = f"modes[{i}]" if len(software.modes) > 1 else "software"
        law, dump, _step = _control(mode.control)
        block = _mode_block(cond, mode, out, (t0, t_end))
        _law_checks(where, law, dump, mode.allocation, (nw, nm, nt), gpinv)
        offsets.append(out.append(block))
    magnetic = any((_control(m.control)[0] is not None and _control(m.control)[0].needs == "dipole")
                   or _control(m.control)[1] is not None for _, m in software.modes)  # fmt: skip
    if magnetic and craft.orbit is None and isinstance(craft.field, str):
        raise AttitudeValueError(
            "software: the magnetic laws read the geomagnetic field along the orbit; give "
            "Spacecraft(..., orbit=...)"
        )
    fs_size = _kf.state_size(software.delay, ncmd)
    ss0 = np.zeros(0)
    sensors = software.sensors or ()
    if sensors or software.estimator is not None:
        from ..sensors._models import SunSensor, sensor_program

        sn, ss0 = sensor_program(sensors, software.period, craft, t0, t_end)
        h.update(sensors=out.append(sn), ss=fs_size, es=fs_size + ss0.size)
        fs_size += ss0.size + ES.SIZE
        h["z"] = fs_size
        heads = max((x.normals.shape[0] for x in sensors if isinstance(x, SunSensor)), default=0)
        fs_size += _ks.Z.SIZE + heads
        if software.estimator is not None:
            from ..estimation import MEKF

            if not isinstance(software.estimator, MEKF):
                raise AttitudeTypeError(
                    f"estimator: expected an attitude.estimation.MEKF, got "
                    f"{type(software.estimator).__name__}"
                )
            h["est"] = out.append(software.estimator.record(sensors))
    needs_field = magnetic or any(getattr(x, "kind", "") == "magnetometer" for x in sensors)
    if needs_field and not nm and craft.orbit is not None:
        from ..potentials import MagneticDipole

        fm = MagneticDipole(craft.orbit, [0.0, 0.0, 0.0], craft.field)
        span = np.array([t0, t_end])
        fm.prepare(span)
        h["field"] = out.append(fm._kernel_params(span))
    if software.burns:
        from ._burns import burn_table

        h["burns"] = out.append(burn_table(software.burns, craft))
    if craft.orbit is not None:
        h["orbit"] = out.append(craft.orbit.kernel_data())
        if getattr(craft.orbit, "epoch", None) is not None:
            from orbit import sun as _sun

            h["sun"] = out.append(
                _sun.SunTable(craft.orbit.epoch, t0 - 60.0, t_end + 60.0).kernel_data()
            )
    fw = FW.pack_into(out.array(), 0, **h)
    fw[modes_at : modes_at + len(offsets)] = offsets
    return Program(
        fw=fw,
        fs_size=fs_size,
        n_cmd=ncmd,
        rec_width=_kf.record_width(ncmd, bool(sensors) or software.estimator is not None),
        python_step=software.python_step,
        compiled_step=software.compiled_step,
        mode_names=software.mode_names,
        ideal=ideal,
        ss0=ss0,
        sensors=tuple(sensors),
        estimator=software.estimator,
        n_ticks=n_ticks,
        recorded=recorded,
    )
