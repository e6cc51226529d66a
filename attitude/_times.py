"""Equally spaced output times generated on demand: :class:`TimeGrid`.

A scenario's ``[time]`` table describes up to 1e9 equally spaced samples. Holding them as an
array costs 8 bytes a sample (8 GB at the limit) before anything is computed; a
:class:`TimeGrid` holds three numbers and gives any slice on request, bit for bit the values of
``numpy.linspace(start, stop, n)``, so a streamed run (``attitude run``) needs memory for one
chunk of times only. Everywhere an array of times is accepted, a grid is too (``np.asarray``
materialises it).
"""

from __future__ import annotations

import math
import operator
from typing import Any

import numpy as np
from numpy.lib.mixins import NDArrayOperatorsMixin

from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["TimeGrid", "seconds_of"]


class TimeGrid(NDArrayOperatorsMixin):
    """The times ``numpy.linspace(start, stop, n)[:length]``, computed a slice at a time.

    Parameters
    ----------
    start, stop : float
        First and last time of the full grid (finite; ``stop > start`` when ``n > 1``).
    n : int
        Number of samples of the full grid (>= 1).
    length : int, optional
        Keep only the first ``length`` samples (default ``n``; see :meth:`truncated`).

    Raises
    ------
    AttitudeValueError
        Non-finite bounds, a span that overflows, or a spacing too small to keep consecutive
        times distinct in double precision.

    Notes
    -----
    Behaves as a read-only 1-D float64 array for ``len``, ``shape``, indexing and slicing
    (slices are ndarrays), ``np.asarray`` and numpy arithmetic (both materialise).
    """

    __array_priority__ = 10.0

    def __init__(self, start: float, stop: float, n: int, length: int | None = None):
        try:
            n = operator.index(n)
        except TypeError:
            raise AttitudeTypeError(
                f"n: expected an integer number of samples, got {n!r}"
            ) from None
        start, stop = float(start), float(stop)
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise AttitudeValueError(
                f"times: start and stop must be finite, got {start!r}, {stop!r}"
            )
        if n < 1:
            raise AttitudeValueError(f"n: needs at least one sample, got {n}")
        delta = stop - start
        if n > 1:
            if not math.isfinite(delta):
                raise AttitudeValueError(
                    f"times: the span stop - start = {stop!r} - {start!r} overflows double "
                    "precision; give start and stop closer together"
                )
            if not delta > 0:
                raise AttitudeValueError(
                    f"times: stop must be after start, got {start!r}, {stop!r}"
                )
            step = delta / (n - 1)
            # Consecutive times must stay distinct (strictly increasing) after rounding.
            ulp = float(np.spacing(max(abs(start), abs(stop))))
            if not step > 4.0 * ulp:
                raise AttitudeValueError(
                    f"times: a spacing of {step!r} between {start!r} and {stop!r} is below the "
                    f"resolution of double precision there ({ulp:.3g}); use fewer samples or "
                    "times closer to 0"
                )
        self.start = start
        self.stop = stop
        self.n = n
        self._delta = delta
        self._div = n - 1
        self.length = n if length is None else int(length)
        if not 1 <= self.length <= n:
            raise AttitudeValueError(f"length: must be in 1..{n}, got {length!r}")

    # -- array protocol ----------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int]:
        return (self.length,)

    @property
    def size(self) -> int:
        return self.length

    ndim = 1
    dtype = np.dtype(np.float64)

    @property
    def nbytes(self) -> int:
        """Bytes the materialised array would take."""
        return 8 * self.length

    def __len__(self) -> int:
        return self.length

    def values(self, i0: int, i1: int) -> np.ndarray:
        """The times of samples ``i0 .. i1 - 1`` (0 <= i0 <= i1 <= len), as numpy.linspace."""
        y = np.arange(i0, i1, dtype=np.float64)
        if self._div > 0:
            step = self._delta / self._div
            if step == 0:  # denormal spacing (numpy.linspace, gh-5437); unreachable here
                y /= self._div
                y *= self._delta
            else:
                y *= step
        else:
            y *= self._delta
        y += self.start
        if self.n > 1 and i1 == self.n and i1 > i0:
            y[-1] = self.stop
        return y

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, slice):
            i0, i1, st = key.indices(self.length)
            if st == 1:
                return self.values(i0, max(i0, i1))
            return np.asarray(self)[key]
        try:
            i = operator.index(key)
        except TypeError:
            return np.asarray(self)[key]
        if i < 0:
            i += self.length
        if not 0 <= i < self.length:
            raise IndexError(f"index {key} is out of bounds for {self.length} times")
        return np.float64(self.values(i, i + 1)[0])

    def __iter__(self):
        for i0 in range(0, self.length, 65536):
            yield from self.values(i0, min(self.length, i0 + 65536))

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        arr = self.values(0, self.length)
        return arr if dtype is None else arr.astype(dtype)

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        args = [np.asarray(x) if isinstance(x, TimeGrid) else x for x in inputs]
        return getattr(ufunc, method)(*args, **kwargs)

    # -- grids --------------------------------------------------------------------------------
    def head(self, limit: float) -> TimeGrid:
        """The leading samples ``<= limit`` (the same values); an error if there are none."""
        if self.length == 1 or self.n == 1:
            k = 1 if self.start <= limit else 0
        else:
            step = self._delta / self._div
            est = (limit - self.start) / step + 1.0
            k = int(min(self.length, max(0.0, math.floor(est)))) if math.isfinite(est) else 0
            if est >= self.length:
                k = self.length
            while k < self.length and self[k] <= limit:
                k += 1
            while k > 0 and self[k - 1] > limit:
                k -= 1
        if k == 0:
            raise AttitudeValueError(f"limit: {limit!r} is before the first time {self.start!r}")
        return TimeGrid(self.start, self.stop, self.n, k)

    def __repr__(self) -> str:
        tail = "" if self.length == self.n else f", length={self.length}"
        return f"TimeGrid(start={self.start!r}, stop={self.stop!r}, n={self.n}{tail})"


def seconds_of(text: str) -> float:
    """A duration written with its time unit (``"10min"``, ``"1.5 h"``, ``"600 s"``) in
    seconds; NaN for anything else (a plain number has no unit to say what it counts)."""
    from astropy import units as u

    try:
        q = u.Quantity(str(text).strip())
        return float(q.to_value(u.s)) if q.unit != u.dimensionless_unscaled else math.nan
    except (TypeError, ValueError, u.UnitsError):
        return math.nan
