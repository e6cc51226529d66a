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

__all__ = ["UnitSystem", "add_event_variables", "build_dataset"]


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
            self.length = self.torque = "1"
        else:
            self.time = "s"
            self.inertia = "kg km2"
            self.momentum = "kg km2 s-1"
            self.energy = "kg km2 s-2"
            self.rate = "rad s-1"
            self.length = "km"
            self.torque = "kg km2 s-2"


def build_dataset(
    t: np.ndarray,
    y: np.ndarray,
    diag: np.ndarray,
    body: RigidBody,
    potential: Any,
    attrs: dict[str, Any],
    torques: np.ndarray | None = None,
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
    torques : ndarray, shape (m, n_terms + 1, 3), optional
        Body torque of each term of the model and their sum (``_core.dynamics.term_torques_with``).
    """
    u = UnitSystem(body)
    comp = ["w", "x", "y", "z"]
    axis = ["x", "y", "z"]

    def var(dims, data, units, long_name, **extra):
        return xr.Variable(
            dims, np.ascontiguousarray(data), {"units": units, "long_name": long_name, **extra}
        )

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
    extra_coords = {}
    if torques is not None:
        names = [*potential.term_names(), "total"]
        data_vars["torque"] = var(
            ("time", "model", "axis"),
            torques,
            u.torque,
            "body-frame torque of each model term and their sum (model = total)",
        )
        extra_coords = {
            "model": (
                "model",
                np.arange(len(names), dtype=np.int64),
                {"long_name": "index of the torque model term (labels in model_label)"},
            ),
            "model_label": ("model", np.array(names), {"long_name": "torque model term"}),
        }
        missing = getattr(potential, "terms_without_potential", None)
        if missing:
            attrs = {**attrs, "terms_without_potential": ", ".join(missing)}
    coords = {
        **extra_coords,
        "time": (
            "time",
            np.asarray(t, dtype=np.float64),
            {"units": u.time, "long_name": "time since the scenario epoch"},
        ),
        "component": ("component", comp, {"long_name": "quaternion component, scalar first"}),
        "axis": ("axis", axis, {"long_name": "vector component"}),
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
    return xr.Dataset(data_vars, coords=coords, attrs=base)


def add_event_variables(
    ds: xr.Dataset, evset: Any, records: Any, body: RigidBody, status: int
) -> xr.Dataset:
    """The run's events as variables on an ``event`` dimension (docs/events.md).

    ``event`` (coordinate: occurrence number), ``event_time``, ``event_detector`` (which event:
    an index of the ``detector`` dimension, labelled by ``detector_label``),
    ``event_direction`` (+1 rising, −1 falling), ``event_q``, ``event_Q``, ``event_omega`` (the
    state there); per detector ``detector_count`` and ``detector_first_time`` (NaN: none).
    Attrs ``status`` ("success" or "event": a terminal event ended the run) and
    ``terminal_event`` (its label and time).
    """
    from ._core import rk as _rk

    u = UnitSystem(body)
    k = records.t.shape[0]
    y = records.y.reshape(k, 8)
    g = 0.5 * _conj_mul_vec(y[:, :4], y[:, 4:])
    omega = g / np.asarray(body.inertia, dtype=np.float64)
    n = len(evset.labels)

    def var(dims, data, units, long_name, **extra):
        attrs = {"long_name": long_name, **extra}
        if units is not None:
            attrs = {"units": units, **attrs}
        return xr.Variable(dims, np.ascontiguousarray(data), attrs)

    new = {
        "event_time": var(("event",), records.t, u.time, "time of the event"),
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
            ("detector",), records.first, u.time, "time of the first occurrence (NaN: none)"
        ),
    }
    coords = {
        "event": ("event", np.arange(k, dtype=np.int64), {"long_name": "event occurrence"}),
        "detector": (
            "detector",
            np.arange(n, dtype=np.int64),
            {"long_name": "index of the event detector (labels in detector_label)"},
        ),
        "detector_label": ("detector", np.array(evset.labels), {"long_name": "event name"}),
    }
    out = ds.assign_coords(coords).assign(new)
    out.attrs = dict(ds.attrs)
    terminal = status == _rk.EVENT
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
