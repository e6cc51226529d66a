"""Statistics over ensemble members: percentiles of pointing error, body rates, event times."""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from orbit import _rk

from .._validation import as_bool, as_float_array
from ..errors import AttitudeTypeError, AttitudeValueError

# ------------------------------------------------------------------------------------------------
# statistics over members
# ------------------------------------------------------------------------------------------------


#: The percentiles the statistics functions compute when none are given.
DEFAULT_PERCENTILES = (5.0, 50.0, 95.0)

#: Variables of a statistics-only result (``propagate_ensemble(..., output="statistics")``).
STORED = {"pointing": "pointing_error_percentiles", "omega": "omega_norm_percentiles"}


def _stored(ds: Any, which: str) -> xr.DataArray | None:
    """The stored percentiles of a statistics-only result, or None (a result with members)."""
    name = STORED[which]
    if isinstance(ds, xr.Dataset) and name in ds and "q" not in ds:
        return ds[name]
    return None


def _select_stored(da: xr.DataArray, p: np.ndarray) -> xr.DataArray:
    have = np.asarray(da["percentile"].values, dtype=np.float64)
    idx = []
    for x in p:
        hit = np.flatnonzero(np.isclose(have, x, rtol=0, atol=1e-9))
        if not hit.size:
            raise AttitudeValueError(
                f"percentiles: this result holds statistics only, for the percentiles "
                f"{', '.join(f'{v:g}' for v in have)}; {x:g} was not computed (choose among "
                "those, or run with percentiles=...)"
            )
        idx.append(int(hit[0]))
    return da.isel(percentile=idx)


def _check_ensemble(ds: Any, var: str) -> xr.DataArray:
    if not isinstance(ds, xr.Dataset):
        raise AttitudeTypeError(f"ds: expected an xarray.Dataset, got {type(ds).__name__}")
    if not isinstance(var, str):
        raise AttitudeTypeError(f"variable: expected a variable name (str), got {var!r}")
    if var not in ds or "member" not in ds[var].dims:
        raise AttitudeValueError(
            f"ds: expected an ensemble result with a variable {var!r} over 'member' "
            "(from attitude.propagate_ensemble)"
        )
    return ds[var]


def _successful(ds: xr.Dataset) -> xr.Dataset:
    """The members that did not fail: failed ones hold NaN after their failure and are left
    out of the statistics; members ended by a terminal event count up to the event (NaN after
    it, skipped by the percentiles)."""
    if "member_status" in ds and ds["member_status"].dims == ("member",):
        st = np.asarray(ds["member_status"].values)
        ok = (st == _rk.SUCCESS) | (st == _rk.EVENT)
        if not ok.all():
            if not ok.any():
                raise AttitudeValueError("ds: every member failed (member_status); no statistics")
            ds = ds.isel(member=np.flatnonzero(ok))
    return ds


def _percentiles(percentiles: Any) -> np.ndarray:
    p = as_float_array(percentiles, "percentiles")
    p = np.atleast_1d(p)
    if p.ndim != 1 or p.size == 0 or np.any((p < 0) | (p > 100)):
        raise AttitudeValueError(
            f"percentiles: expected numbers in [0, 100], e.g. (5, 50, 95), got {p.tolist()}"
        )
    return p


def _over_members(err: xr.DataArray, p: np.ndarray) -> xr.DataArray:
    if err.chunks is not None:  # dask: quantiles need every member of a time in one block
        err = err.chunk({"member": -1})
    out = err.quantile(p / 100.0, dim="member")
    return out.rename(quantile="percentile").assign_coords(percentile=p)


def _mean_attitude(q: xr.DataArray) -> np.ndarray:
    """Average attitude per time: the dominant eigenvector of Σ q qᵀ over members.

    Markley, Cheng, Crassidis & Oshman, J. Guid. Control Dyn. 30, 1193 (2007), eq. 12: it
    maximises Σ (q·q̄)², the chordal mean, and is insensitive to the sign of each q.
    """
    q2 = q.rename(component="component_b")
    M = xr.dot(q, q2, dim="member").transpose("time", "component", "component_b").values
    _, vecs = np.linalg.eigh(M)
    qm = vecs[..., :, -1]
    return qm * np.where(qm[..., :1] < 0, -1.0, 1.0)


def has_nominal(ds: xr.Dataset) -> bool:
    """Whether ``ds`` stores the ensemble's reference attitude ``reference_q`` (time, component)
    (not the flight software's guidance reference of a closed-loop ensemble, (member, tick,
    component), which has the same name)."""
    return "reference_q" in ds and ds["reference_q"].dims == ("time", "component")


def _reference(ds: xr.Dataset, q: xr.DataArray, reference: Any) -> xr.DataArray:
    m = ds.sizes["time"]
    if reference is None:
        reference = "nominal" if has_nominal(ds) else "mean"
    if isinstance(reference, str):
        if reference not in ("mean", "nominal"):
            raise AttitudeValueError(
                f"reference: expected 'mean', 'nominal', a member index, a Dataset with q (a "
                f"nominal run) or quaternions (4,) / (time, 4), got {reference!r}"
            )
        if reference == "nominal":
            if not has_nominal(ds):
                raise AttitudeValueError(
                    "reference: 'nominal' needs the reference attitude stored with the "
                    "ensemble (reference_q: propagate_ensemble(..., nominal=(q0, Q0)) or a "
                    "scenario run); this result has none"
                )
            ref = np.asarray(ds["reference_q"].transpose("time", "component").values)
        else:
            ref = _mean_attitude(q)
    elif isinstance(reference, (int, np.integer)) and not isinstance(reference, bool):
        if int(reference) not in set(ds["member"].values.tolist()):
            raise AttitudeValueError(f"reference: no member {reference} in ds")
        ref = np.asarray(q.sel(member=int(reference)).transpose("time", "component").values)
    elif isinstance(reference, xr.Dataset):
        if "q" not in reference or "member" in reference["q"].dims:
            raise AttitudeValueError("reference: a Dataset must be one run with q (time, 4)")
        rt = reference["time"].values
        if rt.shape != (m,) or not np.array_equal(rt, ds["time"].values):
            raise AttitudeValueError(
                "reference: the nominal run must have the ensemble's output times exactly "
                "(propagate it with the same t)"
            )
        ref = np.asarray(reference["q"].transpose("time", "component").values)
    else:
        ref = as_float_array(reference, "reference", trailing=4)
        if ref.shape not in ((4,), (m, 4)):
            raise AttitudeValueError(
                f"reference: expected shape (4,) or (time, 4) = ({m}, 4), got {ref.shape}"
            )
        ref = np.broadcast_to(ref, (m, 4))
    nr = np.linalg.norm(ref, axis=-1)
    if np.any(np.abs(nr - 1.0) > 1e-6):
        raise AttitudeValueError("reference: quaternions must be unit quaternions")
    return xr.DataArray(ref / nr[:, None], dims=("time", "component"))


def _error_angles(q, r, axis):
    """Angle between attitudes q (..., 4) and r (..., 4), or between q b and r b (rad)."""
    from ..quaternion import multiply, rotate

    if axis is None:
        w = multiply(r * np.array([1.0, -1.0, -1.0, -1.0]), q)
        return 2.0 * np.arctan2(np.linalg.norm(w[..., 1:], axis=-1), np.abs(w[..., 0]))
    u = rotate(q, axis)
    v = rotate(r, axis)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def pointing_error_percentiles(
    ds: xr.Dataset,
    reference: Any = None,
    percentiles: Any = DEFAULT_PERCENTILES,
    *,
    axis: Any = None,
    degrees: bool = False,
) -> xr.DataArray:
    """Percentiles over members of the attitude (or boresight) error against time.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result (:func:`propagate_ensemble`), in memory or lazy (dask). A
        statistics-only result (``output="statistics"``) gives its stored percentiles. Members
        that failed (``member_status`` other than success or a terminal event) are left out.
    reference : None, "nominal", "mean", int, Dataset or array_like shape (4,) or (time, 4)
        What the error is measured from. None (default): the reference stored with the
        ensemble (``reference_q``: the nominal state propagated once, as in a scenario run),
        else ``"mean"``. ``"nominal"``: the stored one; ``"mean"``: the average attitude of
        the members at each time (Markley et al. 2007); a member index; a nominal
        ``propagate`` result with the same times; or reference quaternions.
    percentiles : sequence of float
        Percentiles in [0, 100] (linear interpolation between members, as ``np.percentile``).
    axis : array_like, shape (3,), optional
        A body axis (boresight). Given, the error is the angle between the directions this
        axis points to in space, q b q̃ and q_ref b q̃_ref; otherwise the total rotation
        angle 2 atan2(|vec(q̃_ref∘q)|, |scalar(q̃_ref∘q)|) in [0, π].
    degrees : bool
        Degrees instead of radians.

    Returns
    -------
    xarray.DataArray, dims (percentile, time)
    """
    degrees = as_bool(degrees, "degrees")
    stored = _stored(ds, "pointing")
    if stored is not None:
        nominal = reference is None or (isinstance(reference, str) and reference == "nominal")
        if not nominal or axis is not None:
            raise AttitudeValueError(
                "reference: this result holds statistics only, measured from its stored "
                "reference (reference_q); other references and axes need the members "
                "(output='samples')"
            )
        out = _select_stored(stored, _percentiles(percentiles))
        if degrees:
            out = np.degrees(out)
            out.attrs = {**stored.attrs, "units": "deg"}
        return out.rename("pointing_error")
    _check_ensemble(ds, "q")
    ds = _successful(ds)
    q = ds["q"]
    p = _percentiles(percentiles)
    b = None
    if axis is not None:
        b = as_float_array(axis, "axis", trailing=3, ndim=1)
        nb = float(np.linalg.norm(b))
        if nb == 0.0:
            raise AttitudeValueError("axis: the zero vector is not a direction")
        b = b / nb
    ref = _reference(ds, q, reference)
    err = xr.apply_ufunc(
        _error_angles,
        q,
        ref,
        kwargs={"axis": b},
        input_core_dims=[["component"], ["component"]],
        dask="parallelized",
        output_dtypes=[np.float64],
    )
    if degrees:
        err = np.degrees(err)
    out = _over_members(err.transpose("member", "time"), p)
    kind = "boresight pointing error" if b is not None else "attitude error angle"
    out.attrs = {
        "units": "deg" if degrees else "rad",
        "long_name": f"percentiles over members of the {kind}",
        "reference": (
            reference
            if isinstance(reference, str)
            else ("nominal" if reference is None and has_nominal(ds) else "given")
        ),
    }
    return out.rename("pointing_error")


def rate_percentiles(
    ds: xr.Dataset,
    percentiles: Any = DEFAULT_PERCENTILES,
    *,
    norm: bool = True,
    variable: str = "omega",
    degrees: bool = False,
) -> xr.DataArray:
    """Percentiles over members of the body angular velocity against time.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result (:func:`propagate_ensemble`).
    percentiles : sequence of float
        Percentiles in [0, 100].
    norm : bool
        True (default): of the magnitude |ω|; False: of each body-axis component.
    variable : str
        ``"omega"`` (default) or another (member, time, axis) variable (``"g"``, ``"G"``).
    degrees : bool
        Angular velocity in degrees (deg s^-1; per time unit for a dimensionless run)
        instead of radians, as ``pointing_error_percentiles(degrees=True)``.

    Returns
    -------
    xarray.DataArray, dims (percentile, time) or (percentile, time, axis)
        In the variable's units (or degrees).
    """
    norm = as_bool(norm, "norm")
    degrees = as_bool(degrees, "degrees")
    if not isinstance(variable, str):
        raise AttitudeTypeError(f"variable: expected a variable name (str), got {variable!r}")
    if degrees and variable != "omega":
        raise AttitudeValueError(
            f"degrees: only for the angular velocity (variable='omega'), not {variable!r}"
        )
    stored = _stored(ds, "omega") if variable == "omega" else None
    if stored is not None:
        if not norm:
            raise AttitudeValueError(
                "norm: this result holds statistics only, of |omega|; the components need the "
                "members (output='samples')"
            )
        out = _select_stored(stored, _percentiles(percentiles))
        if degrees:
            out = _to_degrees(out, str(stored.attrs.get("units", "1")))
        return out.rename("omega_percentiles")
    _check_ensemble(ds, variable)
    ds = _successful(ds)
    w = ds[variable]
    if "axis" not in w.dims:
        raise AttitudeValueError(f"variable: {variable!r} is not a (member, time, axis) vector")
    p = _percentiles(percentiles)
    val = np.sqrt((w * w).sum("axis")) if norm else w
    out = _over_members(val, p)
    what = f"|{variable}|" if norm else f"{variable} components"
    out.attrs = {
        "units": w.attrs.get("units", ""),
        "long_name": f"percentiles over members of {what}",
    }
    if degrees:
        out = _to_degrees(out, str(w.attrs.get("units", "1")))
    return out.rename(f"{variable}_percentiles")


def event_time_percentiles(
    ds: xr.Dataset,
    percentiles: Any = DEFAULT_PERCENTILES,
) -> xr.Dataset:
    """Percentiles over members of the time of each event's first occurrence.

    "Time until the pointing error exceeds 5°": members where the event never occurred
    (``event_first_time`` NaN) are left out of the percentiles and counted in
    ``fraction_with_event``.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result with events (``propagate_ensemble(..., events=[...])`` or a
        scenario with an ``[events]`` table).
    percentiles : sequence of float
        Percentiles in [0, 100] (linear interpolation, as ``np.nanpercentile``).

    Returns
    -------
    xarray.Dataset
        ``first_time`` (percentile, detector): the percentiles (NaN for an event no member
        had); ``fraction_with_event`` (detector); ``mean_count`` (detector): occurrences per
        member; coordinates ``detector`` and ``detector_label``.
    """
    first = _check_ensemble(ds, "event_first_time")
    count = _check_ensemble(ds, "event_count")
    p = _percentiles(percentiles)
    from ..results import time_values

    # seconds since the epoch, also from a file whose times xarray decoded to datetimes
    tf = time_values(first.transpose("member", "detector").to_dataset(name="t"), "t")
    cnt = np.asarray(count.transpose("member", "detector").values, dtype=np.float64)
    have = np.isfinite(tf)
    q = np.full((p.size, tf.shape[1]), np.nan)
    for j in range(tf.shape[1]):
        if have[:, j].any():
            q[:, j] = np.percentile(tf[have[:, j], j], p)
    coords = {
        "percentile": ("percentile", p),
        "detector": ds["detector"].variable,
    }
    if "detector_label" in ds.coords:
        coords["detector_label"] = ds["detector_label"].variable
    when = {  # the encoding of `time` (docs/results.md), also after CF decoding
        k: first.attrs.get(k, first.encoding.get(k))
        for k in ("units", "calendar", "units_metadata", "elapsed_time_units")
        if k in first.attrs or k in first.encoding
    }
    return xr.Dataset(
        {
            "first_time": (
                ("percentile", "detector"),
                q,
                {**when, "long_name": "percentiles over members of the first event time"},
            ),
            "fraction_with_event": (
                ("detector",),
                have.mean(axis=0),
                {"units": "1", "long_name": "fraction of members where the event occurred"},
            ),
            "mean_count": (
                ("detector",),
                cnt.mean(axis=0),
                {"units": "1", "long_name": "mean number of occurrences per member"},
            ),
        },
        coords=coords,
        attrs={"ensemble_size": np.int64(tf.shape[0])},
    )


def _to_degrees(da: xr.DataArray, units: str) -> xr.DataArray:
    """An angular velocity in rad s^-1 (or rad per time unit: units "1") in degrees."""
    if units != "1" and not units.startswith("rad"):
        raise AttitudeValueError(
            f"degrees: the variable's unit {units!r} is not an angular velocity in radians"
        )
    out = np.degrees(da)
    out.attrs = {**da.attrs, "units": "deg" if units == "1" else "deg" + units[3:]}
    if units == "1":
        out.attrs["comment"] = "degrees per time unit (a dimensionless run)"
    return out


# ------------------------------------------------------------------------------------------------
# closed loop: the flight software's pointing error per tick
# ------------------------------------------------------------------------------------------------


def _error_angle(ds: Any, variable: str) -> xr.DataArray:
    da = _check_ensemble(ds, variable)
    if da.dims != ("member", "tick"):
        raise AttitudeValueError(
            f"variable: {variable!r} is not a (member, tick) variable of an ensemble with flight "
            "software (error_angle: the software's attitude error from its guidance)"
        )
    return da


def error_angle_percentiles(
    ds: xr.Dataset,
    percentiles: Any = DEFAULT_PERCENTILES,
    *,
    variable: str = "error_angle",
    degrees: bool = False,
) -> xr.DataArray:
    """Percentiles over members of the flight software's pointing error at every tick.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result with flight software (``propagate_ensemble(..., software=...)``).
    percentiles : sequence of float
        Percentiles in [0, 100].
    variable : str
        A (member, tick) variable: ``"error_angle"`` (default; the angle between the attitude
        the software acts on and its reference, rad) or another.
    degrees : bool
        In degrees instead of radians (``error_angle``).

    Returns
    -------
    xarray.DataArray, dims (percentile, tick)
    """
    degrees = as_bool(degrees, "degrees")
    _error_angle(ds, variable)
    ds = _successful(ds)
    da = ds[variable]
    p = _percentiles(percentiles)
    out = _over_members(da, p)
    out.attrs = {"units": da.attrs.get("units", ""),
                 "long_name": f"percentiles over members of {variable}"}  # fmt: skip
    if degrees:
        out = _to_degrees(out, str(da.attrs.get("units", "1")))
    return out.rename(f"{variable}_percentiles")


def settling_times(
    ds: xr.Dataset, threshold: Any, *, variable: str = "error_angle", after: Any = None
) -> xr.DataArray:
    """Each member's settling time: the first recorded tick from which ``variable`` stays
    at or below ``threshold`` to the end of the run.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result with flight software.
    threshold : float or Quantity
        In the variable's units (rad for ``error_angle``; an angle Quantity is converted).
    variable : str
        A (member, tick) variable (default ``"error_angle"``).
    after : float, optional
        Only ticks at or after this time count (e.g. after a slew's start; default all).

    Returns
    -------
    xarray.DataArray, dims (member,)
        The tick's time (the ``tick`` coordinate's values: seconds, or datetime for a dated
        run) relative to the run's first tick, in seconds; NaN for a member that has not
        settled by its last recorded tick (or failed before it, or whose variable is NaN at
        the last tick).
    """
    from astropy import units as u

    da = _error_angle(ds, variable)
    if isinstance(threshold, u.Quantity):
        try:
            threshold = threshold.to_value(u.rad)
        except u.UnitConversionError:
            raise AttitudeValueError(
                f"threshold: units {threshold.unit} are not an angle"
            ) from None
    thr = float(as_float_array(threshold, "threshold", ndim=0))
    if not thr > 0:
        raise AttitudeValueError(f"threshold: expected a positive value, got {thr!r}")
    from ..results import time_values

    tick = np.asarray(time_values(ds, "tick"), dtype=np.float64)
    x = np.asarray(da.transpose("member", "tick").values, dtype=np.float64)
    use = np.ones(tick.shape, dtype=bool) if after is None else tick >= float(after)
    if not use.any():
        raise AttitudeValueError(f"after: no recorded tick at or after {after!r}")
    x = x[:, use]
    tt = tick[use]
    bad = ~(x <= thr)  # above the threshold, or NaN
    # the last tick above the threshold; settled at the next one
    last_bad = np.where(bad.any(axis=1), x.shape[1] - 1 - np.argmax(bad[:, ::-1], axis=1), -1)
    settled = last_bad + 1
    out = np.full(x.shape[0], np.nan)
    ok = settled < x.shape[1]
    out[ok] = tt[settled[ok]] - tick[0]
    return xr.DataArray(
        out,
        dims=("member",),
        coords={"member": ds["member"].values},
        attrs={"units": "s", "long_name": f"settling time: {variable} <= {thr:g} from then on"},
        name="settling_time",
    )
