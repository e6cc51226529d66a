"""The propagation result: one xarray Dataset schema for every method and formulation.

See docs/results.md for the schema. It follows CF-1.11: dimension coordinates are numeric
(``component`` 0..3, ``axis`` 0..2, with the letters in the auxiliary label coordinates
``component_label`` and ``axis_label``), ``time`` is a CF time coordinate (``seconds since
<epoch>``) when the run has an epoch, and every unit string is parsed alike by astropy,
UDUNITS (cf_units) and pint's default registry (``kg m^2 s^-1`` style). A body with units gives
SI results (orbit quantities in km); a body without units gives dimensionless ones (``"1"``).
"""

from __future__ import annotations

import datetime
import time
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from ._core import diagnostics as _kd
from ._version import __version__
from .body import RigidBody

__all__ = [
    "AXIS_LABELS",
    "COMPONENT_LABELS",
    "INSTANT_VARIABLES",
    "SI",
    "Trajectory",
    "UnitSystem",
    "add_event_variables",
    "build_dataset",
    "dataset_from_samples",
    "instant_attrs",
    "set_time_attrs",
    "time_attrs",
    "time_unit",
    "time_values",
]


class Trajectory(NamedTuple):
    """The plain-array result of ``propagate(..., output="arrays")``: the states only, without
    diagnostics, torques or a Dataset (for loops and optimisers that call ``propagate`` many
    times; the same numbers as the Dataset's ``time``, ``q`` and ``Q``, bit for bit).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Output times (s for a body with units, else the time unit of the run).
    q : ndarray, shape (m, 4)
        Attitude quaternions, body to space, scalar first.
    Q : ndarray, shape (m, 4)
        Conjugate momenta (kg m² s⁻¹ for a body with units).
    stats : dict
        The run's statistics (tolerances, steps, right-hand sides...), as the Dataset's attrs.
    """

    t: np.ndarray
    q: np.ndarray
    Q: np.ndarray
    stats: dict


#: Unit strings of a body with units (SI; orbit lengths in km). Each is parsed to the same unit
#: by astropy, UDUNITS (cf_units) and pint's default registry (tests/test_cf.py).
SI = {
    "time": "s",
    "inertia": "kg m^2",
    "momentum": "kg m^2 s^-1",  # = N m s
    "energy": "J",
    "rate": "rad s^-1",
    "torque": "N m",
    "force": "N",
    "length": "m",  # lengths on the body (heavy-top centre of mass)
    "orbit_length": "km",  # the orbit module works in km and s
    "angle": "rad",
}
#: Letters of the quaternion components (index 0..3 of ``component``), scalar first.
COMPONENT_LABELS = ("w", "x", "y", "z")
#: Letters of the body/space vector components (index 0..2 of ``axis``).
AXIS_LABELS = ("x", "y", "z")

_LEAP_SECOND_NOTE = (
    "time counts SI seconds elapsed since the epoch (UTC), leap seconds included. CF "
    "calendars (calendar = standard) have no leap seconds: datetimes decoded by CF tools "
    "(xarray, netCDF4.num2date, cftime) are late by the leap seconds inserted between the "
    "epoch and the sample (none since 2017-01-01). The exact epoch is the global attr "
    "'epoch'; attitude reads times exactly (ds.attitude.times(), astropy)."
)


def _utc_now() -> str:
    """Current UTC time as ISO 8601 to the second, with a Z (for the CF ``history`` attr)."""
    sec = int(time.time())
    if _NOW[0] != sec:  # formatted once per second (a short propagate() is ~0.1 ms)
        stamp = datetime.datetime.fromtimestamp(sec, datetime.timezone.utc)
        _NOW[:] = [sec, stamp.strftime("%Y-%m-%dT%H:%M:%SZ")]
    return _NOW[1]


_NOW: list[Any] = [None, ""]


def _plain(x: Any, unit: str | None) -> np.ndarray:
    """Float64 array of ``x`` (an astropy Quantity is converted to ``unit`` first)."""
    if hasattr(x, "unit") and hasattr(x, "to_value"):
        x = x.to_value(unit) if unit is not None else x.to_value()
    return np.asarray(x, dtype=np.float64)


class UnitSystem:
    """Unit strings of the result variables, from the body's unit system (SI or ``"1"``)."""

    def __init__(self, body: RigidBody):
        if body.units is None:
            self.time = self.inertia = self.momentum = self.energy = self.rate = "1"
            self.torque = self.length = "1"
        else:
            self.time = SI["time"]
            self.inertia = SI["inertia"]
            self.momentum = SI["momentum"]
            self.energy = SI["energy"]
            self.rate = SI["rate"]
            self.torque = SI["torque"]
            self.length = SI["length"]


def _cf_reference(epoch: str) -> str | None:
    """The epoch as a CF/UDUNITS reference time ``YYYY-MM-DD hh:mm:ss.ffffff`` (UTC).

    None for an epoch inside a leap second (23:59:60), which CF calendars cannot express.
    """
    from astropy.time import Time

    t = Time(str(epoch).rstrip("Z"), scale="utc")
    t.precision = 6
    iso = str(t.iso)
    if iso[17:19] == "60":
        return None
    return iso


#: Reference time written when a run has no epoch: CF requires ``<unit> since <reference>`` of
#: a time coordinate, so a conventional placeholder is used and the attrs say so.
PLACEHOLDER_REFERENCE = "1970-01-01 00:00:00"

#: Variables that hold instants on the run's time axis (event times): their CF encoding
#: (``units``, ``calendar``, ``units_metadata``, ``elapsed_time_units``) is ``time``'s, in single
#: runs and ensembles alike, so CF tools decode them as ``time`` (datetimes with an epoch) and
#: :func:`attitude.io.read` gives the same numbers (seconds since the epoch).
INSTANT_VARIABLES = ("event_time", "detector_first_time", "event_first_time")
_INSTANT_KEYS = ("units", "calendar", "units_metadata", "elapsed_time_units")


def time_attrs(units: str, epoch: str | None = None) -> dict[str, str]:
    """Attrs of the ``time`` coordinate (CF 1.11 sect. 4.4).

    Parameters
    ----------
    units : {"s", "1"}
        Time unit of the run (``"1"`` for a dimensionless body).
    epoch : str, optional
        ISO 8601 UTC epoch of ``time = 0`` (the global attr ``epoch``).

    Returns
    -------
    dict
        ``standard_name = "time"``, ``axis = "T"``, ``calendar = "standard"`` and
        ``units = "seconds since <epoch>"`` (UTC) with a comment on leap seconds and
        ``units_metadata = "leap_seconds: utc"`` (CF 1.11 sect. 4.4.3: the numbers count the
        leap seconds between the epoch and the sample). A run without
        an epoch (or dimensionless) has the placeholder reference
        :data:`PLACEHOLDER_REFERENCE`, which CF requires, and says so in ``long_name`` and
        ``comment``. ``elapsed_time_units`` is the plain unit of the stored numbers (``"s"``,
        or ``"1"`` for a dimensionless run, whose numbers are not seconds).
    """
    ref = _cf_reference(epoch) if (epoch and units != "1") else None
    a = {"standard_name": "time", "axis": "T", "calendar": "standard"}
    if ref is not None:
        return {
            "units": f"seconds since {ref}",
            **a,
            "units_metadata": "leap_seconds: utc",
            "long_name": "time",
            "elapsed_time_units": "s",
            "comment": _LEAP_SECOND_NOTE,
        }
    if units == "1":
        note = (
            "dimensionless run (a body without units): the numbers are times in the body's "
            "own consistent unit, not seconds, and there is no epoch; the reference "
            f"'seconds since {PLACEHOLDER_REFERENCE}' is a placeholder that CF requires of a "
            "time coordinate (read the plain numbers: attitude.io.read, or "
            "xarray.open_dataset(..., decode_times=False))"
        )
        long_name = "dimensionless time since the initial state (no epoch)"
    else:
        note = (
            "no epoch: times are seconds since the initial state; the reference "
            f"{PLACEHOLDER_REFERENCE} is a placeholder that CF requires of a time coordinate "
            + (
                "(the epoch is inside a leap second, which CF reference times cannot express; "
                "it is the global attr 'epoch')"
                if epoch
                else "(give the scenario an epoch for absolute times)"
            )
        )
        long_name = "time since the initial state (no epoch)"
    return {
        "units": f"seconds since {PLACEHOLDER_REFERENCE}",
        **a,
        "units_metadata": "leap_seconds: none",  # no dates: no leap seconds apply
        "long_name": long_name,
        "elapsed_time_units": units,
        "comment": note,
    }


def instant_attrs(units: str, epoch: str | None = None) -> dict[str, str]:
    """The CF encoding attrs of a variable of :data:`INSTANT_VARIABLES`: those of ``time``
    (:func:`time_attrs`) that say how to read the numbers."""
    a = time_attrs(units, epoch)
    return {k: a[k] for k in _INSTANT_KEYS}


def time_unit(var: Any) -> str:
    """The plain unit (``"s"`` or ``"1"``) of a ``time`` variable, CF-encoded or decoded."""
    plain = var.attrs.get("elapsed_time_units")
    if plain:
        return str(plain)
    if np.issubdtype(np.asarray(var.values[:0]).dtype, np.datetime64):
        return "s"
    units = str(var.attrs.get("units", "")).strip()
    if " since " in units:
        units = units.split(" since ", 1)[0].strip()
        return {"seconds": "s", "second": "s", "sec": "s", "secs": "s"}.get(units, units)
    return units or "1"


def energy_semi_major_axis(attrs: dict[str, Any], r: Any, v: Any) -> np.ndarray | None:
    """The semi-major axis [km] of a run's propagated orbit from its orbital energy in the
    field's point mass and J2 (:func:`orbit.j2.energy_semi_major_axis`, with the run's attrs
    ``orbit_gm``, ``orbit_j2``, ``orbit_reference_radius``), at positions ``r`` [km] and
    velocities ``v`` [km/s] of shape (n, 3); None for a file without them."""
    if "orbit_gm" not in attrs:
        return None
    from orbit.j2 import energy_semi_major_axis as a_of_energy

    return a_of_energy(r, v, 1e-9 * float(attrs["orbit_gm"]), float(attrs.get("orbit_j2", 0.0)),
                       1e-3 * float(attrs.get("orbit_reference_radius", 0.0)))  # fmt: skip


def time_values(ds: xr.Dataset, name: str = "time") -> np.ndarray:
    """The ``time`` coordinate (or an instant variable, e.g. ``event_time``) as float64 in its
    plain unit (seconds since the epoch, or "1").

    Works on the Datasets of :func:`attitude.io.read` (the stored numbers, bit for bit) and on
    files opened by ``xarray.open_dataset`` with CF decoding (datetime64 converted back to
    seconds since the reference time of the encoding, to 1 ns; NaT to NaN).
    """
    t = ds[name]
    vals = np.asarray(t.values)
    if not np.issubdtype(vals.dtype, np.datetime64):
        return np.asarray(vals, dtype=np.float64)
    units = str(t.encoding.get("units", ""))
    if " since " in units:
        ref = np.datetime64(units.split(" since ", 1)[1].strip().replace(" ", "T").rstrip("Z"))
    else:
        from .errors import AttitudeValueError

        raise AttitudeValueError(
            f"{name}: decoded datetimes without their CF units (open the file with "
            "attitude.io.read, or xarray.open_dataset(..., decode_times=False))"
        )
    v = vals.astype("datetime64[ns]")
    ns = (v - ref.astype("datetime64[ns]")).astype(np.int64)
    return np.where(np.isnat(v), np.nan, ns.astype(np.float64) * 1e-9)


def set_time_attrs(ds: xr.Dataset) -> xr.Dataset:
    """Make the attrs of ``ds.time`` follow the global attr ``epoch`` (in place; returns ds).

    Call after setting ``ds.attrs["epoch"]``; :func:`attitude.io.write` and
    :class:`attitude.io.StreamWriter` apply the same rule to the file.
    """
    if "time" in ds.variables:
        var = ds.variables["time"]
        units = time_unit(var)
        new = time_attrs(units, ds.attrs.get("epoch"))
        for k in ("standard_name", "axis", "calendar", "comment", "elapsed_time_units"):
            var.attrs.pop(k, None)
        var.attrs.update(new)
        for name in INSTANT_VARIABLES:
            if name in ds.variables:
                ds.variables[name].attrs.update(instant_attrs(units, ds.attrs.get("epoch")))
    return ds


def index_coords() -> dict[str, Any]:
    """The ``component``/``axis`` coordinates of every result Dataset.

    CF coordinate variables are numeric and monotonic: indices, with the letters in the
    auxiliary label coordinates ``component_label``/``axis_label`` (CF 1.11 sect. 6.1).
    """
    return {
        "component": (
            "component",
            np.arange(4, dtype=np.int32),
            {
                "long_name": "quaternion component index: 0 = w (scalar), 1 = x, 2 = y, 3 = z",
                "units": "1",
            },
        ),
        "component_label": (
            "component",
            np.array(COMPONENT_LABELS),
            {"long_name": "quaternion component (scalar first)"},
        ),
        "axis": (
            "axis",
            np.arange(3, dtype=np.int32),
            {"long_name": "vector component index: 0 = x, 1 = y, 2 = z", "units": "1"},
        ),
        "axis_label": ("axis", np.array(AXIS_LABELS), {"long_name": "vector component"}),
    }


def build_dataset(
    t: np.ndarray,
    y: np.ndarray,
    diag: np.ndarray,
    body: RigidBody,
    potential: Any,
    attrs: dict[str, Any],
    torques: np.ndarray | None = None,
    orbit: Any = None,
) -> xr.Dataset:
    """Assemble the result Dataset from the states and their diagnostics.

    Parameters
    ----------
    t : ndarray, shape (m,)
        Output times.
    y : ndarray, shape (m, 8)
        Canonical states (q, Q).
    diag : ndarray, shape (m, 13)
        Diagnostics from ``_core.dynamics.diagnostics_with``.
    body : RigidBody
    potential : Potential
    attrs : dict
        Run description (method, tolerances, statistics...).
    torques : ndarray, shape (m, n_terms + 1, 3), optional
        Body torque of each term of the model and their sum (``_core.dynamics.term_torques_with``).
    orbit : Orbit, optional
        The orbit of the orbit variables (default the potential's): a coupled run's own.

    The orbit's variables (``r``, ``f``, ``p``) are computed here by the orbit's methods;
    :func:`dataset_from_samples` takes everything from one compiled pass instead.
    """

    def c(a: Any) -> np.ndarray:
        return np.ascontiguousarray(a, dtype=np.float64)

    blocks = {
        "q": c(y[:, :4]),
        "Q": c(y[:, 4:]),
        "omega": c(diag[:, 0:3]),
        "g": c(diag[:, 3:6]),
        "G": c(diag[:, 6:9]),
        "energy": c(diag[:, 9]),
        "potential_energy": c(diag[:, 12]),
        "norm_error": c(diag[:, 10]),
        "qQ": c(diag[:, 11]),
    }
    if orbit is None:
        orbit = getattr(potential, "orbit", None)
    if orbit is not None:
        # The orbit module works in km and s whatever the body's unit system.
        blocks["r"] = c(_plain(orbit.radius(t), "km"))
        blocks["f"] = c(_plain(orbit.true_anomaly(t), "rad"))
        blocks["p"] = c(_plain(orbit.frame_quaternion(t), None))
    if torques is not None:
        blocks["torque"] = c(torques)
    return _assemble(np.asarray(t, dtype=np.float64), blocks, body, potential, attrs)


def dataset_from_samples(
    t: np.ndarray,
    buf: np.ndarray,
    n_terms: int,
    body: RigidBody,
    potential: Any,
    attrs: dict[str, Any],
    has_orbit: bool,
) -> xr.Dataset:
    """Assemble the result Dataset from the buffer of one compiled pass over the samples.

    Parameters
    ----------
    t : ndarray, shape (m,)
        Output times.
    buf : ndarray, shape (m * (27 + 3 (n_terms + 1)),)
        Every per-sample variable, one contiguous block each (layout in
        :mod:`attitude._core.diagnostics`, written by the entry point ``samples``); the
        Dataset's variables are views of it.
    n_terms : int
        Number of terms of the model.
    body, potential, attrs
        As :func:`build_dataset`.
    has_orbit : bool
        Whether the orbit blocks were written (the potential has an orbit).
    """
    m = t.shape[0]
    blocks = {}
    for name, off, width in _kd.BLOCKS:
        if name in _ORBIT_BLOCKS and not has_orbit:
            continue
        v = buf[off * m : (off + width) * m]
        blocks[name] = v.reshape(m, width) if width > 1 else v
    w3 = 3 * (n_terms + 1)
    o = _kd.SAMPLE.SIZE * m
    blocks["torque"] = buf[o : o + w3 * m].reshape(m, n_terms + 1, 3)
    return _assemble(t, blocks, body, potential, attrs)


_ORBIT_BLOCKS = ("r", "f", "p")


def _assemble(
    t: np.ndarray, b: dict[str, np.ndarray], body: RigidBody, potential: Any, attrs: dict
) -> xr.Dataset:
    """The Dataset of the contiguous float64 arrays ``b`` (one per variable)."""
    u = UnitSystem(body)

    def var(dims, data, units, long_name):
        return _variable(dims, data, {"units": units, "long_name": long_name})

    tc = ("time", "component")
    ta = ("time", "axis")
    t1 = ("time",)
    data_vars = {
        "q": var(
            tc, b["q"], "1", "attitude quaternion (Euler parameters), body to space, scalar first"
        ),
        "Q": var(
            tc,
            b["Q"],
            u.momentum,
            "conjugate momenta of the Euler parameters, Q = 2 q o (0, g)",
        ),
        "omega": var(ta, b["omega"], u.rate, "angular velocity in body axes"),
        "g": var(ta, b["g"], u.momentum, "angular momentum in body axes"),
        "G": var(ta, b["G"], u.momentum, "angular momentum in space axes"),
        "energy": var(t1, b["energy"], u.energy, "total energy H = T + U"),
        "potential_energy": var(t1, b["potential_energy"], u.energy, "potential energy U"),
        "norm_error": var(t1, b["norm_error"], "1", "|q| - 1"),
        "qQ": var(t1, b["qQ"], u.momentum, "q . Q (zero on the constraint manifold)"),
    }
    if "r" in b:
        data_vars["r"] = var(t1, b["r"], SI["orbit_length"], "orbit radius")
        data_vars["f"] = var(t1, b["f"], "rad", "true anomaly")
        data_vars["p"] = var(
            tc,
            b["p"],
            "1",
            "orbital-frame quaternion p: x_S = p o x_O o conj(p) (x_O radial, y_O along-track, "
            "z_O orbit normal), scalar first",
        )
    names = None
    if "torque" in b:
        names = (*potential.term_names(), "total")
        data_vars["torque"] = var(
            ("time", "model", "axis"),
            b["torque"],
            u.torque,
            "body-frame torque of each model term and their sum (model = total)",
        )
        missing = getattr(potential, "terms_without_potential", None)
        if missing:
            attrs = {**attrs, "terms_without_potential": ", ".join(missing)}
    base = {
        "Conventions": "CF-1.11",
        "title": "attitude propagation",
        "history": f"{_utc_now()} attitude {__version__}: propagate",
        "source": f"attitude {__version__} (canonical quaternion propagator)",
        "package_version": __version__,
        "inertia": np.asarray(body.inertia, dtype=np.float64),
        "inertia_units": u.inertia,
        "potential": potential.describe(),
        "potential_name": potential.name,
        "quaternion_convention": (
            "scalar first (w, x, y, z), Hamilton product, q maps body to space"
        ),
    }
    base.update(attrs)
    return _result_dataset(data_vars, t, time_attrs(u.time, attrs.get("epoch")), names, base)


def _model_coords(names: tuple[str, ...]) -> dict[str, Any]:
    """The ``model``/``model_label`` coordinates of the torque terms ``names``."""
    return {
        "model": (
            "model",
            np.arange(len(names), dtype=np.int32),
            {"long_name": "torque model term index (labels in model_label)", "units": "1"},
        ),
        "model_label": ("model", np.array(names), {"long_name": "torque model term"}),
    }


def _result_dataset(
    data_vars: dict[str, xr.Variable],
    t: np.ndarray,
    tattrs: dict,
    names: tuple[str, ...] | None,
    attrs: dict,
) -> xr.Dataset:
    """The result Dataset of ``data_vars`` on the times ``t`` (attrs ``tattrs``), with the
    ``component``, ``axis`` and (torque terms ``names``) ``model`` coordinates: the constant
    coordinates and their indexes built once per set of names, copied with their own attrs."""

    def coords() -> dict[str, tuple]:
        c = {"time": ("time", t, tattrs), **index_coords()}
        return c if names is None else {**c, **_model_coords(names)}

    try:
        const = _CONSTANT_COORDS.get(names)
        if const is None:
            ds = _dataset({}, {k: v for k, v in coords().items() if k != "time"}, {})
            for v in ds.variables.values():  # shared by every result: read-only
                if isinstance(v._data, np.ndarray):
                    v._data.setflags(write=False)
            const = _CONSTANT_COORDS[names] = (dict(ds.variables), dict(ds.xindexes))
        cvars, cidx = const
        import pandas as pd
        from xarray.core.indexes import PandasIndex

        pidx = pd.Index(t, name="time", copy=False)
        tidx = PandasIndex(pidx, "time", coord_dtype=t.dtype, fastpath=True)
        tvar = tidx.create_variables()["time"]
        tvar.attrs = tattrs
        variables = {**data_vars, "time": tvar}
        for k, v in cvars.items():
            variables[k] = _shallow_copy(v)
        indexes = {"time": tidx, **cidx}
        dims = {"time": t.shape[0], "component": 4, "axis": 3}
        if names is not None:
            dims["model"] = len(names)
        return xr.Dataset._construct_direct(variables, {"time", *cvars}, dims, attrs, indexes)
    except (ImportError, AttributeError, TypeError):  # pragma: no cover - xarray internals moved
        return _dataset(data_vars, coords(), attrs)


# The constant coordinates of the result Datasets (variables and indexes) by torque terms.
_CONSTANT_COORDS: dict[Any, tuple[dict, dict]] = {}


def _shallow_copy(v: xr.Variable) -> xr.Variable:
    """``v.copy(deep=False)`` (same data, own attrs and encoding) without its overhead."""
    if not _RAW_VARIABLES:
        return v.copy(deep=False)
    w = _new_variable(type(v))
    w._dims = v._dims
    w._data = v._data
    w._attrs = None if v._attrs is None else dict(v._attrs)
    w._encoding = None if v._encoding is None else dict(v._encoding)
    return w


def _variable(dims: tuple | str, data: Any, attrs: dict) -> xr.Variable:
    """``xr.Variable(dims, data, attrs, fastpath=True)`` for a numpy array whose dims match its
    shape, without the constructor's checks (a fifth of its cost: the Dataset has twenty
    variables); the public constructor on an xarray whose Variable is laid out otherwise, or
    for anything but a numeric or text array of as many dimensions as ``dims`` names.

    Also what keeps a run from importing dask (0.3 s) when it is installed: the public
    constructor imports ``dask.array`` to ask whether the data is one.
    """
    dims = (dims,) if isinstance(dims, str) else tuple(dims)
    if (
        not isinstance(data, np.ndarray)
        or data.ndim != len(dims)
        or data.dtype.kind not in "biufcUS"
    ):
        return xr.Variable(dims, data, attrs)
    if not _RAW_VARIABLES:
        return xr.Variable(dims, data, attrs, fastpath=True)
    v = _new_variable(xr.Variable)
    v._dims = dims
    v._data = data
    v._attrs = attrs
    v._encoding = None
    return v


_new_variable = object.__new__
_RAW_VARIABLES = set(getattr(xr.Variable, "__slots__", ())) == {
    "_attrs",
    "_data",
    "_dims",
    "_encoding",
} and all(
    getattr(c, "__new__", object.__new__) is object.__new__
    for c in xr.Variable.__mro__
    if c is not object and "__new__" in vars(c)
)


def _dataset(
    data_vars: dict[str, xr.Variable], coords: dict[str, tuple], attrs: dict
) -> xr.Dataset:
    """``xr.Dataset(data_vars, coords=coords, attrs=attrs)``, assembled directly.

    The public constructor merges and aligns its arguments (about 0.4 ms, most of a short
    ``propagate`` call); here every variable already has its final dims, dtype and attrs and
    every coordinate is 1-D (a dimension coordinate, indexed, or an auxiliary label
    coordinate), so the Dataset is put together from its parts (variables, default pandas
    indexes of the dimension coordinates, dims). tests/test_results_fast.py checks that the
    result is identical to the public constructor's; on an xarray without the internals used
    here the public constructor is used.
    """
    try:
        import pandas as pd
        from xarray.core.indexes import PandasIndex

        coord_vars: dict[str, Any] = {}
        indexes: dict[str, Any] = {}
        for name, (dim, values, vattrs) in coords.items():
            values = np.asarray(values)
            if name != dim:  # an auxiliary (label) coordinate: no index
                coord_vars[name] = _variable((dim,), values, dict(vattrs))
                continue
            idx = PandasIndex(pd.Index(values), dim, coord_dtype=values.dtype)
            cvar = idx.create_variables({name: _variable(dim, values, dict(vattrs))})[name]
            coord_vars[name] = cvar
            indexes[name] = idx
        variables = {**data_vars, **coord_vars}  # the public constructor's order
        dims: dict[str, int] = {}
        for v in coord_vars.values():
            dims.update(zip(v.dims, v.shape, strict=True))
        return xr.Dataset._construct_direct(variables, set(coords), dims, attrs, indexes)
    except (ImportError, AttributeError, TypeError):  # pragma: no cover - xarray internals moved
        return xr.Dataset(
            data_vars, coords={k: (d, v, a) for k, (d, v, a) in coords.items()}, attrs=attrs
        )


def add_event_variables(
    ds: xr.Dataset,
    evset: Any,
    records: Any,
    body: RigidBody,
    status: int,
    omega: np.ndarray | None = None,
) -> xr.Dataset:
    """The run's events as variables on an ``event`` dimension (docs/events.md).

    ``event`` (coordinate: occurrence number), ``event_time``, ``event_detector`` (which event:
    an index of the ``detector`` dimension, labelled by ``detector_label``),
    ``event_direction`` (+1 rising, −1 falling), ``event_q``, ``event_Q``, ``event_omega`` (the
    state there); per detector ``detector_count`` and ``detector_first_time`` (NaN: none).
    Attrs ``status`` ("success" or "event": a terminal event ended the run) and
    ``terminal_event`` (its label and time). ``omega`` (k, 3): the body rates at the events
    when they are not those of the rigid body's (q, Q) (a spacecraft's wheels).
    """
    from orbit import _rk

    u = UnitSystem(body)
    k = records.t.shape[0]
    y = records.y.reshape(k, -1)[:, :8] if k else np.empty((0, 8))
    if omega is None:
        g = 0.5 * _conj_mul_vec(y[:, :4], y[:, 4:])
        omega = g / np.asarray(body.inertia, dtype=np.float64)
    n = len(evset.labels)

    def var(dims, data, units, long_name, encoding=None):
        attrs = {"long_name": long_name, **(encoding or {})}
        if units is not None:
            attrs = {"units": units, **attrs}
        return _variable(dims, np.ascontiguousarray(data), attrs)

    when = instant_attrs(u.time, ds.attrs.get("epoch"))  # encoded as `time` (docs/results.md)
    new = {
        "event_time": var(("event",), records.t, None, "time of the event", when),
        "event_detector": var(
            ("event",),
            records.which.astype(np.int64),
            None,
            "which event occurred (index of the detector dimension)",
        ),
        "event_direction": var(
            ("event",),
            records.direction.astype(np.int64),
            "1",
            "direction of the sign change of g: 1 rising, -1 falling",
        ),
        "event_q": var(("event", "component"), y[:, :4], "1", "attitude quaternion at the event"),
        "event_Q": var(("event", "component"), y[:, 4:], u.momentum, "momenta at the event"),
        "event_omega": var(
            ("event", "axis"), omega, u.rate, "angular velocity in body axes at the event"
        ),
        "detector_count": var(
            ("detector",), records.count.astype(np.int64), "1", "occurrences of each event"
        ),
        "detector_first_time": var(
            ("detector",), records.first, None, "time of the first occurrence (NaN: none)", when
        ),
    }
    coords = {
        "event": _variable(
            "event", np.arange(k, dtype=np.int64), {"long_name": "event occurrence"}
        ),
        "detector": _variable(
            "detector",
            np.arange(n, dtype=np.int64),
            {"long_name": "index of the event detector (labels in detector_label)"},
        ),
        "detector_label": _variable(
            "detector", np.array(evset.labels), {"long_name": "event name"}
        ),
    }
    out = ds.assign_coords(coords).assign(new)
    out.attrs = dict(ds.attrs)
    impact = "impact_time" in ds.attrs  # the run's own stop (its attrs say so already)
    terminal = status == _rk.EVENT and not impact
    if not impact:
        out.attrs["status"] = "event" if terminal else "success"
    if terminal and k:
        j = int(records.which[-1])
        out.attrs["terminal_event"] = f"{evset.labels[j]} at t = {float(records.t[-1])!r}"
    return out


def _conj_mul_vec(q: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """vec(q̃∘Q) for rows of quaternions."""
    w0, w1, w2, w3 = (q[:, i] for i in range(4))
    Q0, Q1, Q2, Q3 = (Q[:, i] for i in range(4))
    return np.stack(
        [
            w0 * Q1 - w1 * Q0 - w2 * Q3 + w3 * Q2,
            w0 * Q2 + w1 * Q3 - w2 * Q0 - w3 * Q1,
            w0 * Q3 - w1 * Q2 + w2 * Q1 - w3 * Q0,
        ],
        axis=-1,
    )
