"""Epochs, time scales and the IERS Earth-orientation data, all through astropy.

An orbit's ``epoch`` is an :class:`astropy.time.Time`; orbit times ``t`` are elapsed SI seconds
since it. Leap seconds, TAI, TT, GPS: astropy (ERFA) does the arithmetic; there is no
hand-written leap-second table here.

Earth orientation (UT1 − UTC, polar motion, celestial-pole offsets) comes from the IERS-A table
bundled with ``astropy-iers-data`` (``finals2000A.all``: IERS Bulletin B values for the past,
Bulletin A predictions for about a year after the file was made), **never from the network**:
every astropy call that needs it runs inside :func:`offline_iers`, which

* sets ``astropy.utils.iers.conf.auto_download = False`` (machines have no network; an
  attempted download would wait for a timeout and fail);
* uses a plain :class:`astropy.utils.iers.IERS_A` table, not astropy's default ``IERS_Auto``,
  whose "predictive values more than 30 days old" check raises for any date past the start of
  the predictions once the bundled file is a month old and the download has failed;
* sets ``iers_degraded_accuracy = "ignore"`` and instead checks the times itself
  (:func:`check_iers_range`): times beyond the table (before 1973 or after its last
  prediction) give one :class:`IERSRangeWarning` naming the first such time and the table's
  end, and the last tabulated values are used there.

``set_iers_table(path)`` replaces the bundled table with a newer ``finals2000A.all`` the user
downloaded themselves.
"""

from __future__ import annotations

import datetime as _dt
import math
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from .errors import OrbitTypeError, OrbitValueError

__all__ = [
    "DATE_RANGE",
    "IERSRangeWarning",
    "as_epoch",
    "check_dates",
    "check_iers_range",
    "format_epoch",
    "iers_table",
    "offline_iers",
    "same_epoch",
    "set_iers_table",
    "ut1_minus_utc",
]

#: Time scales accepted in an epoch string suffix ("2024-01-01T00:00:00 TT").
SCALES = ("UTC", "TAI", "TT", "TDB", "GPS")
#: GPS time = TAI − 19 s (constant since 1980; IS-GPS-200).
GPS_MINUS_TAI = -19.0


#: The dates the package computes with (UTC): every epoch, and epoch + t wherever a date is
#: needed (Earth-fixed positions, the Sun, the geomagnetic field, the atmosphere). UTC has
#: leap seconds from 1960, the IERS table runs from 1973, IGRF from 1900; astropy/ERFA warn of
#: "dubious years" outside, and fail or run out of memory for absurd ones (t = 9.2e18 s).
DATE_RANGE = ("1900-01-01", "2200-01-01")
_JD_RANGE = (2415020.5, 2524593.5)  # the Julian dates of DATE_RANGE


def check_dates(epoch: Any, t: Any, name: str = "t") -> None:
    """Raise :class:`OrbitValueError` (naming ``name``) if ``epoch + t`` leaves
    :data:`DATE_RANGE` (``t`` in seconds; plain arithmetic on Julian dates, no astropy call)."""
    arr = np.asarray(t, dtype=np.float64)
    if epoch is None or arr.size == 0:
        return
    jd = float(epoch.jd1) + float(epoch.jd2)
    lo, hi = float(np.min(arr)), float(np.max(arr))
    for s, edge in ((lo, "start"), (hi, "end")):
        j = jd + s / 86400.0
        if not (_JD_RANGE[0] <= j <= _JD_RANGE[1]):
            year = 2000.0 + (j - 2451545.0) / 365.25 if math.isfinite(j) else j
            with quiet_erfa():  # (the epoch itself may be past ERFA's leap-second table)
                iso = epoch.utc.isot[:19]
            raise OrbitValueError(
                f"{name}: {s!r} s from the epoch {iso} is the year {year:.6g}; "
                f"dates are accepted from {DATE_RANGE[0]} to {DATE_RANGE[1]} (time scales, "
                f"Earth orientation and the Sun are defined there): the run's {edge} is outside"
            )


class IERSRangeWarning(UserWarning):
    """Times lie outside the IERS Earth-orientation table: degraded Earth-fixed accuracy."""


_TABLE: list[Any] = []


def iers_table() -> Any:
    """The IERS table used for UT1 − UTC and polar motion (bundled IERS-A unless replaced)."""
    if not _TABLE:
        _TABLE.append(_bundled_table())
    return _TABLE[0]


def _bundled_table() -> Any:
    """The bundled IERS-A table, parsed once per installation: astropy's reader of the 20 000
    lines takes 0.4–0.7 s of every process that needs Earth orientation; the parsed table is
    kept pickled in the cache (:func:`orbit._shared_jit.data_cache_dir`), keyed on the file, its
    size and time and the astropy and Python versions, and loads in ~20 ms."""
    import hashlib
    import os
    import pickle
    import sys
    import tempfile

    import astropy
    from astropy.utils import iers

    from ._shared_jit import data_cache_dir

    src = os.path.realpath(iers.IERS_A_FILE)
    try:
        st = os.stat(src)
    except OSError:
        return iers.IERS_A.open(iers.IERS_A_FILE)  # (astropy says what is missing)
    key = f"{src}|{st.st_size}|{st.st_mtime_ns}|{astropy.__version__}|{sys.version_info[:2]}"
    path = data_cache_dir() / f"iers-a-{hashlib.sha256(key.encode()).hexdigest()[:16]}.pickle"
    try:
        with open(path, "rb") as fh:
            table = pickle.load(fh)
        if isinstance(table, iers.IERS_A):
            return table
    except Exception:  # (absent, unreadable or corrupt: parse the file again)
        pass
    table = iers.IERS_A.open(iers.IERS_A_FILE)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(table, fh, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, path)  # (whole or not at all: another process may be reading)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except OSError:
        pass  # (a read-only cache: parse it again next time)
    return table


def set_iers_table(table: Any = None) -> None:
    """Use another IERS table: a path to a ``finals2000A.all`` file, an astropy ``IERS`` table,
    or None for the bundled one."""
    from astropy.utils import iers

    if table is None:
        _TABLE.clear()
        return
    if isinstance(table, iers.IERS):
        t = table
    else:
        try:
            t = iers.IERS_A.open(str(table))
        except (OSError, ValueError) as exc:
            raise OrbitValueError(
                f"table: cannot read an IERS-A file from {table!r}: {exc}"
            ) from None
    _TABLE[:] = [t]


@contextmanager
def offline_iers() -> Iterator[None]:
    """Run astropy time/frame code with our IERS policy (no network, no 30-day check)."""
    from astropy.utils import iers

    with (
        iers.conf.set_temp("auto_download", False),
        iers.conf.set_temp("iers_degraded_accuracy", "ignore"),
        iers.earth_orientation_table.set(iers_table()),
        quiet_erfa(),
    ):
        yield


@contextmanager
def quiet_erfa() -> Iterator[None]:
    """ERFA's "dubious year" warnings silenced (UTC dates before 1960 or a few years past its
    leap-second table), and astropy's about polar motion outside the IERS table: the dates are
    checked against :data:`DATE_RANGE`, and Earth-fixed computations warn once with
    :class:`IERSRangeWarning` where the accuracy degrades."""
    from astropy.utils.exceptions import AstropyWarning
    from erfa import ErfaWarning

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", r".*dubious year", ErfaWarning)
        warnings.filterwarnings("ignore", r"Tried to get polar motions", AstropyWarning)
        yield


def check_iers_range(times: Any, name: str = "t") -> None:
    """Warn (:class:`IERSRangeWarning`) if some of ``times`` lie outside the IERS table."""
    tab = iers_table()
    mjd = np.atleast_1d(np.asarray(times.utc.mjd, dtype=np.float64))
    if mjd.size == 0:
        return
    lo, hi = float(tab["MJD"][0].value), float(tab["MJD"][-1].value)
    bad = (mjd < lo) | (mjd > hi)
    if np.any(bad):
        from astropy.time import Time

        first = Time(float(mjd[np.argmax(bad)]), format="mjd", scale="utc").isot
        warnings.warn(
            f"{name}: {int(bad.sum())} time(s), the first {first} UTC, lie outside the IERS "
            f"Earth-orientation table ({Time(lo, format='mjd').iso[:10]} to "
            f"{Time(hi, format='mjd').iso[:10]}); UT1 − UTC is held at the table's last value "
            "and polar motion falls back to astropy's 50-year mean there, so Earth-fixed "
            "positions (ITRS, geodetic) degrade by "
            "roughly 0.5 m per day beyond the table (UT1 drifts ~1 ms/day). Give a newer "
            "finals2000A.all with orbit.timescales.set_iers_table(path).",
            IERSRangeWarning,
            stacklevel=3,
        )


def ut1_minus_utc(time: Any) -> np.ndarray:
    """UT1 − UTC [s] that this package's frame conversions use at ``time`` (astropy Time)."""
    with offline_iers():
        check_iers_range(time, "time")
        u = time.utc
        return np.asarray(u.get_delta_ut1_utc(), dtype=np.float64)


def _parse_string(s: str, name: str) -> Any:
    from astropy.time import Time

    text = s.strip()
    scale = "UTC"
    parts = text.split()
    if len(parts) == 2 and parts[1].upper() in SCALES:
        text, scale = parts[0], parts[1].upper()
    elif len(parts) != 1:
        raise OrbitValueError(
            f"{name}: {s!r} is not an ISO 8601 time; write e.g. '2024-03-20T12:00:00' (UTC), "
            f"optionally followed by a scale: {', '.join(SCALES)}"
        )
    if text.endswith("Z"):
        if scale != "UTC":
            raise OrbitValueError(f"{name}: {s!r} has a 'Z' (UTC) and a {scale} scale")
        text = text[:-1]
    from erfa import ErfaWarning

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ErfaWarning)
            warnings.filterwarnings("ignore", r".*dubious year", ErfaWarning)
            if scale == "GPS":
                t = Time(text, scale="tai") - GPS_MINUS_TAI * _sec()
                t = Time(t, scale="tai")
            else:
                t = Time(text, scale=scale.lower())
        for w in caught:
            if "end of day" in str(w.message):
                raise OrbitValueError(
                    f"{name}: {s!r} is not a time: a second 60 exists only at the end of a UTC "
                    "day with a leap second (e.g. 2016-12-31T23:59:60), and this day had none"
                )
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return t
    except (ValueError, TypeError) as exc:
        if isinstance(exc, OrbitValueError):
            raise
        raise OrbitValueError(
            f"{name}: astropy cannot read {s!r} as a time; write ISO 8601 like "
            f"'2024-03-20T12:00:00' (UTC), or '2024-03-20T12:00:00 TT' ({', '.join(SCALES)})"
        ) from None


def _sec() -> Any:
    from astropy import units as u

    return u.s


def as_epoch(value: Any, name: str = "epoch", *, allow_none: bool = True) -> Any:
    """An astropy Time from a Time, an ISO 8601 string (UTC unless a scale follows) or a
    datetime (naive = UTC); None passes through.

    Raises
    ------
    OrbitValueError
        The string cannot be read, the Time is not a scalar, or it is not finite.
    OrbitTypeError
        Any other type.
    """
    from astropy.time import Time

    if value is None:
        if allow_none:
            return None
        raise OrbitValueError(f"{name}: a time is needed (an astropy Time or ISO 8601 string)")
    if isinstance(value, Time):
        t = value
    elif isinstance(value, str):
        t = _parse_string(value, name)
    elif isinstance(value, _dt.datetime):
        v = value if value.tzinfo is None else value.astimezone(_dt.timezone.utc)
        t = Time(v.replace(tzinfo=None), scale="utc")
    else:
        raise OrbitTypeError(
            f"{name}: expected an astropy Time or an ISO 8601 string such as "
            f"'2024-03-20T12:00:00', got {type(value).__name__}"
        )
    if not t.isscalar:
        raise OrbitValueError(f"{name}: expected a single time, got {t.shape} times")
    if not (math.isfinite(float(t.jd1)) and math.isfinite(float(t.jd2))):
        raise OrbitValueError(f"{name}: not a finite time ({value!r})")
    jd = float(t.jd1) + float(t.jd2)
    if not _JD_RANGE[0] <= jd <= _JD_RANGE[1]:
        raise OrbitValueError(
            f"{name}: {value!r} is outside the dates the package computes with, "
            f"{DATE_RANGE[0]} to {DATE_RANGE[1]}"
        )
    return t


def format_epoch(t: Any) -> str:
    """UTC ISO 8601 with a trailing Z, microseconds (nanoseconds when they are needed)."""
    with quiet_erfa():
        return _format_epoch(t)


def _format_epoch(t: Any) -> str:
    u = t.utc
    c = u.copy()
    c.precision = 6
    s6 = c.isot
    from astropy.time import Time

    back = Time(s6, scale="utc")
    if abs(float((back - u).sec)) > 5e-10:
        c.precision = 9
        s6 = c.isot
    return s6 + "Z"


def same_epoch(a: Any, b: Any, tol: float = 1e-9) -> bool:
    """Whether two epochs are the same instant (to ``tol`` seconds)."""
    return abs(float((a - b).sec)) <= tol


def seconds_since(epoch: Any, times: Any) -> np.ndarray:
    """Elapsed SI seconds from ``epoch`` to ``times`` (astropy Time arrays)."""
    d = times - epoch
    return np.asarray(d.sec, dtype=np.float64)
