"""The propagation result: one xarray Dataset schema for every method and formulation.

See docs/results.md for the schema. Units are strings that ``astropy.units.Unit`` parses and
CF tools understand; a body given without units gives dimensionless results (``"1"``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from ._version import __version__
from .body import RigidBody

__all__ = ["UnitSystem", "build_dataset"]


def _utc_now() -> str:
    """Current UTC time as ISO 8601 to the second, with a Z (for the CF ``history`` attr)."""
    import datetime

    now = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    return now.strftime("%Y-%m-%dT%H:%M:%SZ")


def _plain(x: Any, unit: str | None) -> np.ndarray:
    """Float64 array of ``x`` (an astropy Quantity is converted to ``unit`` first)."""
    if hasattr(x, "unit") and hasattr(x, "to_value"):
        x = x.to_value(unit) if unit is not None else x.to_value()
    return np.asarray(x, dtype=np.float64)


class UnitSystem:
    """Unit strings of the result variables, from the body's unit system."""

    def __init__(self, body: RigidBody):
        if body.units is None:
            self.time = self.inertia = self.momentum = self.energy = self.rate = "1"
            self.length = "1"
        else:
            self.time = "s"
            self.inertia = "kg km2"
            self.momentum = "kg km2 s-1"
            self.energy = "kg km2 s-2"
            self.rate = "rad s-1"
            self.length = "km"


def build_dataset(
    t: np.ndarray,
    y: np.ndarray,
    diag: np.ndarray,
    body: RigidBody,
    potential: Any,
    attrs: dict[str, Any],
) -> xr.Dataset:
    """Assemble the result Dataset.

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
    """
    u = UnitSystem(body)
    comp = ["w", "x", "y", "z"]
    axis = ["x", "y", "z"]

    def var(dims, data, units, long_name, **extra):
        data = np.ascontiguousarray(data, dtype=np.float64)
        attrs = {"units": units, "long_name": long_name, **extra}
        return xr.Variable(dims, data, attrs, fastpath=True)

    data_vars = {
        "q": var(
            ("time", "component"),
            y[:, :4],
            "1",
            "attitude quaternion (Euler parameters), body to space, scalar first",
        ),
        "Q": var(
            ("time", "component"),
            y[:, 4:],
            u.momentum,
            "conjugate momenta of the Euler parameters, Q = 2 q o (0, g)",
        ),
        "omega": var(("time", "axis"), diag[:, 0:3], u.rate, "angular velocity in body axes"),
        "g": var(("time", "axis"), diag[:, 3:6], u.momentum, "angular momentum in body axes"),
        "G": var(("time", "axis"), diag[:, 6:9], u.momentum, "angular momentum in space axes"),
        "energy": var(("time",), diag[:, 9], u.energy, "total energy H = T + U"),
        "potential_energy": var(("time",), diag[:, 12], u.energy, "potential energy U"),
        "norm_error": var(("time",), diag[:, 10], "1", "|q| - 1"),
        "qQ": var(("time",), diag[:, 11], u.momentum, "q . Q (zero on the constraint manifold)"),
    }
    orbit = getattr(potential, "orbit", None)
    if orbit is not None:
        # The orbit module works in km and s whatever the body's unit system.
        data_vars["r"] = var(("time",), _plain(orbit.radius(t), "km"), "km", "orbit radius")
        data_vars["f"] = var(("time",), _plain(orbit.true_anomaly(t), "rad"), "rad", "true anomaly")
        data_vars["p"] = var(
            ("time", "component"),
            _plain(orbit.frame_quaternion(t), None),
            "1",
            "orbital-frame quaternion p: x_S = p o x_O o conj(p) (x_O radial, y_O along-track, "
            "z_O orbit normal), scalar first",
        )
    coords = {
        "time": (
            "time",
            np.asarray(t, dtype=np.float64),
            {"units": u.time, "long_name": "time since the scenario epoch"},
        ),
        "component": (
            "component",
            np.array(comp),
            {"long_name": "quaternion component, scalar first"},
        ),
        "axis": ("axis", np.array(axis), {"long_name": "vector component"}),
    }
    base = {
        "Conventions": "CF-1.10",
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
    return _dataset(data_vars, coords, base)


def _dataset(
    data_vars: dict[str, xr.Variable], coords: dict[str, tuple], attrs: dict
) -> xr.Dataset:
    """``xr.Dataset(data_vars, coords=coords, attrs=attrs)``, assembled directly.

    The public constructor merges and aligns its arguments (about 0.4 ms, most of a short
    ``propagate`` call); here every variable already has its final dims, dtype and attrs and
    every coordinate is a 1-D dimension coordinate, so the Dataset is put together from its
    parts (variables, default pandas indexes, dims). tests/test_results_fast.py checks that the
    result is identical to the public constructor's; on an xarray without the internals used
    here the public constructor is used.
    """
    try:
        import pandas as pd
        from xarray.core.indexes import PandasIndex

        coord_vars: dict[str, Any] = {}
        indexes: dict[str, Any] = {}
        for name, (dim, values, vattrs) in coords.items():
            key = (name, tuple(values), tuple(vattrs.items())) if values.dtype.kind == "U" else None
            if key is not None and key in _COORD_CACHE:
                idx, cvar = _COORD_CACHE[key]
                cvar = cvar.copy(deep=False)  # own attrs dict; the index is immutable
            else:
                idx = PandasIndex(pd.Index(values), dim, coord_dtype=values.dtype)
                cvar = idx.create_variables({name: xr.Variable((dim,), values, dict(vattrs))})[name]
                if key is not None:
                    _COORD_CACHE[key] = (idx, cvar.copy(deep=False))
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


# Default indexes of the constant string coordinates ("component", "axis"), reused.
_COORD_CACHE: dict[tuple, Any] = {}
