"""The environment of a spacecraft in Earth orbit: :class:`MagneticDipole`,
:class:`EddyCurrentDamping`, :class:`AerodynamicDrag` and :class:`SolarRadiation`.

Each reads the environment along the orbit from tables computed once per run
(:mod:`attitude.environment`) and interpolated in compiled code (:mod:`attitude._core.environment`);
their common base ``_EnvironmentModel`` keeps the tables over a run's span, and the checks of
their settings (field, orbit, step, span) are here.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from .. import environment as _env
from .._core import environment as _ke
from .._core import models as _models
from .._core import potentials as _kp
from .._validation import as_float_array, as_scalar
from ..errors import AttitudeTypeError, AttitudeValueError
from ..facets import drag_groups, facet_array, force_groups, optical_groups
from ._base import Potential

__all__ = [
    "AerodynamicDrag",
    "EddyCurrentDamping",
    "MagneticDipole",
    "SolarRadiation",
    "check_field",
]


def _seconds(x: Any, name: str) -> float:
    v = as_float_array(x, name, unit="s")
    if v.shape != () or not float(v) > 0.0:
        raise AttitudeValueError(f"{name}: expected a positive time step (s), got {x!r}")
    return float(v)


def _span(span: Any) -> tuple[float, float] | None:
    if span is None:
        return None
    v = as_float_array(span, "span", unit="s")
    if v.shape != (2,) or not v[1] >= v[0]:
        raise AttitudeValueError(
            f"span: expected (start, stop) in seconds since the epoch with stop >= start, got "
            f"{span!r}"
        )
    return float(v[0]), float(v[1])


def _check_orbit(orbit: Any, what: str, needs_epoch: bool, why: str) -> Any:
    if orbit is None and not needs_epoch:
        return None
    if not hasattr(orbit, "kernel_data"):
        raise AttitudeTypeError(
            f"orbit: {what} needs an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
            f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
        )
    if needs_epoch and getattr(orbit, "epoch", None) is None:
        raise AttitudeValueError(
            f"orbit: {what} {why}, so it needs a dated orbit: build the orbit with "
            "epoch='2024-03-20T12:00:00' (an astropy Time or ISO 8601 string; TLE and OEM "
            "orbits carry their own)"
        )
    return orbit


class _EnvironmentModel(Potential):
    """Base of the models whose torque reads the environment along the orbit from tables.

    The tables (:mod:`attitude.environment`) span the run: :meth:`prepare` computes them for
    the times of a run (``attitude.propagate`` calls it), once, and keeps them while later runs
    fit in the same span. Subclasses give ``_table(grid)``, the environment on a
    :class:`attitude.environment.Grid`, and ``_head()``, the block's numbers before the table;
    ``_table`` runs first and may record what it chose for ``_head`` (drag: whether the table
    holds √ρ v; radiation: whether the shadow margins may decide the umbra).
    """

    time_dependent = True
    orbit: Any = None

    def _entry_points(self, closed_loop: bool = False):
        """The entry points of this model alone, specialised to its orbit's type too (the
        Dataset's orbit variables: :mod:`attitude._core.models`)."""
        data = None if self.orbit is None else self.orbit.kernel_data()
        return _models.entry_points(self._kind, data, closed_loop=closed_loop)

    def _setup(self, orbit: Any, step: Any, span: Any) -> None:
        self.step = _env.DEFAULT_STEP if step is None else _seconds(step, "step")
        self.span = _span(span)
        self._block: np.ndarray | None = None
        self._covers: tuple[float, float] | None = None

    # subclass hooks
    #: The block's declaration (attitude._core.environment).
    _layout: Any = _ke.BLOCK

    def _head(self) -> tuple[dict[str, Any], np.ndarray]:
        """(the block's fields by name, what follows them before the table)."""
        raise NotImplementedError

    def _table(self, g: Any) -> np.ndarray:
        raise NotImplementedError

    def _constant_table(self) -> np.ndarray | None:
        return None

    def prepare(self, t: Any) -> Potential:
        const = self._constant_table()
        if const is not None:
            if self._block is None:
                self._block = self._assemble(const)
            return self
        arr = np.asarray(t, dtype=np.float64).reshape(-1)
        if arr.size == 0:
            return self
        lo, hi = float(np.min(arr)), float(np.max(arr))
        c = self._covers
        if self._block is not None and c is not None and c[0] <= lo and hi <= c[1]:
            return self
        self.check_times(arr, "t")
        g = _env.grid(self.orbit, lo, hi, self.step)
        self._block = self._assemble(self._table(g))
        self._covers = (lo, hi)
        return self

    def _assemble(self, table: np.ndarray) -> np.ndarray:
        fields, tail = self._head()
        head = np.concatenate([self._layout.pack(**fields), tail])
        head[self._layout.TAB] = head.size  # the table follows the fields
        # the block without its kind (_kernel_params puts it in front)
        return np.concatenate([head[1:], table]).astype(np.float64)

    def _potential_params(self) -> Any:
        if self._block is None:
            span = self.span
            if span is None and self.orbit is not None:
                lo, hi = self.orbit.time_span
                span = (lo, hi) if math.isfinite(lo) and math.isfinite(hi) else None
            if span is None:
                raise AttitudeValueError(
                    f"span: the {self.name} tables cover the times of a run; "
                    "attitude.propagate prepares them, and torque()/value() for the times "
                    "they are given; to build the parameters yourself call "
                    f"model.prepare(t) or give {type(self).__name__}(..., span=(start, stop))"
                )
            self.prepare(np.array(span))
        return self._block

    def check_times(self, t: Any, name: str = "t") -> None:
        if self.orbit is not None:
            try:
                self.orbit.check_times(t, name)
            except ValueError as exc:
                raise AttitudeValueError(str(exc)) from None

    def _kernel_params(self, t: np.ndarray) -> np.ndarray:
        self.prepare(t)
        return np.concatenate([[self._kind], self._block])

    def _table_values(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """(params, values (m, ncomp)) of the table at times ``t`` (compiled interpolation)."""
        tt = np.ascontiguousarray(as_float_array(t, "t", unit="s"), dtype=np.float64)
        flat = tt.reshape(-1)
        self.check_times(flat, "t")
        params = self._kernel_params(flat)
        o = int(params[_ke.BLOCK.TAB])
        s0 = o + int(params[o + 1])  # first segment: ncomp is the same in all
        out = np.empty((flat.size, int(params[s0 + _ke.SEG.NCOMP])))
        _ke.table_loop(flat, params, o, out)
        return params, out.reshape((*tt.shape, out.shape[-1]))


def check_field(field: Any) -> np.ndarray | None:
    """The constant field [T] of a ``field`` setting, or None for a model name ('igrf' or
    'dipole'); anything else is refused, naming ``field`` and the choices."""
    if isinstance(field, str):
        if field not in ("igrf", "dipole"):
            raise AttitudeValueError(
                f"field: expected 'igrf' (IGRF-14 through ppigrf), 'dipole' (its tilted "
                f"dipole) or a constant field vector (T, space axes), got {field!r}"
            )
        return None
    b = as_float_array(field, "field", unit="T")
    if b.shape != (3,):
        raise AttitudeValueError(
            f"field: a constant field is 3 space-frame components (T), got shape {b.shape}"
        )
    return b


def _field_setting(field: Any, orbit: Any, what: str) -> tuple[str, np.ndarray | None, Any]:
    """('igrf' | 'dipole' | 'constant', constant field [T] or None, orbit)."""
    b = check_field(field)
    if b is None:
        why = "evaluates the geomagnetic field at the orbit's Earth-fixed positions and date"
        orbit = _check_orbit(orbit, what, True, why)
        _env.check_igrf_dates(np.array([orbit.epoch.utc.to_value("datetime64")], "datetime64[ns]"))
        return field, None, orbit
    return "constant", b, _check_orbit(orbit, what, False, "")


class MagneticDipole(_EnvironmentModel):
    """Torque on a body-fixed magnetic dipole in the geomagnetic field: τ = m × B_B.

    U = −m·B_B (a time-dependent potential: the energy of the dipole in the field).

    Parameters
    ----------
    orbit : orbit.Orbit
        The orbit, with an epoch (the field is evaluated at its Earth-fixed positions and
        date); may be None with a constant ``field``.
    dipole : array_like or Quantity, shape (3,)
        m in body axes [A m²] (a residual dipole, or a magnetorquer's constant moment).
    field : {"igrf", "dipole"} or array_like, shape (3,)
        ``"igrf"``: IGRF-14 (degree 13) through ``ppigrf``; ``"dipole"``: the tilted dipole of
        the same IGRF coefficients (degree 1, closed form); or a constant field in the space
        frame [T] (Quantity accepted, e.g. nT).
    step : float or Quantity, optional
        Node spacing of the field table [s] (default :data:`attitude.environment.DEFAULT_STEP`).
    span : (float, float), optional
        Times [s] the tables must cover when the model is used outside ``attitude.propagate``.

    Notes
    -----
    The field is computed once per run along the orbit (ITRS positions by astropy, IGRF by
    ppigrf, rotated to the GCRS by astropy) and interpolated in the compiled right-hand side
    (degree-7 Lagrange, :mod:`attitude._core.environment`); docs/potentials.md gives the
    measured interpolation error.
    """

    name = "magnetic_dipole"
    _kind = _kp.KIND_MAGNETIC_DIPOLE

    def __init__(
        self, orbit: Any, dipole: Any, field: Any = "igrf", *, step: Any = None, span: Any = None
    ):
        self.field, self._const, self.orbit = _field_setting(field, orbit, "MagneticDipole")
        m = as_float_array(dipole, "dipole", unit="A m2")
        if m.shape != (3,):
            raise AttitudeValueError(
                f"dipole: expected 3 body-axis components (A m²), got shape {m.shape}"
            )
        self.dipole = m
        self._setup(self.orbit, step, span)

    _layout = _ke.DIPOLE

    def _head(self) -> tuple[dict[str, Any], np.ndarray]:
        return {"vec": self.dipole}, np.zeros(0)

    def _constant_table(self) -> np.ndarray | None:
        return None if self._const is None else _env.constant_table(self._const)

    def _table(self, g: Any) -> np.ndarray:
        return _env.table(g, _env.magnetic_field_gcrs(g, self.field))

    def magnetic_field(self, t: Any) -> np.ndarray:
        """The field the torque uses [T], space-frame components, shape t.shape + (3,)."""
        return self._table_values(t)[1]

    def __repr__(self) -> str:
        f = self.field if self._const is None else self._const.tolist()
        return f"MagneticDipole(dipole={self.dipole.tolist()}, field={f!r})"


class EddyCurrentDamping(_EnvironmentModel):
    """Eddy-current torque on a conducting body: τ = m × B_B, m = −M dB_B/dt
    = M (ω × B_B − q̃∘Ḃ_S∘q) (body axes; (M (ω × B)) × B in a field fixed in space).

    The tensor model of Ortiz Gómez & Walker (2015), "Eddy currents applied to de-tumbling of
    space debris: analysis and validation of approximate proposed methods", Acta Astronautica
    114, 34–53: the currents induced in the conductor give a magnetic moment M (ω × B) when
    the body rotates in a field B fixed in space, whose torque in B damps the rotation
    perpendicular to B and leaves the spin about B alone: ω·τ = −(ω × B)·M (ω × B) <= 0,
    τ ⊥ B. The moment answers the change of the field seen from the body (Faraday's law in
    the low-frequency limit, the assumption of the tensor model), and along an orbit the field
    also changes in space: dB_B/dt = −ω × B_B + q̃∘Ḃ_S∘q, with Ḃ_S the rate of the field along
    the orbit (up to ~4e-3 rad/s of rotation in LEO: 2–4 % of a 5 °/s tumble, all of it for a
    body slowed to a few times the orbital rate). Praly et al. (2012), "Study on the eddy
    current damping of the spin dynamics of space debris from the Ariane launcher upper
    stages", Acta Astronautica 76, 145–153, model the induction of a conductor orbiting
    through the geomagnetic field. Ḃ_S is tabulated with B: the derivative of the degree-8
    polynomial through the 9 nearest nodes (:func:`orbit.ephemeris.position_derivative`).
    This is what de-spins defunct satellites and spent stages over months (Praly et al. 2012).

    Parameters
    ----------
    orbit : orbit.Orbit
        The orbit with an epoch (or None with a constant ``field``).
    tensor : float, array_like (3,) or (3, 3), or Quantity
        The magnetic tensor M in body axes [S m⁴ = A m² / (T s⁻¹ T)]: a number (isotropic), the
        diagonal, or the symmetric positive semi-definite matrix. A thin spherical shell of
        radius R, wall thickness e and conductivity σ has M = (2π/3) σ e R⁴ 1
        (:meth:`spherical_shell`).
    field, step, span
        As :class:`MagneticDipole`.
    """

    name = "eddy_current_damping"
    _kind = _kp.KIND_EDDY_CURRENTS
    rate_dependent = True
    has_potential = False

    def __init__(
        self, orbit: Any, tensor: Any, field: Any = "igrf", *, step: Any = None, span: Any = None
    ):
        self.field, self._const, self.orbit = _field_setting(field, orbit, "EddyCurrentDamping")
        m = as_float_array(tensor, "tensor", unit="S m4")
        if m.shape == ():
            m = float(m) * np.eye(3)
        elif m.shape == (3,):
            m = np.diag(m)
        elif m.shape != (3, 3):
            raise AttitudeValueError(
                f"tensor: expected a number, 3 diagonal entries or a 3 × 3 matrix (S m⁴), got "
                f"shape {m.shape}"
            )
        scale = max(float(np.max(np.abs(m))), np.finfo(float).tiny)
        if np.max(np.abs(m - m.T)) > 1e-12 * scale:
            raise AttitudeValueError("tensor: the magnetic tensor must be symmetric")
        if float(np.min(np.linalg.eigvalsh(m))) < -1e-12 * scale:
            raise AttitudeValueError(
                "tensor: must be positive semi-definite (a conductor dissipates energy: "
                "ω·τ = −(ω × B)·M (ω × B) <= 0)"
            )
        self.tensor = m
        self._setup(self.orbit, step, span)

    @staticmethod
    def spherical_shell(radius: Any, thickness: Any, conductivity: Any) -> np.ndarray:
        """M = (2π/3) σ e R⁴ 1 of a thin spherical shell [S m⁴] (Ortiz Gómez & Walker 2015).

        Parameters
        ----------
        radius, thickness : float or Quantity
            R and e [m].
        conductivity : float or Quantity
            σ [S/m] (aluminium alloys: 2e7 to 3.8e7 S/m).
        """
        r = as_scalar(radius, "radius", unit="m")
        e = as_scalar(thickness, "thickness", unit="m")
        s = as_scalar(conductivity, "conductivity", unit="S / m")
        for name, v in (("radius", r), ("thickness", e), ("conductivity", s)):
            if not v > 0:
                raise AttitudeValueError(f"{name}: must be > 0, got {v!r}")
        return (2.0 * math.pi / 3.0) * s * e * r**4 * np.eye(3)

    _layout = _ke.EDDY

    def _head(self) -> tuple[dict[str, Any], np.ndarray]:
        return {"tensor": self.tensor}, np.zeros(0)

    def _constant_table(self) -> np.ndarray | None:
        if self._const is None:
            return None
        return _env.constant_table(np.concatenate([self._const, np.zeros(3)]))

    def _table(self, g: Any) -> np.ndarray:
        from orbit.ephemeris import position_derivative

        b = _env.magnetic_field_gcrs(g, self.field)
        return _env.table(g, np.hstack([b, position_derivative(g.t, b)]))

    def magnetic_field(self, t: Any) -> np.ndarray:
        """The field the torque uses [T], space-frame components, shape t.shape + (3,)."""
        return self._table_values(t)[1][..., :3]

    def magnetic_field_rate(self, t: Any) -> np.ndarray:
        """Its rate of change along the orbit, dB/dt [T/s], space-frame components."""
        return self._table_values(t)[1][..., 3:6]

    def __repr__(self) -> str:
        f = self.field if self._const is None else self._const.tolist()
        return f"EddyCurrentDamping(tensor={self.tensor.tolist()}, field={f!r})"


def _check_above_surface(height: np.ndarray, t: np.ndarray) -> None:
    """Refuse an orbit that goes below the Earth's surface while drag is computed (NRLMSIS
    returns 0 there, the exponential table 1e48 kg/m³ at −800 km: no atmosphere model means
    anything below the ground)."""
    if not height.size or float(np.min(height)) >= 0.0:
        return
    i = int(np.argmin(height))
    raise AttitudeValueError(
        f"orbit: AerodynamicDrag needs the atmosphere along the orbit, and this orbit passes "
        f"{-float(height[i]):.1f} km below the Earth's surface (WGS 84 height "
        f"{float(height[i]):.1f} km at t ≈ {float(t[i]):.6g} s): check "
        "the orbit (its perigee radius a (1 − e) is the geocentric distance of its lowest "
        "point), or leave drag out"
    )


class AerodynamicDrag(_EnvironmentModel):
    """Aerodynamic torque on flat-plate facets in the co-rotating atmosphere.

    A facet whose outward normal faces the flow (cos θ = n̂·v̂ > 0) feels
    F = −½ ρ C_D A cos θ |v|² v̂ at its centre, v the velocity relative to an atmosphere
    co-rotating with the Earth (v − ω⊕ × r); τ = Σ c × F. On a spacecraft with a mass on an
    :class:`orbit.NumericalOrbit` the force Σ F acts on the orbit too (docs/orbit.md). The flow
    around facets that shadow each other is not modelled (every facet facing the flow counts in
    full), nor the velocity ω × c of the facets from the body's own rotation (|ω × c| / |v|
    ~ 1e-6 for a CubeSat).

    Parameters
    ----------
    orbit : orbit.Orbit
        With an epoch (the density depends on the date, local time and the Earth-fixed
        position).
    facets : sequence of attitude.Facet
        The surfaces (body axes, SI).
    density : {"msis", "exponential"} or float
        NRLMSIS 2.1 through ``pymsis`` with the indices below, the exponential atmosphere of
        Vallado (2013), Table 8-4 (no indices), or a constant density [kg/m³] (an idealised
        atmosphere, e.g. for trade studies and checks).
    f107, f107a : float
        Daily F10.7 of the previous day and its 81-day mean [sfu], each in [50, 400]; given,
        never fetched (pymsis is called with all indices, so it never opens or downloads its
        space-weather file).
    ap : float
        Daily Ap in [0, 400].
    step, span
        As :class:`MagneticDipole`.
    """

    name = "aerodynamic_drag"
    _kind = _kp.KIND_AERODYNAMIC_DRAG
    has_potential = False

    def __init__(
        self,
        orbit: Any,
        facets: Any,
        density: str = "msis",
        f107: Any = 150.0,
        f107a: Any = 150.0,
        ap: Any = 4.0,
        *,
        step: Any = None,
        span: Any = None,
    ):
        self._bands = _env.VALLADO_EXPONENTIAL
        if not isinstance(density, str):
            rho = as_scalar(density, "density")
            if not (math.isfinite(rho) and rho > 0.0):
                raise AttitudeValueError(
                    f"density: a constant density must be a positive number of kg/m³, got {rho!r}"
                )
            # one band with an infinite scale height: ρ everywhere
            self._bands = np.array([[-1e9, rho, math.inf]])
            density = rho
        elif density not in ("msis", "exponential"):
            raise AttitudeValueError(
                f"density: expected 'msis' (NRLMSIS 2.1 through pymsis), 'exponential' "
                f"(Vallado's table) or a constant density in kg/m³, got {density!r}"
            )
        why = "evaluates the atmosphere at the orbit's Earth-fixed positions and date"
        self.orbit = _check_orbit(orbit, "AerodynamicDrag", True, why)
        self.facets = facet_array(facets)
        self.density = density
        self.f107 = as_scalar(f107, "f107")
        self.f107a = as_scalar(f107a, "f107a")
        self.ap = as_scalar(ap, "ap")
        _env.check_space_weather(self.f107, self.f107a, self.ap)
        self._density_code = _ke.DENSITY_TABLE if density == "msis" else _ke.DENSITY_EXPONENTIAL
        self._setup(self.orbit, step, span)

    _layout = _ke.DRAG

    def _head(self) -> tuple[dict[str, Any], np.ndarray]:
        bands = self._bands
        groups = drag_groups(self.facets).reshape(-1, _ke.DRAG_GROUP.SIZE)
        bands_at = _ke.DRAG.FACETS + groups.size
        forces = force_groups(self.facets, lambda f: [f.cd * f.area])
        fields = dict(nf=len(groups), density=self._density_code, bands=bands_at, nb=len(bands),
                      forces=bands_at + np.size(bands))  # fmt: skip
        return fields, np.concatenate([groups.ravel(), np.ravel(bands), forces.ravel()])

    def _rows(self, g: Any) -> np.ndarray:
        key = ("drag_rows", self.density, self.f107, self.f107a, self.ap)
        if key not in g._memo:
            lat, lon, h = g.geodetic
            _check_above_surface(h, g.t)
            if self.density != "msis":
                x = h
            else:
                x = np.log(
                    _env.msis_density(g.datetime64, lat, lon, h, self.f107, self.f107a, self.ap)
                )
            g._memo[key] = np.concatenate([_env.relative_velocity(g), x[:, None]], axis=1)
        return g._memo[key]

    def _folded_rows(self, g: Any) -> np.ndarray:
        rows = self._rows(g).copy()
        rows[:, :3] *= np.exp(0.5 * rows[:, 3:4])  # √ρ v
        return rows

    def _table(self, g: Any) -> np.ndarray:
        if self.density != "msis":
            self._density_code = _ke.DENSITY_EXPONENTIAL
            return _env.table(g, self._rows(g))
        # pymsis's density jumps at 00:00 UTC: tables cut there
        plain = _env.table_by_utc_day(g, self._rows)
        folded = _env.table_by_utc_day(g, self._folded_rows)
        if _env.folds_density(plain, folded, g):
            self._density_code = _ke.DENSITY_FOLDED
            return folded
        self._density_code = _ke.DENSITY_TABLE
        return plain

    def atmosphere(self, t: Any) -> dict[str, np.ndarray]:
        """What the torque uses at times ``t``: ``density`` [kg/m³] and ``velocity`` [m/s],
        the velocity relative to the atmosphere in space-frame components."""
        _, v = self._table_values(t)
        if self.density != "msis":
            rho = _env.exponential_density(v[..., 3], self._bands)
        else:
            rho = np.exp(v[..., 3])
        if self._density_code == _ke.DENSITY_FOLDED:
            return {"density": rho, "velocity": v[..., :3] * np.exp(-0.5 * v[..., 3:4])}
        return {"density": rho, "velocity": v[..., :3]}

    def __repr__(self) -> str:
        extra = f", f107={self.f107!r}, f107a={self.f107a!r}, ap={self.ap!r}"
        return (
            f"AerodynamicDrag({len(self.facets)} facets, density={self.density!r}"
            + (extra if self.density == "msis" else "")
            + ")"
        )


class SolarRadiation(_EnvironmentModel):
    """Solar-radiation-pressure torque on flat-plate facets, with the Earth's shadow.

    A facet facing the Sun (cos θ = n̂·ŝ > 0) feels
    F = −P A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂] (absorbed, specular and diffuse
    parts: Wertz 1978, Sect. 17.2.2; Montenbruck & Gill 2000, Sect. 3.4.1), with
    P = ν P⊙ (1 AU / d)², P⊙ = 1361 W m⁻² / c = 4.54e-6 N m⁻² (IAU 2015 nominal irradiance),
    d the satellite–Sun distance and ν the shadow fraction; τ = Σ c × F. Facets shadowing each
    other, Earth albedo and infrared are not modelled.

    Parameters
    ----------
    orbit : orbit.Orbit
        With an epoch (the Sun's position is dated).
    facets : sequence of attitude.Facet
        The surfaces with their optical coefficients.
    eclipse : {"conical", "cylindrical", "none"}
        Earth shadow: conical with penumbra (Montenbruck & Gill 2000, Sect. 3.4.2; default),
        cylindrical, or none.
    step, span
        As :class:`MagneticDipole`.
    """

    name = "solar_radiation"
    _kind = _kp.KIND_SOLAR_RADIATION
    has_potential = False

    _ECLIPSE: ClassVar[dict[str, int]] = {
        "conical": _ke.ECLIPSE_CONICAL,
        "cylindrical": _ke.ECLIPSE_CYLINDRICAL,
        "none": _ke.ECLIPSE_NONE,
    }

    def __init__(
        self,
        orbit: Any,
        facets: Any,
        eclipse: str = "conical",
        *,
        step: Any = None,
        span: Any = None,
    ):
        if not isinstance(eclipse, str) or eclipse not in self._ECLIPSE:
            raise AttitudeValueError(
                f"eclipse: expected 'conical' (with penumbra), 'cylindrical' or 'none', got "
                f"{eclipse!r}"
            )
        why = "needs the Sun's position at the orbit's dates"
        self.orbit = _check_orbit(orbit, "SolarRadiation", True, why)
        self.facets = facet_array(facets)
        self.eclipse = eclipse
        self._umbra = False
        self._setup(self.orbit, step, span)

    _layout = _ke.SRP

    def _head(self) -> tuple[dict[str, Any], np.ndarray]:
        from orbit.sun import R_EARTH, R_SUN

        groups = optical_groups(self.facets).reshape(-1, _ke.SRP_GROUP.SIZE)
        fields = dict(
            nf=len(groups),
            eclipse=self._ECLIPSE[self.eclipse],
            p=_env.P_SUN_1AU,
            au=_env.AU_KM,
            rsun=R_SUN,
            rearth=R_EARTH,
            umbra=float(self._umbra),  # the shadow margins may decide the umbra (set by _table)
            forces=_ke.SRP.FACETS + groups.size,
        )
        forces = force_groups(
            self.facets,
            lambda f: [f.area * (1.0 - f.specular), 2.0 * f.area * f.specular,
                       (2.0 / 3.0) * f.area * f.diffuse],
        )  # fmt: skip
        return fields, np.concatenate([groups.ravel(), forces.ravel()])

    def _table(self, g: Any) -> np.ndarray:
        rows = _env.sun_shadow(g)
        self._umbra = _env.earth_disk_larger(rows)
        return _env.table(g, rows)

    def sunlight(self, t: Any) -> dict[str, np.ndarray]:
        """What the torque uses at times ``t``: ``shadow`` ν (1 sunlit, 0 umbra),
        ``distance`` to the Sun [km] and ``direction`` (unit vector to the Sun, space axes)."""
        tt = np.ascontiguousarray(as_float_array(t, "t", unit="s"), dtype=np.float64)
        flat = tt.reshape(-1)
        self.check_times(flat, "t")
        params = self._kernel_params(flat)
        out = np.empty((flat.size, 5))
        _ke.solar_state_loop(flat, params, 0, out)
        out = out.reshape((*tt.shape, 5))
        return {"shadow": out[..., 0], "distance": out[..., 1], "direction": out[..., 2:]}

    def __repr__(self) -> str:
        return f"SolarRadiation({len(self.facets)} facets, eclipse={self.eclipse!r})"
