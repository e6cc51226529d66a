"""Open-loop commands: :class:`CommandSchedule`, held piecewise constant (zero-order hold)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..errors import AttitudeFileError, AttitudeTypeError, AttitudeValueError

__all__ = ["CommandSchedule"]

#: Column names of a command CSV file (1-based actuator numbers).
_CSV_COLUMN = re.compile(r"^(wheel_torque|dipole|thrust)_([1-9][0-9]*)$")


class CommandSchedule:
    """Actuator commands held piecewise constant from each time to the next.

    The commands given at ``times[j]`` act on [times[j], times[j + 1]); the last ones until
    the end of the run; before the first time every command is zero. The integrators restart
    at every time of the schedule (and where a thruster's firing ends), so a command step is
    resolved exactly, not smeared by a step that straddles it. Passed as
    ``propagate(spacecraft, ..., commands=schedule)``; the flight software
    (:class:`attitude.FlightSoftware`) produces the same commands tick by tick.

    Parameters
    ----------
    times : array_like or Quantity, shape (K,)
        Start times of the holds (s, the run's time axis), strictly increasing.
    wheel_torque : array_like or Quantity, shape (K, n_wheels), optional
        Motor torque command per wheel (N m), clipped by each wheel's limits when applied.
    dipole : array_like or Quantity, shape (K, n_magnetorquers), optional
        Dipole command per magnetorquer (A m²), clipped to ±max_dipole.
    thrust : array_like, shape (K, n_thrusters), optional
        Fraction of each hold every thruster fires, from the start of the hold (0 to 1).

    Notes
    -----
    The number of columns must match the spacecraft's actuators; a spacecraft's actuators
    without a column get zero commands only if the schedule gives none of that kind
    (``wheel_torque=None``). Checked by :func:`attitude.propagate` before any work.
    """

    def __init__(
        self, times: Any, wheel_torque: Any = None, dipole: Any = None, thrust: Any = None
    ):
        t = as_float_array(times, "times", unit="s")
        if t.ndim == 0:
            t = t.reshape(1)
        if t.ndim != 1 or t.size == 0:
            raise AttitudeValueError(
                f"times: expected a 1-D array of at least one hold start time, got shape {t.shape}"
            )
        if t.size > 1 and not bool(np.all(t[1:] > t[:-1])):
            i = int(np.argmin(t[1:] > t[:-1]))
            raise AttitudeValueError(
                f"times: must be strictly increasing; times[{i}] = {t[i]!r} and "
                f"times[{i + 1}] = {t[i + 1]!r} (sort the schedule, or merge equal times)"
            )
        self.times = t
        self.wheel_torque = self._column(wheel_torque, "wheel_torque", "N m", t.size)
        self.dipole = self._column(dipole, "dipole", "A m2", t.size)
        th = self._column(thrust, "thrust", None, t.size)
        if th is not None and th.size and not bool(np.all((th >= 0.0) & (th <= 1.0))):
            bad = tuple(int(i) for i in np.argwhere((th < 0.0) | (th > 1.0))[0])
            raise AttitudeValueError(
                f"thrust: on-time fractions lie between 0 and 1; thrust{list(bad)} = {th[bad]!r}"
            )
        self.thrust = th
        # read-only copies: the caller's arrays stay as they were (writable; the run's own times
        # are often the schedule's)
        for key in ("times", "wheel_torque", "dipole", "thrust"):
            a = getattr(self, key)
            if a is not None:
                a = np.array(a, order="C")
                a.setflags(write=False)
                setattr(self, key, a)

    @staticmethod
    def _column(x: Any, name: str, unit: str | None, k: int) -> np.ndarray | None:
        if x is None:
            return None
        a = as_float_array(x, name, unit=unit)
        if a.ndim == 1 and a.shape[0] == k:
            a = a.reshape(k, 1)  # one actuator
        if a.ndim != 2 or a.shape[0] != k:
            raise AttitudeValueError(
                f"{name}: expected shape ({k}, n), one row per time of the schedule, got shape "
                f"{a.shape}"
            )
        return a

    def __len__(self) -> int:
        return int(self.times.size)

    def counts(self) -> tuple[int | None, int | None, int | None]:
        """Columns given for (wheels, magnetorquers, thrusters); None where not given."""
        kinds = (self.wheel_torque, self.dipole, self.thrust)
        n = [None if a is None else int(a.shape[1]) for a in kinds]
        return n[0], n[1], n[2]

    def arrays(self, n_w: int, n_m: int, n_t: int) -> tuple[np.ndarray, np.ndarray]:
        """(times (K,), raw commands (K, n_w + n_m + n_t)) for a spacecraft with these
        actuator counts (zero for a kind the schedule does not give).

        Raises
        ------
        AttitudeValueError
            A kind given with the wrong number of columns, or for actuators the spacecraft does
            not have.
        """
        k = self.times.size
        out = np.zeros((k, n_w + n_m + n_t))
        c = 0
        for a, n, name, what in (
            (self.wheel_torque, n_w, "wheel_torque", "wheels"),
            (self.dipole, n_m, "dipole", "magnetorquers"),
            (self.thrust, n_t, "thrust", "thrusters"),
        ):
            if a is not None:
                if n == 0:
                    raise AttitudeValueError(
                        f"commands: the schedule commands {name} but the spacecraft has no {what}"
                    )
                if a.shape[1] != n:
                    raise AttitudeValueError(
                        f"commands: {name} has {a.shape[1]} columns, the spacecraft has {n} {what}"
                    )
                out[:, c : c + n] = a
            c += n
        return self.times, out

    @classmethod
    def from_csv(cls, path: Any) -> CommandSchedule:
        """Read a schedule from a CSV file.

        The header names the columns: ``time`` (s), then any of ``wheel_torque_1``,
        ``wheel_torque_2``, ... (N m), ``dipole_1``, ... (A m²), ``thrust_1``, ... (on-time
        fractions), numbered from 1 in the order of the spacecraft's actuators; ``#`` starts
        a comment line.
        """
        if not isinstance(path, (str, Path)):
            raise AttitudeTypeError(
                f"path: expected a file name (str or pathlib.Path), got {type(path).__name__}"
            )
        p = Path(path)
        if "\x00" in str(p):
            raise AttitudeFileError(f"path: {str(p)!r} holds a NUL byte; no file has that name")
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise AttitudeFileError(f"{p}: cannot read the command schedule: {exc}") from None
        lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
        if not lines:
            raise AttitudeValueError(f"{p}: the command schedule is empty")
        header = [h.strip() for h in lines[0].split(",")]
        if header[0] != "time":
            raise AttitudeValueError(f"{p}: the first column must be 'time', got {header[0]!r}")
        kinds: dict[str, dict[int, int]] = {"wheel_torque": {}, "dipole": {}, "thrust": {}}
        for c, h in enumerate(header[1:], start=1):
            mt = _CSV_COLUMN.match(h)
            if mt is None:
                raise AttitudeValueError(
                    f"{p}: unknown column {h!r}; columns are time, wheel_torque_<k>, "
                    "dipole_<k>, thrust_<k> (k from 1)"
                )
            if int(mt.group(2)) in kinds[mt.group(1)]:
                raise AttitudeValueError(f"{p}: the column {h!r} is given twice")
            kinds[mt.group(1)][int(mt.group(2))] = c
        rows = []
        for i, ln in enumerate(lines[1:], start=2):
            cells = [x.strip() for x in ln.split(",")]
            if len(cells) != len(header):
                raise AttitudeValueError(
                    f"{p}: data line {i} has {len(cells)} values, the header {len(header)}"
                )
            try:
                rows.append([float(x) for x in cells])
            except ValueError:
                raise AttitudeValueError(
                    f"{p}: data line {i} holds a value that is not a number"
                ) from None
        if not rows:
            raise AttitudeValueError(f"{p}: the command schedule has no data lines")
        data = np.array(rows)
        cols: dict[str, np.ndarray | None] = {}
        for kind, idx in kinds.items():
            if not idx:
                cols[kind] = None
                continue
            n = max(idx)
            if n != len(idx):  # numbers 1..n, each once (checked above)
                raise AttitudeValueError(
                    f"{p}: the {kind} columns must be numbered 1 to {n} without gaps"
                )
            cols[kind] = data[:, [idx[j] for j in range(1, n + 1)]]
        return cls(data[:, 0], **cols)

    def __repr__(self) -> str:
        kinds = [
            f"{name}={a.shape[1]}"
            for name, a in (
                ("wheels", self.wheel_torque),
                ("magnetorquers", self.dipole),
                ("thrusters", self.thrust),
            )
            if a is not None
        ]
        return f"CommandSchedule({len(self)} holds, {', '.join(kinds) or 'no commands'})"
