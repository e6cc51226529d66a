"""Hermite tables of positions sampled once through astropy, read in compiled code.

Quantities that do not depend on the attitude — the Sun's geocentric position
(:mod:`orbit.sun`), a ground station's position in the GCRS (``attitude.frames.target``) — are
computed **once, vectorised**, by astropy on a uniform time grid that covers a run, and
interpolated in compiled code; hot loops never call astropy.

A table has exactly the layout of an ephemeris orbit (:mod:`orbit._state_kernels`,
``TYPE_EPHEMERIS``: type code, an unused μ slot, the valid span, N, the spacing h, the node
times, then rows x, y, z, vx, vy, vz), so ``orbit._state_kernels.orbit_state(table, t)`` reads
it: the degree-7 Hermite polynomial through the 4 nodes around t, matching positions and
velocities. Error per component (Hermite remainder): ``<= 7.8e-6 h⁸ max|x⁽⁸⁾|`` in the inner
intervals; the grid runs ``margin`` steps beyond the requested span on each side so the
requested span never uses the end intervals.

Velocities are 5-point central differences of the sampled positions with spacing ``delta``
(default h/60): truncation ``delta⁴/30 max|x⁽⁵⁾|``, rounding ``~eps max|x| / delta``. For the
Sun (|x| = 1.5e8 km, turning at 2e-7 rad/s) at h = 3600 s that is 5e-10 km/s; for a ground
station (6378 km at 7.3e-5 rad/s) at h = 600 s, 1e-13 km/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from . import _state_kernels as _sk
from .errors import OrbitValueError

__all__ = ["MAX_NODES", "evaluate", "tabulate"]

#: Most nodes of a table sampled through astropy or SGP4 (an ephemeris, the Sun, a ground
#: station, the environment along an orbit): a span too long for its step is refused before
#: anything is computed (t = [0, 1e12] asked numpy for 248 GiB).
MAX_NODES = 10_000_000


def tabulate(
    positions: Callable[[np.ndarray], np.ndarray],
    start: float,
    stop: float,
    step: float,
    *,
    delta: float | None = None,
    margin: int = 2,
) -> np.ndarray:
    """A Hermite table (ephemeris layout) of ``positions`` over [start, stop].

    Parameters
    ----------
    positions : callable
        ``positions(t) -> (k, 3)`` [km] for seconds ``t`` (k,) since the table's time origin;
        called once, vectorised, on the grid and its difference stencil.
    start, stop : float
        Span the table must cover [s].
    step : float
        Grid spacing h [s].
    delta : float, optional
        Spacing of the velocity stencil (default h/60).
    margin : int
        Extra nodes beyond each end (default 2: the span then uses inner intervals only).

    Returns
    -------
    ndarray, shape (8 + 7N,)
        Kernel data read by ``orbit._state_kernels.orbit_state`` (positions and velocities).
    """
    start, stop, step = float(start), float(stop), float(step)
    if not (math.isfinite(start) and math.isfinite(stop)) or stop < start:
        raise OrbitValueError(f"start, stop: expected a finite span, got [{start}, {stop}]")
    if not step > 0:
        raise OrbitValueError(f"step: must be positive, got {step}")
    n = math.ceil((stop - start) / step) + 1 + 2 * int(margin)
    n = max(n, 4)
    if n > MAX_NODES:
        raise OrbitValueError(
            f"t: a table over [{start:.6g}, {stop:.6g}] s every {step:g} s would have {n:.3g} "
            f"nodes, more than {MAX_NODES}; shorten the span"
        )
    t = start - margin * step + step * np.arange(n, dtype=np.float64)
    dl = step / 60.0 if delta is None else float(delta)
    offs = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) * dl
    tt = (t[:, None] + offs[None, :]).ravel()
    x = np.asarray(positions(tt), dtype=np.float64).reshape(n, 5, 3)
    pos = x[:, 2]
    vel = (x[:, 0] - 8.0 * x[:, 1] + 8.0 * x[:, 3] - x[:, 4]) / (12.0 * dl)
    d = np.empty(_sk.E_TIMES + 7 * n)
    d[_sk.TYPE] = _sk.TYPE_EPHEMERIS
    d[_sk.MU] = 0.0  # unused: a table of positions, not an orbit
    d[_sk.T_MIN] = t[0]
    d[_sk.T_MAX] = t[-1]
    d[_sk.E_N] = n
    d[_sk.E_H] = step
    d[_sk.E_H + 1 : _sk.E_TIMES] = 0.0
    d[_sk.E_TIMES : _sk.E_TIMES + n] = t
    rows = np.concatenate([pos, vel], axis=1)
    d[_sk.E_TIMES + n :] = rows.ravel()
    return d


def evaluate(data: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Positions and velocities (k, 6) of a table at seconds ``t`` (NaN outside its span)."""
    flat = np.ascontiguousarray(np.asarray(t, dtype=np.float64).ravel())
    out = np.empty((flat.size, 6))
    _sk.state_loop(data, flat, out)
    return out.reshape((*np.shape(t), 6))
