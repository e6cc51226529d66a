"""The space environment along an orbit, computed once per run with the reference libraries.

What the environment torques need and what does not depend on the attitude is evaluated here,
vectorised, on a uniform time grid spanning the run (:class:`Grid`), and packed into tables
that the compiled right-hand side interpolates (:mod:`attitude._core.environment`):

* the geomagnetic field in the space frame (GCRS), from IGRF-14 through ``ppigrf`` at the ITRS
  positions, or the tilted dipole of the same IGRF coefficients (closed form); rotated from
  the ITRS by astropy (:func:`orbit.frames.gcrs_to_itrs_matrix`, offline IERS policy);
* the atmospheric density from NRLMSIS 2.1 through ``pymsis`` with the space-weather indices
  *given* (never fetched), or Vallado's exponential model; the velocity relative to an
  atmosphere co-rotating with the Earth, v − ω⊕ × r;
* the Sun: its apparent position from astropy (:mod:`orbit.sun`) relative to the satellite,
  and the satellite's own position for the Earth's shadow, evaluated in the compiled kernel.

Nothing here runs inside the integrator. ``ppigrf`` and ``pymsis`` are imported only by the
functions that use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ._core import environment as _ke
from .errors import AttitudeValueError

__all__ = [
    "AP_RANGE",
    "AU_KM",
    "DEFAULT_STEP",
    "F107_RANGE",
    "FOLD_TOLERANCE",
    "OMEGA_EARTH",
    "P_SUN_1AU",
    "SOLAR_IRRADIANCE",
    "VALLADO_EXPONENTIAL",
    "Grid",
    "dipole_field_itrs",
    "earth_disk_larger",
    "exponential_density",
    "folds_density",
    "grid",
    "igrf_dipole_coefficients",
    "igrf_field_itrs",
    "magnetic_field_gcrs",
    "msis_density",
    "pack_segment",
    "pack_table",
    "relative_velocity",
    "sun_relative",
    "sun_shadow",
    "table",
    "table_by_utc_day",
]

#: Default node spacing of the environment tables [s] (docs/potentials.md: the measured
#: interpolation errors are below 1e-6 relative at this spacing in LEO).
DEFAULT_STEP = 30.0
#: Spacing [s] of the Sun's positions from astropy, interpolated to the nodes of a grid.
SUN_STEP = 3600.0
#: Spacing [s] of astropy's GCRS → ITRS matrices (the Earth rotation angle is exact at every
#: node; :func:`orbit.frames.gcrs_to_itrs_matrix`).
ROTATION_STEP = 600.0
#: Earth's rotation rate [rad/s] (WGS 84; the IERS nominal value).
OMEGA_EARTH = 7.292115e-5
#: Total solar irradiance at 1 AU [W/m²] (IAU 2015 Resolution B3 nominal value).
SOLAR_IRRADIANCE = 1361.0
#: Solar radiation pressure at 1 AU [N/m²]: irradiance / c.
P_SUN_1AU = SOLAR_IRRADIANCE / 299_792_458.0
#: Astronomical unit [km] (IAU 2012 Resolution B2, exact).
AU_KM = 149_597_870.7
#: Accepted F10.7 and F10.7a [sfu] (solar flux units, 1e-22 W m⁻² Hz⁻¹): the range of
#: observed daily values (solar minimum ≈ 65, the largest daily values ≈ 400), where NRLMSIS
#: is fitted; outside it the model would extrapolate.
F107_RANGE = (50.0, 400.0)
#: Accepted Ap: the ap/Ap scale is defined from 0 to 400.
AP_RANGE = (0.0, 400.0)

#: Vallado (2013), *Fundamentals of Astrodynamics and Applications*, 4th ed., Table 8-4:
#: exponential atmosphere, rows (base height h0 [km], ρ0 [kg/m³], scale height H [km]);
#: ρ(h) = ρ0 exp(−(h − h0)/H) in the band h0 <= h < next h0 (the last band above 1000 km).
VALLADO_EXPONENTIAL = np.array(
    [
        (0.0, 1.225, 7.249),
        (25.0, 3.899e-2, 6.349),
        (30.0, 1.774e-2, 6.682),
        (40.0, 3.972e-3, 7.554),
        (50.0, 1.057e-3, 8.382),
        (60.0, 3.206e-4, 7.714),
        (70.0, 8.770e-5, 6.549),
        (80.0, 1.905e-5, 5.799),
        (90.0, 3.396e-6, 5.382),
        (100.0, 5.297e-7, 5.877),
        (110.0, 9.661e-8, 7.263),
        (120.0, 2.438e-8, 9.473),
        (130.0, 8.484e-9, 12.636),
        (140.0, 3.845e-9, 16.149),
        (150.0, 2.070e-9, 22.523),
        (180.0, 5.464e-10, 29.740),
        (200.0, 2.789e-10, 37.105),
        (250.0, 7.248e-11, 45.546),
        (300.0, 2.418e-11, 53.628),
        (350.0, 9.518e-12, 53.298),
        (400.0, 3.725e-12, 58.515),
        (450.0, 1.585e-12, 60.828),
        (500.0, 6.967e-13, 63.822),
        (600.0, 1.454e-13, 71.835),
        (700.0, 3.614e-14, 88.667),
        (800.0, 1.170e-14, 124.64),
        (900.0, 5.245e-15, 181.05),
        (1000.0, 3.019e-15, 268.00),
    ]
)


# --------------------------------------------------------------------------------------------
# The time grid
# --------------------------------------------------------------------------------------------


@dataclass(eq=False)
class Grid:
    """Uniform node times along an orbit, with the orbit's geometry evaluated lazily (and once).

    Attributes
    ----------
    orbit : orbit.Orbit
        With an epoch (the environment is dated).
    t : ndarray, shape (n,)
        Node times [s since the epoch], uniform spacing ``h``.
    h : float
        Spacing [s].
    lo, hi : float
        The times the tables built on this grid serve (the nodes may start and end up to one
        step inside: the edge windows extrapolate that far).
    """

    orbit: Any
    t: np.ndarray
    h: float
    lo: float
    hi: float
    _memo: dict[str, Any] = field(default_factory=dict, repr=False)

    @cached_property
    def times(self) -> Any:
        """The node times as an astropy Time (UTC)."""
        return self.orbit.absolute_times(self.t)

    @cached_property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """GCRS position [km] and velocity [km/s] at the nodes, shape (n, 3) each."""
        return self.orbit.to_state(self.t)

    @cached_property
    def rotation(self) -> np.ndarray:
        """R(t) (n, 3, 3): x_ITRS = R x_GCRS (astropy every 600 s, the Earth rotation angle
        at every node: :func:`orbit.frames.gcrs_to_itrs_matrix`, 2e-12 rad)."""
        from orbit.frames import gcrs_to_itrs_matrix

        return gcrs_to_itrs_matrix(self.times, "t", step=ROTATION_STEP)

    @cached_property
    def itrs_position(self) -> np.ndarray:
        """ITRS (Earth-fixed) position [km], (n, 3)."""
        return np.einsum("nij,nj->ni", self.rotation, self.state[0])

    @cached_property
    def geodetic(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """WGS 84 latitude [rad], longitude [rad], height [km] (astropy/ERFA)."""
        from orbit.frames import geodetic_from_itrs

        return geodetic_from_itrs(self.itrs_position)

    @cached_property
    def datetime64(self) -> np.ndarray:
        """The node times as numpy datetime64[ns] (UTC), for ppigrf and pymsis."""
        return np.asarray(self.times.utc.to_value("datetime64"), dtype="datetime64[ns]")

    @cached_property
    def sun(self) -> np.ndarray:
        """Geocentric apparent Sun [km], GCRS, (n, 3): :func:`orbit.sun.sun_position` every
        :data:`SUN_STEP` seconds, interpolated to the nodes (degree 7; ~1e-6 km)."""
        from orbit.sun import sun_position

        t0, t1 = float(self.t[0]), float(self.t[-1])
        nc = max(_ke.WINDOW, math.ceil((t1 - t0) / SUN_STEP) + 9)
        tc = t0 - 4.0 * SUN_STEP + SUN_STEP * np.arange(nc, dtype=np.float64)
        if tc.size >= self.t.size:
            return sun_position(self.orbit.epoch, self.t)
        tab = table(
            Grid(self.orbit, tc, SUN_STEP, tc[0], tc[-1]), sun_position(self.orbit.epoch, tc)
        )
        out = np.empty((self.t.size, 3))
        _ke.table_loop(np.ascontiguousarray(self.t), tab, 0, out)
        return out


#: Grids of recent runs (the terms of one model share one): {(orbit id, lo, hi, step): Grid}.
_GRIDS: dict[tuple, Grid] = {}
_GRIDS_MAX = 8


def _utc_fraction(epoch: Any) -> float:
    """Fraction of a second of the epoch in UTC (0 for a whole second)."""
    sec = float(epoch.utc.ymdhms["second"])
    return sec - math.floor(sec)


def grid_times(orbit: Any, lo: float, hi: float, step: float) -> tuple[np.ndarray, float, float]:
    """(nodes, a, b): node times serving [a, b] = [lo, hi] padded by 4 steps where the orbit
    allows (so every time of the run sits in a centred interpolation window).

    With a whole number of seconds as the step, the nodes fall on whole UTC seconds (pymsis
    reads the time of day in whole seconds: nodes there see the model without that rounding);
    otherwise they divide [a, b] evenly. At least 8 nodes, at most ``step`` apart.
    """
    from orbit.errors import OrbitError
    from orbit.tables import MAX_NODES
    from orbit.timescales import check_dates

    pad = 4.0 * step
    span_lo, span_hi = orbit.time_span
    a, b = max(lo - pad, span_lo), min(hi + pad, span_hi)
    epoch = getattr(orbit, "epoch", None)
    if (b - a) / step + 1.0 > MAX_NODES:
        raise AttitudeValueError(
            f"t: the environment along the orbit is tabulated every {step:g} s (the model's "
            f"step) over the run's {hi - lo:.6g} s: {(b - a) / step:.3g} nodes, more than "
            f"{MAX_NODES}; shorten the run or give the model a larger step"
        )
    try:
        check_dates(epoch, [a, b], "t")
    except OrbitError as exc:
        raise AttitudeValueError(str(exc)) from None
    if epoch is not None and step == round(step) and b - a >= 7.0 * step:
        f = _utc_fraction(epoch)
        k0 = math.ceil((a + f) / step - 1e-9)
        k1 = math.floor((b + f) / step + 1e-9)
        if k1 - k0 + 1 >= _ke.WINDOW:
            return np.arange(k0, k1 + 1, dtype=np.float64) * step - f, a, b
    n = max(_ke.WINDOW, math.ceil((b - a) / step - 1e-9) + 1)
    return np.linspace(a, b, n), a, b


def grid(orbit: Any, lo: float, hi: float, step: float) -> Grid:
    """The :class:`Grid` of the run [lo, hi] (shared by the models of one run)."""
    key = (id(orbit), float(lo), float(hi), float(step))
    g = _GRIDS.get(key)
    if g is not None and g.orbit is orbit:
        return g
    t, a, b = grid_times(orbit, lo, hi, step)
    g = Grid(orbit, t, float(t[1] - t[0]), a, b)
    if len(_GRIDS) >= _GRIDS_MAX:
        _GRIDS.pop(next(iter(_GRIDS)))
    _GRIDS[key] = g
    return g


def pack_segment(t: np.ndarray, values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """One segment (layout of :mod:`attitude._core.environment`): ``values`` (n, ncomp) at the
    uniform node times ``t`` (n,), valid on [lo, hi]; n = 1 is a constant."""
    v = np.ascontiguousarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    n, ncomp = v.shape
    h = float(t[1] - t[0]) if n > 1 else 0.0
    inv_h = 1.0 / h if n > 1 else 0.0
    head = _ke.SEG.pack(n=n, h=h, inv_h=inv_h, ncomp=ncomp, lo=lo, hi=hi)
    return np.concatenate([head, np.asarray(t, dtype=np.float64), v.ravel()])


def pack_table(segments: list[np.ndarray]) -> np.ndarray:
    """A table of consecutive segments (each from :func:`pack_segment`)."""
    nseg = len(segments)
    offsets, at = [], 1 + nseg
    for seg in segments:
        offsets.append(at)
        at += seg.size
    return np.concatenate([[nseg, *offsets], *segments]).astype(np.float64)


#: Largest difference [relative to max |√ρ v|] between the interpolants of √ρ v and of v and
#: ln ρ apart at which the drag table holds √ρ v (:func:`folds_density`): below the precision
#: of the densities themselves (pymsis runs NRLMSIS in single precision: ~3e-6 rms in ρ, so
#: ~1.5e-6 in √ρ), and of the documented interpolation error of the tables.
FOLD_TOLERANCE = 1e-6


def folds_density(plain: np.ndarray, folded: np.ndarray, g: Grid) -> bool:
    """Whether the drag table ``folded`` (√ρ v, ln ρ) interpolates √ρ v as well as ``plain``
    (v, ln ρ) gives it: compared half-way between the nodes, where interpolation errs most, to
    :data:`FOLD_TOLERANCE`. Near-circular orbits pass (ρ changes by a few percent per node);
    fast passes through a steep atmosphere, where √ρ is far from a polynomial over the window,
    keep v and ln ρ apart.
    """
    mid = np.ascontiguousarray(0.5 * (g.t[1:] + g.t[:-1]))
    mid = mid[(mid >= g.lo) & (mid <= g.hi)]
    if mid.size == 0:
        return False
    a = np.empty((mid.size, 4))
    b = np.empty((mid.size, 4))
    _ke.table_loop(mid, plain, 0, a)
    _ke.table_loop(mid, folded, 0, b)
    want = a[:, :3] * np.exp(0.5 * a[:, 3:4])
    scale = float(np.max(np.abs(want)))
    return bool(scale > 0.0 and np.max(np.abs(b[:, :3] - want)) <= FOLD_TOLERANCE * scale)


def table(g: Grid, values: np.ndarray) -> np.ndarray:
    """A one-segment table of ``values`` at the grid's nodes."""
    return pack_table([pack_segment(g.t, values, g.lo, g.hi)])


def constant_table(values: Any) -> np.ndarray:
    """A table holding a constant row (valid at every time)."""
    v = np.asarray(values, dtype=np.float64)[None, :]
    return pack_table([pack_segment(np.zeros(1), v, -math.inf, math.inf)])


def _day_numbers(dates: np.ndarray) -> np.ndarray:
    return _round_ms(dates).astype("datetime64[D]").astype(np.int64)


def table_by_utc_day(g: Grid, values: Any) -> np.ndarray:
    """A table cut at UTC midnights, for quantities that jump there (``values(grid)`` gives
    the rows at a grid's nodes).

    pymsis hands NRLMSIS the day of year as an integer, so its density jumps at 00:00 UTC (by
    ~0.7 % at 600 km); one segment per UTC day keeps the interpolation off the jump. A segment
    with fewer than 16 of the grid's nodes gets 8 nodes of its own (the last one 1 s before a
    midnight that ends it).
    """
    days = _day_numbers(g.datetime64)
    if days[0] == days[-1]:
        return table(g, values(g))
    from astropy.time import Time

    rows = np.asarray(values(g), dtype=np.float64)
    rows = rows[:, None] if rows.ndim == 1 else rows
    segs = []
    uniq = np.unique(days)
    bounds = [g.lo]
    for d in uniq[1:]:
        midnight = np.datetime64(int(d), "D").astype("datetime64[ns]")
        bounds.append(float((Time(midnight, scale="utc") - g.orbit.epoch).sec))
    bounds.append(g.hi)
    for j, d in enumerate(uniq):
        a, b = bounds[j], bounds[j + 1]
        last = j == len(uniq) - 1
        sel = days == d
        t, v = g.t[sel], rows[sel]
        if t.size >= 2 * _ke.WINDOW:
            if not last and abs(b - t[-1] - g.h) < 1e-6 * g.h:
                # the node at midnight belongs to the next day: give this segment the left
                # limit there, a least-squares degree-7 fit to its last 16 nodes (pymsis runs
                # NRLMSIS in single precision: ~3e-6 rms noise, which a plain extrapolation
                # over a step would amplify ~30-fold)
                x = (t[-16:] - b) / g.h
                coef = np.polynomial.polynomial.polyfit(x, v[-16:], 7)
                t = np.append(t, b)
                v = np.vstack([v, coef[0]])
            segs.append(pack_segment(t, v, a, b))
            continue
        end = b if last else b - min(1.0, (b - a) / _ke.WINDOW)
        tn = np.linspace(a, end, _ke.WINDOW)
        sub = Grid(g.orbit, tn, float(tn[1] - tn[0]), a, b)
        segs.append(pack_segment(tn, values(sub), a, b))
    return pack_table(segs)


# --------------------------------------------------------------------------------------------
# Magnetic field
# --------------------------------------------------------------------------------------------

#: IGRF reference radius [km] (the radius of ppigrf's coefficients).
IGRF_RADIUS = 6371.2


def _shc() -> tuple[Any, Any]:
    from ppigrf import ppigrf as _pp

    if "shc" not in _SHC:
        _SHC["shc"] = _pp.read_shc(_pp.shc_fn)
    return _SHC["shc"]


_SHC: dict[str, Any] = {}


def igrf_epochs() -> np.ndarray:
    """The dates of the IGRF models in ppigrf's coefficient file (datetime64[ns])."""
    g, _ = _shc()
    return np.asarray(g.index.values, dtype="datetime64[ns]")


def check_igrf_dates(dates: np.ndarray, name: str = "orbit") -> None:
    """Raise if some dates lie outside the IGRF-14 coefficients (1900-01-01 to 2030-01-01)."""
    ep = igrf_epochs()
    lo, hi = ep[0], ep[-1]
    if np.any(dates < lo) or np.any(dates > hi):
        bad = dates[(dates < lo) | (dates > hi)][0]
        raise AttitudeValueError(
            f"{name}: the run reaches {np.datetime_as_string(bad, unit='s')} UTC, outside the "
            f"IGRF-14 model ({np.datetime_as_string(lo, unit='D')} to "
            f"{np.datetime_as_string(hi, unit='D')}, the last five years predicted by its "
            "secular variation); the field is undefined there"
        )


def _segment_dates(dates: np.ndarray) -> np.ndarray:
    """The dates at which to evaluate IGRF so that every date lies between two of them inside
    one interval of the coefficient file: the extremes and every IGRF epoch in between."""
    ep = igrf_epochs()
    lo, hi = dates.min(), dates.max()
    inner = ep[(ep > lo) & (ep < hi)]
    return np.unique(np.concatenate([[lo], inner, [hi]]))


def _time_weights(dates: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, s): date i lies between knots k and k + 1 at fraction s (linear in time)."""
    if knots.size == 1:
        return np.zeros(dates.size, dtype=np.int64), np.zeros(dates.size)
    x = dates.astype("int64").astype(np.float64)
    kx = knots.astype("int64").astype(np.float64)
    k = np.clip(np.searchsorted(kx, x, side="right") - 1, 0, kx.size - 2)
    s = (x - kx[k]) / (kx[k + 1] - kx[k])
    return k, s


def _spherical(r_itrs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Geocentric radius [km], colatitude [deg], east longitude [deg] of ITRS positions."""
    x, y, z = r_itrs[:, 0], r_itrs[:, 1], r_itrs[:, 2]
    r = np.sqrt(x * x + y * y + z * z)
    theta = np.degrees(np.arctan2(np.hypot(x, y), z))
    # ppigrf divides by sin θ: keep θ 1e-9 deg (0.1 mm) away from the poles
    theta = np.clip(theta, 1e-9, 180.0 - 1e-9)
    phi = np.degrees(np.arctan2(y, x))
    return r, theta, phi


def _from_spherical(theta_deg, phi_deg, br, bth, bph) -> np.ndarray:
    """ITRS components of a vector given on the local (r̂, θ̂ south, φ̂ east) basis."""
    th = np.radians(theta_deg)
    ph = np.radians(phi_deg)
    st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    return np.stack(
        [
            br * st * cp + bth * ct * cp - bph * sp,
            br * st * sp + bth * ct * sp + bph * cp,
            br * ct - bth * st,
        ],
        axis=-1,
    )


def igrf_field_itrs(dates: np.ndarray, r_itrs: np.ndarray, max_degree: int = 13) -> np.ndarray:
    """IGRF-14 field [T] at ITRS positions [km] and UTC dates (datetime64), ITRS components.

    ``ppigrf.igrf_gc`` at the exact geocentric spherical coordinates of the positions (its
    geodetic entry converts to these internally; this skips the round trip). IGRF's Gauss
    coefficients are linear in time between the five-yearly models, so the field at a date is
    the same linear combination of the fields at two dates of its interval: ppigrf is called
    for the extreme dates and the model epochs in between only, never once per date.
    """
    from ppigrf import igrf_gc

    dates = np.asarray(dates, dtype="datetime64[ns]")
    check_igrf_dates(dates)
    r, theta, phi = _spherical(np.asarray(r_itrs, dtype=np.float64))
    knots = _segment_dates(dates)
    kd = [d.astype("datetime64[us]").item() for d in knots]
    br, bth, bph = igrf_gc(r, theta, phi, kd, max_degree=max_degree)  # (n_knots, n) nT
    k, s = _time_weights(dates, knots)
    idx = np.arange(dates.size)
    k1 = np.minimum(k + 1, knots.size - 1)

    def mix(b):
        return (1.0 - s) * b[k, idx] + s * b[k1, idx]

    return 1e-9 * _from_spherical(theta, phi, mix(br), mix(bth), mix(bph))


def igrf_dipole_coefficients(dates: np.ndarray) -> np.ndarray:
    """(g10, g11, h11) [nT] of IGRF-14 at the dates (datetime64), shape (n, 3).

    The coefficients are linear in time between the models of the file, as in ppigrf."""
    g, h = _shc()
    dates = np.asarray(dates, dtype="datetime64[ns]")
    check_igrf_dates(dates)
    ex = np.asarray(g.index.values, dtype="datetime64[ns]").astype("int64").astype(np.float64)
    x = dates.astype("int64").astype(np.float64)
    cols = (g[(1, 0)].values, g[(1, 1)].values, h[(1, 1)].values)
    return np.stack([np.interp(x, ex, np.asarray(c, dtype=np.float64)) for c in cols], axis=-1)


def dipole_field_itrs(dates: np.ndarray, r_itrs: np.ndarray) -> np.ndarray:
    """Tilted-dipole field [T] (IGRF degree 1 at the dates) at ITRS positions [km], ITRS axes.

    With m = (g11, h11, g10) and a = 6371.2 km, the degree-1 potential is V = a³ m·r/r³ and
    B = −∇V = (a/r)³ [3 (m·r̂) r̂ − m].
    """
    c = igrf_dipole_coefficients(dates)
    m = np.stack([c[:, 1], c[:, 2], c[:, 0]], axis=-1)
    r = np.asarray(r_itrs, dtype=np.float64)
    rn = np.linalg.norm(r, axis=-1)
    u = r / rn[:, None]
    k = (IGRF_RADIUS / rn) ** 3
    mu = np.einsum("ij,ij->i", m, u)
    return 1e-9 * k[:, None] * (3.0 * mu[:, None] * u - m)


def magnetic_field_gcrs(g: Grid, model: str) -> np.ndarray:
    """The geomagnetic field [T] at the grid's nodes, GCRS components, (n, 3)."""
    key = f"field:{model}"
    if key not in g._memo:
        check_igrf_dates(g.datetime64)  # before any frame work
        if model == "igrf":
            b = igrf_field_itrs(g.datetime64, g.itrs_position)
        else:
            b = dipole_field_itrs(g.datetime64, g.itrs_position)
        g._memo[key] = np.einsum("nji,nj->ni", g.rotation, b)  # Rᵀ B
    return g._memo[key]


# --------------------------------------------------------------------------------------------
# Atmosphere
# --------------------------------------------------------------------------------------------


def relative_velocity(g: Grid) -> np.ndarray:
    """Velocity relative to an atmosphere co-rotating with the Earth, v − ω⊕ × r [m/s], GCRS.

    ω⊕ = OMEGA_EARTH along the ITRS z axis, expressed in the GCRS with astropy's rotation.
    """
    key = "v_rel"
    if key not in g._memo:
        r, v = g.state
        axis = g.rotation[:, 2, :]  # Rᵀ e3: the ITRS pole in GCRS components
        g._memo[key] = 1e3 * (v - OMEGA_EARTH * np.cross(axis, r))
    return g._memo[key]


def check_space_weather(f107: float, f107a: float, ap: float) -> None:
    """Raise :class:`AttitudeValueError` naming the index outside its accepted range."""
    for name, v, (lo, hi), what in (
        ("f107", f107, F107_RANGE, "daily F10.7 of the previous day [sfu]"),
        ("f107a", f107a, F107_RANGE, "81-day mean F10.7 [sfu]"),
        ("ap", ap, AP_RANGE, "daily Ap"),
    ):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise AttitudeValueError(
                f"{name}: the {what} must be in [{lo:g}, {hi:g}] (the range NRLMSIS is fitted "
                f"to / the scale's definition), got {v!r}"
            )


def _round_ms(dates: np.ndarray) -> np.ndarray:
    """Dates rounded to the nearest millisecond (a node on a whole second stays on it)."""
    ns = np.asarray(dates, dtype="datetime64[ns]").astype(np.int64)
    return ((ns + 500_000) // 1_000_000 * 1_000_000).astype("datetime64[ns]")


def msis_density(
    dates: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    height: np.ndarray,
    f107: float,
    f107a: float,
    ap: float,
) -> np.ndarray:
    """NRLMSIS 2.1 total mass density [kg/m³] (``pymsis``) with the given indices.

    All three indices are passed, so pymsis never looks for (or downloads) its space-weather
    file. Daily-Ap mode (the model's default switches): the seven ap entries are all ``ap``.
    pymsis hands the model float32 inputs (height to ~3e-5 km at 600 km: ~5e-7 relative in
    density) and returns float32.
    """
    import pymsis

    check_space_weather(f107, f107a, ap)
    n = np.size(dates)
    out = pymsis.calculate(
        _round_ms(dates),
        np.degrees(np.asarray(lon, dtype=np.float64)),
        np.degrees(np.asarray(lat, dtype=np.float64)),
        np.asarray(height, dtype=np.float64),
        np.full(n, float(f107)),
        np.full(n, float(f107a)),
        np.full((n, 7), float(ap)),
        version=2.1,
    )
    return np.asarray(out[..., 0], dtype=np.float64).reshape(n)


def exponential_density(height: Any, bands: Any = None) -> np.ndarray:
    """Vallado's exponential atmosphere (Table 8-4; or other ``bands`` (h0 km, ρ0, H km))
    [kg/m³] at geodetic heights [km]."""
    h = np.asarray(height, dtype=np.float64)
    tab = VALLADO_EXPONENTIAL if bands is None else np.asarray(bands, dtype=np.float64)
    k = np.clip(np.searchsorted(tab[:, 0], h, side="right") - 1, 0, len(tab) - 1)
    return tab[k, 1] * np.exp(-(h - tab[k, 0]) / tab[k, 2])


# --------------------------------------------------------------------------------------------
# Sun
# --------------------------------------------------------------------------------------------


def sun_shadow(g: Grid) -> np.ndarray:
    """(n, 8): :func:`sun_relative`, then the conical shadow's margins g_penumbra, g_umbra
    [rad] (:func:`orbit.sun.shadow_function`; positive in light), which the torque kernel
    interpolates to skip the shadow function well inside the light or the umbra."""
    key = "sun_shadow"
    if key not in g._memo:
        from orbit.sun import shadow_function

        rel = sun_relative(g)
        r = rel[:, 3:]
        _, gp, gu = shadow_function(r, rel[:, :3] + r, margins=True)
        g._memo[key] = np.concatenate([rel, gp[:, None], gu[:, None]], axis=1)
    return g._memo[key]


def earth_disk_larger(rows: np.ndarray, margin: float = 1e-3) -> bool:
    """Whether the Earth's disk is larger than the Sun's by ``margin`` [rad] at every node of
    :func:`sun_shadow`'s rows: only then is g_umbra < 0 the umbra (else an annular shadow)."""
    from orbit.sun import R_EARTH, R_SUN

    b = np.arcsin(np.minimum(R_EARTH / np.linalg.norm(rows[:, 3:6], axis=1), 1.0))
    a = np.arcsin(R_SUN / np.linalg.norm(rows[:, :3], axis=1))
    return bool(np.all(b - a > margin))


def sun_relative(g: Grid) -> np.ndarray:
    """(n, 6): Sun − satellite [km] and the satellite's position [km], GCRS axes."""
    key = "sun_rel"
    if key not in g._memo:
        r = g.state[0]
        g._memo[key] = np.concatenate([g.sun - r, r], axis=1)
    return g._memo[key]
