"""Tabulated orbits: :class:`EphemerisOrbit` (arrays, TLEs through SGP4, CCSDS OEM files).

The table holds positions and velocities at node times; between them the state is the
Hermite interpolant of degree 7 through the 4 nearest nodes (value and velocity at each),
evaluated in compiled code (:mod:`orbit._state_kernels`), also inside the attitude
integrators' right-hand sides. Times outside the table are an error, never an extrapolation.

Interpolation error (Hermite remainder, h = node spacing): |Δr| <= 7.8e-6 h⁸ max|r⁽⁸⁾| on inner
intervals, 2.5e-5 h⁸ max|r⁽⁸⁾| on the first and last (per component). For a circular orbit of
radius r and mean motion n,
|r⁽⁸⁾| = n⁸ r: in LEO (7000 km) at h = 60 s that is 2e-11 km, far below the 1 mm required;
h = 300 s gives ~1e-5 km. docs/orbit.md has the table and the measured errors.

Sources
-------
* ``EphemerisOrbit(t, r, v, epoch=None, mu=None)``: your own arrays (space frame: GCRS when an
  epoch is given).
* :meth:`EphemerisOrbit.from_tle`: SGP4 through the ``sgp4`` package (Vallado's reference
  implementation, its vectorised ``sgp4_array``), TEME → GCRS by astropy.
* :meth:`EphemerisOrbit.from_oem`: a CCSDS Orbit Ephemeris Message (KVN or XML) read by
  ``ccsds-ndm-py``; frames EME2000 (rotated by the frame bias to GCRS), GCRF/GCRS/ICRF
  (Earth-centred).
* :meth:`EphemerisOrbit.from_orbit`: samples any other orbit (tests, or to freeze an orbit).
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from . import _state_kernels as _sk
from ._oem import _oem_kvn, _oem_path, _oem_time, _oem_xml
from .base import OrbitBase
from .ccsds import is_xml
from .errors import OrbitTypeError, OrbitValueError, TLEAgeWarning
from .kepler import _as_array
from .keplerorbit import _scalar, earth_mu
from .tables import MAX_NODES  # (1e7 nodes are 560 MB of floats)
from .timescales import as_epoch, format_epoch, offline_iers

__all__ = ["EphemerisOrbit", "check_tle", "position_derivative"]

#: Step [s] of the central differences giving a TLE table's velocities (truncation
#: δ⁴/30 |r⁽⁵⁾| ~ 5e-12 km/s in LEO; SGP4's 1e-12 rad Kepler tolerance noise / δ ~ 4e-9 km/s;
#: measured: interpolated positions within 8e-9 km of SGP4 at off-grid times, δ = 1 to 4 s).
FD_STEP = 2.0
#: astropy's TEME → GCRS rotation every hour, interpolated between (orbit.frames: 1e-13 rad).
TEME_STEP = 3600.0
#: Largest distance [km] between the Hermite tables built on an OEM's velocities and on the
#: derivative of its positions, at the midpoints between states, before ``from_oem`` warns
#: (1 mm: the interpolation error of a 60 s LEO table is 1e-8 of that).
VELOCITY_CHECK = 1e-6
#: Reference frames of an OEM that are accepted (Earth-centred): EME2000 is rotated to GCRS.
OEM_FRAMES = ("EME2000", "GCRF", "GCRS", "ICRF")
#: Time systems of an OEM that are accepted.
OEM_TIME_SYSTEMS = ("UTC", "TAI", "TT", "GPS", "TDB")


# ---------------------------------------------------------------------------------------------
# TLE checks (sgp4 parses columns without checking the format or the checksums).
def _tle_checksum(line: str) -> int:
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


#: The numeric fields of a TLE: (line, first column, last column (1-based, inclusive), name,
#: format). A line shifted by one blank keeps a valid checksum; its fields do not parse.
_TLE_FIELDS = [
    (1, 19, 20, "epoch year", r"[ \d]\d"),
    (1, 21, 32, "epoch day of the year", r"[ \d]{3}\.\d{8}"),
    (1, 34, 43, "first derivative of the mean motion", r"[ +-]\.\d{8}"),
    (1, 45, 52, "second derivative of the mean motion", r"[ +-]\d{5}[+-]\d"),
    (1, 54, 61, "BSTAR drag term", r"[ +-]\d{5}[+-]\d"),
    (1, 63, 63, "ephemeris type", r"[ \d]"),
    (1, 65, 68, "element set number", r" *\d*"),
    (2, 9, 16, "inclination", r"[ \d]{3}\.[\d ]{4}"),
    (2, 18, 25, "right ascension of the ascending node", r"[ \d]{3}\.[\d ]{4}"),
    (2, 27, 33, "eccentricity", r"\d{7}"),
    (2, 35, 42, "argument of perigee", r"[ \d]{3}\.[\d ]{4}"),
    (2, 44, 51, "mean anomaly", r"[ \d]{3}\.[\d ]{4}"),
    (2, 53, 63, "mean motion", r"[ \d]{2}\.[\d ]{8}"),
    (2, 64, 68, "revolution number", r" *\d*"),
]
#: The columns that are blank between the fields (1-based).
_TLE_BLANKS = {1: (2, 9, 18, 33, 44, 53, 62, 64), 2: (2, 8, 17, 26, 34, 43, 52)}


def _check_tle_fields(line: str, name: str, num: int) -> None:
    """Raise OrbitValueError naming the first TLE field that is not in its fixed columns."""
    for n, c0, c1, what, fmt in _TLE_FIELDS:
        if n == num and not re.fullmatch(fmt, line[c0 - 1 : c1]):
            raise OrbitValueError(
                f"{name}: the {what} (columns {c0}-{c1}) reads {line[c0 - 1 : c1]!r}, not a "
                "number in its fixed columns: is the line shifted (a blank added or lost)?"
            )
    for c in _TLE_BLANKS[num]:
        if line[c - 1] != " ":
            raise OrbitValueError(
                f"{name}: column {c} separates two fields and must be blank, got "
                f"{line[c - 1]!r}: is the line shifted (a blank added or lost)?"
            )


#: Days from a TLE's epoch beyond which :class:`~orbit.errors.TLEAgeWarning` is given: SGP4
#: errors grow by about 1-3 km a day in low orbit; element sets are refitted daily.
TLE_MAX_AGE = 30.0
#: No element set describes an orbit before the first satellite (Sputnik 1, launched
#: 1957-10-04T19:28:34 UTC): a TLE span that starts earlier is refused.
FIRST_SATELLITE = "1957-10-04T19:28:34"


def _check_tle_span(t_start: Any, t_stop: Any, tle_epoch: Any) -> None:
    from astropy.time import Time

    first = Time(FIRST_SATELLITE, scale="utc")
    if float((t_start - first).sec) < 0.0:
        raise OrbitValueError(
            f"start: {t_start.utc.isot[:19]} UTC is before {FIRST_SATELLITE[:10]}, the launch "
            "of the first satellite: no element set describes an orbit then"
        )
    age = max(abs(float((t - tle_epoch).sec)) for t in (t_start, t_stop)) / 86400.0
    if age > TLE_MAX_AGE:
        warnings.warn(
            f"start, stop: the span reaches {age:.4g} days from the element set's epoch "
            f"{tle_epoch.utc.isot[:19]} UTC; SGP4's error grows with that time (about 1-3 km a "
            f"day in low orbit): beyond {TLE_MAX_AGE:g} days use an element set of the span's "
            "dates",
            TLEAgeWarning,
            stacklevel=3,
        )


def check_tle(line1: Any, line2: Any) -> tuple[str, str]:
    """Validate the two lines of a TLE; return them stripped of trailing whitespace.

    Raises
    ------
    OrbitValueError
        Naming ``line1`` or ``line2``: wrong line number, length, checksum, or catalogue numbers
        that differ. ``OrbitTypeError`` for non-strings.
    """
    lines = []
    for name, line, num in (("line1", line1, "1"), ("line2", line2, "2")):
        if not isinstance(line, str):
            raise OrbitTypeError(f"{name}: expected the TLE line as a string, got {type(line)}")
        s = line.rstrip("\r\n ").lstrip("\ufeff")
        if not s.startswith(num + " "):
            other = "2" if num == "1" else "1"
            hint = (
                f" (it starts with '{other} ': the two lines are swapped?)"
                if s.startswith(other + " ")
                else ""
            )
            raise OrbitValueError(
                f"{name}: a TLE line {num} starts with '{num} ', got {s[:12]!r}{hint}"
            )
        if len(s) != 69:
            raise OrbitValueError(
                f"{name}: a TLE line has 69 characters, this one has {len(s)} ({s!r})"
            )
        if not s[68].isdigit() or _tle_checksum(s) != int(s[68]):
            raise OrbitValueError(
                f"{name}: checksum error: the last digit is {s[68]!r} but the line sums to "
                f"{_tle_checksum(s)} (mod 10); the line is corrupted or mistyped"
            )
        _check_tle_fields(s, name, int(num))
        lines.append(s)
    if lines[0][2:7] != lines[1][2:7]:
        raise OrbitValueError(
            f"line2: catalogue number {lines[1][2:7]!r} differs from line1's {lines[0][2:7]!r}: "
            "the two lines are from different element sets"
        )
    return lines[0], lines[1]


def _grid(span: float, step: float) -> np.ndarray:
    """Equal intervals no longer than ``step`` covering [0, span] (nodes 0 ... span)."""
    n = max(2, math.ceil(span / step * (1.0 - 1e-12)) + 1)
    if n > MAX_NODES:
        raise OrbitValueError(
            f"step: {n} nodes over {span!r} s is more than {MAX_NODES}; use a larger step"
        )
    return np.linspace(0.0, span, n)


def _positive_seconds(x: Any, name: str) -> float:
    v = _scalar(x, name, "s")
    if not (math.isfinite(v) and v > 0.0):
        raise OrbitValueError(f"{name}: must be a positive number of seconds, got {v!r}")
    return v


def _atomic_write(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=str(path.parent or Path(".")), prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


class EphemerisOrbit(OrbitBase):
    """An orbit given as a table of states, interpolated by degree-7 Hermite polynomials.

    Parameters
    ----------
    t : array_like, shape (n,) [s]
        Node times, seconds since ``epoch``, strictly increasing, n >= 2 (>= 4 for the full
        interpolation order).
    r : array_like, shape (n, 3) [km]
        Positions in the space frame (GCRS when there is an epoch).
    v : array_like, shape (n, 3) [km/s]
        Velocities.
    epoch : astropy Time or str, optional
        Date of t = 0 (UTC unless a scale is given).
    mu : float or Quantity [km³/s²], optional
        Gravitational parameter of the central body (the gravity gradient uses it); default
        astropy's GM_earth.
    source : str, keyword-only, optional
        One line naming the origin of the table (recorded in result attrs).

    Raises
    ------
    OrbitValueError
        Shapes, non-finite values, fewer than 2 nodes, times not strictly increasing (the
        message names the first offending index), a zero position, mu <= 0.
    """

    def __init__(
        self,
        t: Any,
        r: Any,
        v: Any,
        epoch: Any = None,
        mu: Any = None,
        *,
        source: str | None = None,
    ) -> None:
        self._epoch = as_epoch(epoch, "epoch")
        tt = np.ascontiguousarray(_as_array(t, "t", "s"), dtype=np.float64)
        rr = np.ascontiguousarray(_as_array(r, "r", "km"), dtype=np.float64)
        vv = np.ascontiguousarray(_as_array(v, "v", "km / s"), dtype=np.float64)
        if tt.ndim != 1 or tt.size < 2:
            raise OrbitValueError(f"t: expected a 1-D array of >= 2 node times, got {tt.shape}")
        n = tt.size
        for name, arr in (("r", rr), ("v", vv)):
            if arr.shape != (n, 3):
                raise OrbitValueError(
                    f"{name}: expected shape ({n}, 3) to match t's {n} times, got {arr.shape}"
                )
            if not np.all(np.isfinite(arr)):
                k = int(np.argmin(np.all(np.isfinite(arr), axis=1)))
                raise OrbitValueError(f"{name}: non-finite value at index {k}")
        if not np.all(np.isfinite(tt)):
            raise OrbitValueError(f"t: non-finite time at index {int(np.argmin(np.isfinite(tt)))}")
        dt = np.diff(tt)
        if not np.all(dt > 0.0):
            k = int(np.argmin(dt > 0.0)) + 1
            raise OrbitValueError(
                f"t: times must be strictly increasing; t[{k}] = {tt[k]!r} s follows "
                f"t[{k - 1}] = {tt[k - 1]!r} s (sort the table and remove duplicate epochs)"
            )
        if n > MAX_NODES:
            raise OrbitValueError(f"t: {n} nodes is more than {MAX_NODES}")
        rn = np.linalg.norm(rr, axis=1)
        if not np.all(rn > 0.0):
            raise OrbitValueError(f"r: zero position at index {int(np.argmin(rn > 0.0))}")
        mu_ = earth_mu() if mu is None else _scalar(mu, "mu", "km3 / s2")
        if not (math.isfinite(mu_) and mu_ > 0.0):
            raise OrbitValueError(f"mu: gravitational parameter must be > 0 km³/s², got {mu_!r}")
        h = (tt[-1] - tt[0]) / (n - 1)
        uniform = bool(np.max(np.abs(dt - h)) <= 1e-9 * h)
        d = np.empty(_sk.E_TIMES + 7 * n, dtype=np.float64)
        d[_sk.TYPE] = _sk.TYPE_EPHEMERIS
        d[_sk.MU] = mu_
        d[_sk.T_MIN] = tt[0]
        d[_sk.T_MAX] = tt[-1]
        d[_sk.E_N] = n
        d[_sk.E_H] = h if uniform else 0.0
        d[_sk.E_H + 1 : _sk.E_TIMES] = 0.0
        d[_sk.E_TIMES : _sk.E_TIMES + n] = tt
        rows = d[_sk.E_TIMES + n :].reshape(n, 6)
        rows[:, :3] = rr
        rows[:, 3:] = vv
        self._set_data(d)
        self._source = source or f"ephemeris table ({n} states)"

    # -- the table ----------------------------------------------------------------------------
    @property
    def source(self) -> str:
        return self._source

    @property
    def n_nodes(self) -> int:
        """Number of table nodes."""
        return int(self._data[_sk.E_N])

    @property
    def node_times(self) -> np.ndarray:
        """Node times [s since the epoch] (a copy)."""
        return self._data[_sk.E_TIMES : _sk.E_TIMES + self.n_nodes].copy()

    @property
    def node_states(self) -> np.ndarray:
        """Node states (n, 6): x, y, z [km], vx, vy, vz [km/s] (a copy)."""
        n = self.n_nodes
        return self._data[_sk.E_TIMES + n :].reshape(n, 6).copy()

    @property
    def step(self) -> float:
        """Node spacing [s] for a uniform table, else 0."""
        return float(self._data[_sk.E_H])

    def __repr__(self) -> str:
        lo, hi = self.time_span
        ep = "" if self._epoch is None else f", epoch={self._epoch.utc.isot!r}"
        return (
            f"EphemerisOrbit(<{self.n_nodes} states, t = {lo!r} .. {hi!r} s>{ep}, "
            f"mu={self.mu!r})  # {self._source}"
        )

    # -- sources ------------------------------------------------------------------------------
    @classmethod
    def from_orbit(cls, orbit: Any, start: Any, stop: Any, step: Any = 60.0) -> EphemerisOrbit:
        """Sample any orbit (the :class:`orbit.base.Orbit` interface) into a table.

        Parameters
        ----------
        orbit : Orbit
            KeplerOrbit, SecularJ2Orbit, EphemerisOrbit or anything with ``position``,
            ``velocity``, ``epoch`` and ``mu``.
        start, stop : float [s since the orbit's epoch], astropy Time or ISO 8601 string
        step : float or Quantity [s]
            Largest node spacing: [start, stop] is cut into equal intervals no longer than it.

        Returns
        -------
        EphemerisOrbit
            Same epoch and μ as ``orbit``; node times in seconds since that epoch.
        """
        for attr in ("position", "velocity", "mu"):
            if not hasattr(orbit, attr):
                raise OrbitTypeError(
                    f"orbit: expected an orbit (KeplerOrbit, SecularJ2Orbit, EphemerisOrbit), "
                    f"got {type(orbit).__name__}"
                )
        epoch = getattr(orbit, "epoch", None)

        def secs(x: Any, name: str) -> float:
            from astropy.time import Time

            if isinstance(x, (str, Time)):
                if epoch is None:
                    raise OrbitValueError(
                        f"{name}: an absolute time needs an orbit with an epoch; give seconds"
                    )
                return float((as_epoch(x, name) - epoch).sec)
            v = _scalar(x, name, "s")
            if not math.isfinite(v):
                raise OrbitValueError(f"{name}: must be finite, got {v!r}")
            return v

        t0 = secs(start, "start")
        t1 = secs(stop, "stop")
        if not t1 > t0:
            raise OrbitValueError(f"stop: must be after start ({t1!r} s <= {t0!r} s)")
        h = _positive_seconds(step, "step")
        t = t0 + _grid(t1 - t0, h)
        t[-1] = t1
        if hasattr(orbit, "check_times"):
            orbit.check_times(np.array([t0, t1]), "start, stop")
        r = np.asarray(orbit.position(t), dtype=np.float64)
        v = np.asarray(orbit.velocity(t), dtype=np.float64)
        src = getattr(orbit, "source", type(orbit).__name__)
        return cls(t, r, v, epoch=epoch, mu=orbit.mu, source=f"sampled every {h:g} s from {src}")

    @classmethod
    def from_tle(
        cls,
        line1: str,
        line2: str,
        start: Any,
        stop: Any,
        step: Any = 60.0,
        *,
        epoch: Any = None,
        mu: Any = None,
    ) -> EphemerisOrbit:
        """States from a two-line element set: SGP4 (``sgp4`` package), TEME → GCRS (astropy).

        Parameters
        ----------
        line1, line2 : str
            The two 69-character lines (checked: line numbers, lengths, checksums).
        start, stop : astropy Time or ISO 8601 string (UTC unless a scale is given)
            Span of the table.
        step : float or Quantity [s]
            Largest node spacing (default 60 s; the interpolation error is then ~1e-11 km in
            LEO, see the module docstring).
        epoch : astropy Time or str, keyword-only, optional
            Date of t = 0 of the orbit; default ``start``.
        mu : keyword-only, optional
            Gravitational parameter for the gravity gradient; default astropy's GM_earth.

        Notes
        -----
        SGP4 runs with the WGS 72 constants the element sets are fitted with (``sgp4``'s
        default). Its time argument (minutes since the element-set epoch) is taken as elapsed
        SI seconds, so a leap second between the TLE epoch and ``start`` does not shift the
        orbit by 7 km; without a leap second in between this is what ``Satrec.sgp4_array(jd,
        fr)`` computes from UTC Julian dates. The table's velocities are the time derivative of
        the SGP4 position in GCRS (5-point central differences with δ = ``FD_STEP`` = 2 s),
        not SGP4's velocity output, which is not the derivative of its position (it leaves out
        part of the short-period terms' rates: ~5 mm/s in LEO); so the interpolated positions
        follow SGP4's to ~1e-8 km between nodes, and the velocities differ from SGP4's output
        by up to ~2 cm/s.

        Raises
        ------
        OrbitValueError
            Bad TLE lines (``line1``/``line2``), SGP4 initialisation errors (bad elements), an
            SGP4 error code at some time of the span (decayed satellite, eccentricity out of
            range...), naming the time and ``start`` or ``stop``; stop <= start.
        """
        from astropy.time import TimeDelta
        from sgp4.api import SGP4_ERRORS, Satrec

        l1, l2 = check_tle(line1, line2)
        t_start = as_epoch(start, "start", allow_none=False)
        t_stop = as_epoch(stop, "stop", allow_none=False)
        ep = t_start if epoch is None else as_epoch(epoch, "epoch")
        h = _positive_seconds(step, "step")
        with offline_iers():
            span = float((t_stop - t_start).sec)
            if not span > 0.0:
                raise OrbitValueError(
                    f"stop: must be after start ({t_stop.utc.isot} <= {t_start.utc.isot} UTC)"
                )
            sat = Satrec.twoline2rv(l1, l2)
            if sat.error != 0:
                raise OrbitValueError(
                    f"line1, line2: SGP4 rejects the elements: error {sat.error} "
                    f"({SGP4_ERRORS.get(sat.error, 'unknown')})"
                )
            from astropy.time import Time

            tle_epoch = Time(sat.jdsatepoch, sat.jdsatepochF, format="jd", scale="utc")
            _check_tle_span(t_start, t_stop, tle_epoch)
            since = _grid(span, h)
            times = t_start + TimeDelta(since, format="sec")
            offset = float((t_start - tle_epoch).sec)
            # SGP4 at the nodes and at ±δ, ±2δ around them: the table's velocity is the time
            # derivative of the SGP4 position (5-point central difference), because SGP4's own
            # velocity output is not (it differs by ~5 mm/s in LEO), and Hermite interpolation
            # with inconsistent velocities would err by ~0.1 m between nodes.
            offs = FD_STEP * np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
            tall = (since[:, None] + offs[None, :]).ravel()
            tsince_days = (offset + tall) / 86400.0
            jd = np.full(tall.size, sat.jdsatepoch)
            fr = sat.jdsatepochF + tsince_days
            err, r, _ = sat.sgp4_array(jd, fr)
            err = err.reshape(since.size, 5)
            if np.any(err != 0):
                k = int(np.argmax(np.any(err != 0, axis=1)))
                code = int(err[k][np.argmax(err[k] != 0)])
                when = times[k].utc
                when.precision = 3
                name = "start" if k == 0 else "stop"
                raise OrbitValueError(
                    f"{name}: SGP4 fails at {when.isot} UTC ({since[k]:.0f} s after start, "
                    f"{(offset + since[k]) / 86400.0:.3f} d after the element-set epoch "
                    f"{tle_epoch.isot[:19]}): error {code}, "
                    f"{SGP4_ERRORS.get(code, 'unknown error')}. Shorten the span or use a "
                    "newer element set"
                )
            from .frames import teme_to_gcrs_positions

            tabs = t_start + TimeDelta(tall, format="sec")
            rg5 = teme_to_gcrs_positions(tabs, r, step=TEME_STEP).reshape(since.size, 5, 3)
            rg = np.ascontiguousarray(rg5[:, 2])
            vg = (rg5[:, 0] - 8.0 * rg5[:, 1] + 8.0 * rg5[:, 3] - rg5[:, 4]) / (12.0 * FD_STEP)
            t = since + float((t_start - ep).sec)
        from sgp4 import __version__ as sgp4_version

        src = (
            f"TLE {l1[2:7].strip()} (element-set epoch {tle_epoch.isot[:23]} UTC), "
            f"SGP4 (sgp4 {sgp4_version}) every {h:g} s, TEME->GCRS by astropy"
        )
        return cls(t, rg, vg, epoch=ep, mu=mu, source=src)

    @classmethod
    def from_oem(
        cls, path: Any, *, epoch: Any = None, mu: Any = None, velocities: str = "file"
    ) -> EphemerisOrbit:
        """Read a CCSDS Orbit Ephemeris Message: KVN with ``ccsds-ndm-py``, XML with
        :mod:`orbit.ccsds`.

        Parameters
        ----------
        path : str or Path
        epoch : astropy Time or str, keyword-only, optional
            Date of t = 0; default the first state's epoch.
        mu : keyword-only, optional
            Default astropy's GM_earth (an OEM carries no GM).
        velocities : {"file", "positions"}, keyword-only
            The velocities of the Hermite table: the file's (default), or the derivative of
            the positions (the degree-8 polynomial through the 9 nearest states,
            :func:`position_derivative`): positions-only interpolation, for files whose
            velocities are not the time derivative of their positions (SGP4's own velocities
            are not). With ``"file"``, an :class:`~orbit.errors.OemVelocityWarning` says so
            when the two tables differ by more than :data:`VELOCITY_CHECK` between states.

        Notes
        -----
        Accepted: ``CENTER_NAME = EARTH`` with ``REF_FRAME`` EME2000 (rotated to GCRS by the
        IAU 2006 frame bias, ~23 mas, ERFA ``bp06``), GCRF, GCRS or ICRF (taken as GCRS);
        ``TIME_SYSTEM`` UTC, TAI, TT, GPS or TDB (converted by astropy, leap seconds
        included). Several segments are joined in time order (a repeated boundary epoch with the
        same state is dropped). The file's ``INTERPOLATION`` keywords are ignored: the table is
        always interpolated by the degree-7 Hermite polynomial that uses the velocities
        (see ``velocities``).

        Raises
        ------
        OrbitValueError
            Unreadable file, another frame, centre or time system (naming the keyword), times
            not increasing.
        """
        from astropy.time import Time

        if velocities not in ("file", "positions"):
            raise OrbitValueError(
                f"velocities: 'file' or 'positions' (the derivative of the positions), got "
                f"{velocities!r}"
            )
        p = _oem_path(path)
        try:
            raw = p.read_bytes()
        except OSError as exc:
            raise OrbitValueError(f"path: {p} cannot be read ({exc.strerror or exc})") from None
        segments = _oem_xml(raw, p) if is_xml(raw) else _oem_kvn(p)
        all_t: list[Any] = []
        all_s: list[np.ndarray] = []
        names = set()
        frames = set()
        systems = set()
        for k, (meta, epochs, states) in enumerate(segments):
            frame = meta["REF_FRAME"].strip().upper()
            system = meta["TIME_SYSTEM"].strip().upper()
            center = meta["CENTER_NAME"].strip().upper()
            where = f"{p.name} segment {k + 1}"
            if center != "EARTH":
                raise OrbitValueError(
                    f"CENTER_NAME: {where} is centred on {meta['CENTER_NAME']!r}; only EARTH "
                    "is supported"
                )
            if frame not in OEM_FRAMES:
                raise OrbitValueError(
                    f"REF_FRAME: {where} is in {meta['REF_FRAME']!r}; supported: "
                    f"{', '.join(OEM_FRAMES)} (convert Earth-fixed or TEME ephemerides to one "
                    "of them first)"
                )
            if system not in OEM_TIME_SYSTEMS:
                raise OrbitValueError(
                    f"TIME_SYSTEM: {where} uses {meta['TIME_SYSTEM']!r}; supported: "
                    f"{', '.join(OEM_TIME_SYSTEMS)}"
                )
            if states.ndim != 2 or states.shape[1] < 6 or states.shape[0] != len(epochs):
                raise OrbitValueError(f"path: {where} has no usable state vectors")
            strings = [_oem_time(e, system) for e in epochs]
            with offline_iers():
                try:
                    if system == "GPS":
                        tt = Time(strings, scale="tai") + 19.0 * _sec()
                    else:
                        tt = Time(strings, scale=system.lower())
                except ValueError:
                    raise OrbitValueError(
                        f"path: {where} has an epoch astropy cannot read (first: {epochs[0]!r})"
                    ) from None
            s = states[:, :6].copy()
            if frame == "EME2000":
                from .frames import eme2000_to_gcrs

                s[:, :3] = eme2000_to_gcrs(s[:, :3])
                s[:, 3:] = eme2000_to_gcrs(s[:, 3:])
            all_t.append(tt)
            all_s.append(s)
            names.add(meta.get("OBJECT_NAME", "UNKNOWN"))
            frames.add(frame)
            systems.add(system)
        if not all_t:
            raise OrbitValueError(f"path: {p} has no data segment")
        from astropy.time import TimeDelta  # noqa: F401

        ep0 = all_t[0][0]
        ep = ep0 if epoch is None else as_epoch(epoch, "epoch")
        with offline_iers():
            secs = [np.asarray((tt - ep).sec, dtype=np.float64) for tt in all_t]
        t = np.concatenate(secs)
        st = np.concatenate(all_s)
        # join segments: drop a repeated boundary epoch with the same state
        keep = np.ones(t.size, dtype=bool)
        dup = np.flatnonzero(np.diff(t) == 0.0)
        for i in dup:
            if np.array_equal(st[i], st[i + 1]):
                keep[i + 1] = False
        t, st = t[keep], st[keep]
        src = (
            f"OEM {p.name} ({', '.join(sorted(names))}; {', '.join(sorted(frames))}; "
            f"{', '.join(sorted(systems))}; {t.size} states"
            + ("; velocities from the positions)" if velocities == "positions" else ")")
        )
        try:
            out = cls(t, st[:, :3], st[:, 3:], epoch=ep, mu=mu, source=src)
        except OrbitValueError as exc:
            raise OrbitValueError(f"path: {p}: {exc}") from None
        if t.size < 3:
            return out
        v_pos = position_derivative(out.node_times, out.node_states[:, :3])
        other = cls(t, st[:, :3], v_pos, epoch=ep, mu=mu, source=src)
        if velocities == "positions":
            return other
        # The file's velocities disagree with the positions when they differ from dr/dt by
        # much more than dr/dt's own error (estimated by the polynomial of two degrees less):
        # on a coarse table of an eccentric orbit the file's exact velocities are the better.
        v_low = position_derivative(out.node_times, out.node_states[:, :3], points=7)
        dv = np.linalg.norm(st[:, 3:] - v_pos, axis=1)
        own = np.linalg.norm(v_pos - v_low, axis=1)
        if not np.any(dv > 10.0 * own + 1e-15 * np.linalg.norm(v_pos, axis=1)):
            return out
        mid = 0.5 * (t[1:] + t[:-1])
        gap = np.linalg.norm(out.position(mid) - other.position(mid), axis=1)
        worst = int(np.argmax(gap))
        if gap[worst] > VELOCITY_CHECK:
            import warnings

            from .errors import OemVelocityWarning

            warnings.warn(
                f"{p.name}: the file's velocities are not the time derivative of its positions "
                f"(up to {float(np.max(dv)) * 1e3:.3g} m/s apart): interpolating with them "
                f"moves the positions by up to {gap[worst] * 1e3:.3g} m between states (at "
                f"t = {mid[worst]:g} s) from the interpolation of the positions alone; pass "
                "velocities='positions' to interpolate the positions only (docs/orbit.md)",
                OemVelocityWarning,
                stacklevel=2,
            )
        return out

    # -- export -------------------------------------------------------------------------------
    def to_oem(
        self,
        path: Any,
        *,
        frame: str = "GCRF",
        object_name: str = "UNKNOWN",
        object_id: str = "UNKNOWN",
        originator: str = "attitude",
    ) -> Path:
        """Write the table as a CCSDS OEM 2.0 (KVN), UTC epochs, atomically.

        Parameters
        ----------
        path : str or Path
        frame : {"GCRF", "EME2000"}
            ``EME2000`` rotates the states by the frame bias (see :mod:`orbit.frames`).

        Returns
        -------
        Path
        """
        if self._epoch is None:
            raise OrbitValueError("epoch: an OEM needs absolute epochs; this table has no epoch")
        fr = str(frame).upper()
        if fr not in ("GCRF", "EME2000"):
            raise OrbitValueError(f"frame: expected 'GCRF' or 'EME2000', got {frame!r}")
        st = self.node_states
        if fr == "EME2000":
            from .frames import gcrs_to_eme2000

            st[:, :3] = gcrs_to_eme2000(st[:, :3])
            st[:, 3:] = gcrs_to_eme2000(st[:, 3:])
        with offline_iers():
            times = self.absolute_times(self.node_times)
            times.precision = 9
            stamps = list(times.isot)
            now = format_epoch(__import__("astropy.time", fromlist=["Time"]).Time.now())
        lines = [
            "CCSDS_OEM_VERS = 2.0",
            f"CREATION_DATE = {now[:-1]}",
            f"ORIGINATOR = {originator}",
            "",
            "META_START",
            f"OBJECT_NAME = {object_name}",
            f"OBJECT_ID = {object_id}",
            "CENTER_NAME = EARTH",
            f"REF_FRAME = {fr}",
            "TIME_SYSTEM = UTC",
            f"START_TIME = {stamps[0]}",
            f"STOP_TIME = {stamps[-1]}",
            "META_STOP",
            "",
            f"COMMENT {self._source}",
        ]
        for s, row in zip(stamps, st.tolist(), strict=True):
            lines.append(s + " " + " ".join(repr(float(x)) for x in row))
        out = Path(path)
        _atomic_write(out, "\n".join(lines) + "\n")
        return out


def position_derivative(t: Any, r: Any, points: int = 9) -> np.ndarray:
    """dr/dt at the nodes of a table of positions: the derivative of the Lagrange polynomial
    through the ``points`` nearest nodes (centred; shifted inwards at the ends).

    Parameters
    ----------
    t : array_like, shape (n,) [s]
        Strictly increasing node times (any spacing).
    r : array_like, shape (n, 3) [km]
        Positions.
    points : int
        Nodes per polynomial (degree ``points - 1``; fewer when the table is shorter).

    Returns
    -------
    numpy.ndarray, shape (n, 3) [km/s]

    Notes
    -----
    With L_j the Lagrange basis of the window's nodes t_k and t_c the node itself,
    L_j'(t_c) = Π_{k≠j,c}(t_c − t_k) / Π_{k≠j}(t_j − t_k) for j ≠ c, and
    L_c'(t_c) = −Σ_{j≠c} L_j'(t_c) (the weights of a derivative sum to zero). The error on a
    uniform grid of spacing h is O(h^(points−1) |r^(points)|): 1.6e-11 km/s inside a LEO table
    at h = 60 s, 1e-9 km/s at its first and last node (tests/test_ephemeris.py).
    """
    t = np.asarray(t, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    n = t.size
    m = min(int(points), n)
    start = np.clip(np.arange(n) - (m - 1) // 2, 0, n - m)
    c = np.arange(n) - start  # the node's place in its window
    win = start[:, None] + np.arange(m)  # (n, m)
    d = t[win] - t[:, None]  # t_k - t_c, zero at k = c
    rows = np.arange(n)
    w = np.zeros((n, m))
    for j in range(m):
        num, den = np.ones(n), np.ones(n)
        for k in range(m):
            if k != j:
                den *= d[:, j] - d[:, k]
                num *= np.where(c == k, 1.0, -d[:, k])
        w[:, j] = np.where(c == j, 0.0, num / den)
    w[rows, c] = -w.sum(axis=1)  # the weights of a derivative sum to zero
    out = np.zeros((n, 3))
    for j in range(m):
        out += w[:, j, None] * r[win[:, j]]
    return out


def _sec() -> Any:
    from astropy import units as u

    return u.s
