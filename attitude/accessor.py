"""The ``ds.attitude`` accessor on result Datasets (registered on import of this module).

>>> import attitude.accessor                                     # doctest: +SKIP
>>> ds.attitude.quantity("G")        # astropy Quantity, units from the variable's attrs
>>> ds.attitude.euler_angles("321")  # DataArray (time, angle): angle_1, angle_2, angle_3, rad
>>> ds.attitude.matrix()             # DataArray (time, row, col): x_S = R x_B
>>> ds.attitude.angle_between(other) # DataArray (time,) in rad
>>> ds.attitude.relative_to(frames.lvlh(orbit), degrees=True)  # pointing errors (Dataset)
>>> ds.attitude.propagated_orbit()   # the orbit a spacecraft carried (orbit.EphemerisOrbit)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from . import quaternion as _qt
from .errors import AttitudeValueError
from .results import INSTANT_VARIABLES, time_unit, time_values

__all__ = ["AttitudeAccessor"]


def _unit(units: str) -> Any:
    from astropy import units as u

    return u.dimensionless_unscaled if units in ("1", "") else u.Unit(units)


@xr.register_dataset_accessor("attitude")
class AttitudeAccessor:
    """Physical views of a propagation result (see docs/results.md)."""

    def __init__(self, ds: xr.Dataset):
        self._ds = ds

    # -- units --------------------------------------------------------------------------------
    def quantity(self, name: str) -> Any:
        """The variable or coordinate ``name`` as an astropy Quantity (its ``units`` attr).

        Parameters
        ----------
        name : str
            e.g. ``"time"``, ``"q"``, ``"G"``, ``"energy"``, ``"r"``. ``"time"`` gives the
            time since the epoch (s), also from a file whose times xarray decoded to datetimes.

        Returns
        -------
        astropy.units.Quantity
            Same shape as the variable.
        """
        ds = self._ds
        if name not in ds.variables:
            raise AttitudeValueError(
                f"name: no variable {name!r} in this Dataset; it has "
                + ", ".join(sorted(map(str, ds.variables)))
            )
        if name == "time" or name in INSTANT_VARIABLES:  # seconds since the epoch
            return time_values(ds, name) * _unit(time_unit(ds[name]))
        units = ds[name].attrs.get("units")
        if units is None:
            raise AttitudeValueError(f"name: variable {name!r} has no units attr")
        return np.asarray(ds[name].values, dtype=np.float64) * _unit(str(units))

    @property
    def epoch(self) -> Any:
        """The scenario epoch as an astropy Time (UTC), or None when the run has none."""
        e = self._ds.attrs.get("epoch")
        if not e:
            return None
        from astropy.time import Time

        return Time(str(e).rstrip("Z"), scale="utc", format="isot")

    def times(self) -> Any:
        """Absolute sample times: ``epoch + time`` as an astropy Time (needs an epoch)."""
        from astropy.time import TimeDelta

        if self.epoch is None:
            raise AttitudeValueError(
                "epoch: this run has no epoch attr (give the scenario, the orbit or "
                "propagate(..., epoch=...) an epoch) so its times are only relative: use "
                "ds.attitude.quantity('time')"
            )
        dt = self.quantity("time")
        return self.epoch + TimeDelta(dt.to_value("s"), format="sec")

    # -- attitude views ---------------------------------------------------------------------------
    def _q(self) -> np.ndarray:
        q = self._ds["q"]
        if "member" in q.dims:  # (the views are of one attitude history: (time, 4))
            raise AttitudeValueError("ds: an ensemble; select a member first (ds.isel(member=i))")
        return np.asarray(q.values, dtype=np.float64)

    def euler_angles(self, seq: str = "313") -> xr.DataArray:
        """Intrinsic Euler angles of ``q`` (body → space), :func:`attitude.quaternion.to_euler`.

        Parameters
        ----------
        seq : str
            One of the 12 sequences, digits 1, 2, 3 = body x, y, z; ``"313"`` is the paper's
            (φ, ϑ, ψ).

        Returns
        -------
        DataArray, shape (time, 3)
            Angles in rad, dims ``(time, angle)``; ``angle`` is labelled by position
            (``angle_1``, ``angle_2``, ``angle_3``: the rotations about the axes ``seq[0]``,
            ``seq[1]``, ``seq[2]``), the sequence is the attr ``sequence``.
        """
        a = _qt.to_euler(self._q(), seq)
        return xr.DataArray(
            a,
            dims=("time", "angle"),
            coords={"time": self._ds["time"], "angle": ["angle_1", "angle_2", "angle_3"]},
            attrs={
                "units": "rad",
                "long_name": f"intrinsic {seq} Euler angles, body to space",
                "sequence": seq,
                "convention": "intrinsic (rotations about the body axes), "
                f"q = q{seq[0]}(angle_1) o q{seq[1]}(angle_2) o q{seq[2]}(angle_3)",
            },
            name="euler_angles",
        )

    def matrix(self) -> xr.DataArray:
        """Rotation matrices R(q) with x_S = R x_B (columns: body axes in space components).

        Returns
        -------
        DataArray, shape (time, 3, 3)
            Dims ``(time, row, col)``.
        """
        return xr.DataArray(
            _qt.to_matrix(self._q()),
            dims=("time", "row", "col"),
            coords={"time": self._ds["time"]},
            attrs={"units": "1", "long_name": "rotation matrix body to space, x_S = R x_B"},
            name="R",
        )

    def angle_between(self, other: Any) -> xr.DataArray:
        """Rotation angle between this attitude history and ``other``, per sample, in [0, π].

        Parameters
        ----------
        other : Dataset or array_like, shape (4,) or (time, 4)
            Another result on the same time grid, or quaternions.

        Returns
        -------
        DataArray, shape (time,)
            Angles in rad.
        """
        if isinstance(other, xr.Dataset):
            t1, t2 = self._ds["time"].values, other["time"].values
            if t1.shape != t2.shape or not np.array_equal(t1, t2):
                raise AttitudeValueError(
                    "other: the two results must have the same output times (interpolate one "
                    "onto the other first)"
                )
            q2 = np.asarray(other["q"].values, dtype=np.float64)
        else:
            q2 = np.asarray(other, dtype=np.float64)
        ang = _qt.angle_between(self._q(), q2)
        return xr.DataArray(
            np.broadcast_to(ang, self._ds["time"].shape).copy(),
            dims=("time",),
            coords={"time": self._ds["time"]},
            attrs={"units": "rad", "long_name": "rotation angle between the two attitudes"},
            name="angle",
        )

    # -- reference frames -----------------------------------------------------------------------
    def relative_to(self, frame: Any, seq: str = "321", *, degrees: bool = False) -> xr.Dataset:
        """The attitude relative to a reference frame: error quaternion, angles, rates.

        With q_R(t), ω_R(t) the frame's attitude and angular velocity (:mod:`attitude.frames`):
        the error quaternion q_BR = q̃_R∘q (body → reference, scalar first), the error angle
        2 atan2(|vec q_BR|, |q_BR,0|) in [0, π], the intrinsic Euler angles of q_BR in the
        sequence ``seq`` (for an asymmetric sequence also named ``roll``, ``pitch``, ``yaw``:
        the angles about x, y, z; the default 3-2-1 is yaw, pitch, roll), and the body rates
        relative to the frame ω_BR = ω − q̃_BR∘ω_R∘q_BR (body axes).

        Parameters
        ----------
        frame : attitude.frames.Frame
            E.g. ``frames.lvlh(orbit)``; a frame with an orbit needs the run's times in seconds
            since the orbit's epoch (the run's epoch, if it has one, must be the orbit's).
        seq : str
            Euler sequence (digits 1, 2, 3 = body x, y, z), default ``"321"``.
        degrees : bool
            Angles in degrees and rates in deg/s (deg per time unit) instead of rad.

        Returns
        -------
        xarray.Dataset
            ``q_BR`` (time, component), ``error_angle`` (time), ``euler_angles`` (time, angle)
            with ``angle_label``, ``roll``/``pitch``/``yaw`` (time) for asymmetric sequences,
            ``omega_BR`` (time, axis).
        """
        from .frames import Frame

        if not isinstance(frame, Frame):
            raise AttitudeValueError(
                f"frame: expected a reference frame from attitude.frames (lvlh(orbit), ...), "
                f"got {type(frame).__name__}"
            )
        ds = self._ds
        for v in ("q", "omega"):
            if v not in ds:
                raise AttitudeValueError(f"ds: no variable {v!r}; expected a propagation result")
        if "member" in ds["q"].dims:
            raise AttitudeValueError("ds: an ensemble; select a member first (ds.isel(member=i))")
        tu = time_unit(ds["time"])  # "s" or "1" (the CF units are "seconds since ...")
        if frame.orbit is not None:
            if tu in ("1", ""):
                raise AttitudeValueError(
                    "frame: this run's times are dimensionless; a frame on an orbit needs a "
                    "body with units (times in seconds since the orbit's epoch)"
                )
            run_epoch = self.epoch
            fe = frame.epoch
            if run_epoch is not None and fe is not None and abs((run_epoch - fe).sec) > 1e-6:
                raise AttitudeValueError(
                    f"frame: its orbit's epoch differs from the run's ({ds.attrs.get('epoch')}); "
                    "one time origin: build the frame on the run's orbit"
                )
        t = self.quantity("time")
        t = t.to_value("s") if tu not in ("1", "") else np.asarray(t.value)
        frame, on_run = self._on_propagated_orbit(frame, t)
        q = self._q()
        wu = str(ds["omega"].attrs.get("units", "1"))
        w = np.asarray(ds["omega"].values, dtype=np.float64)
        if wu not in ("1", ""):
            w = self.quantity("omega").to_value("rad / s")
        qR, wR = frame.evaluate(t)
        qbr = _qt.multiply(_qt.conjugate(qR), q)
        vec = np.linalg.norm(qbr[..., 1:], axis=-1)
        err = 2.0 * np.arctan2(vec, np.abs(qbr[..., 0]))
        ang = _qt.to_euler(qbr, seq)
        wbr = w - _qt.rotate_inverse(qbr, wR)
        aunit = "deg" if degrees else "rad"
        if degrees:
            err, ang, wbr = np.degrees(err), np.degrees(ang), np.degrees(wbr)
        runit = (aunit + " s-1") if wu not in ("1", "") else ("deg" if degrees else "1")
        time = ds["time"].variable
        labels = [f"a{seq[0]}", f"a{seq[1]}", f"a{seq[2]}"]
        data = {
            "q_BR": (
                ("time", "component"),
                qbr,
                {"units": "1", "long_name": "attitude relative to the frame, q_R~ o q"},
            ),
            "error_angle": (
                ("time",),
                err,
                {"units": aunit, "long_name": "rotation angle of q_BR (attitude error)"},
            ),
            "euler_angles": (
                ("time", "angle"),
                ang,
                {"units": aunit, "long_name": f"intrinsic {seq} Euler angles of q_BR"},
            ),
            "omega_BR": (
                ("time", "axis"),
                wbr,
                {"units": runit, "long_name": "body rates relative to the frame, body axes"},
            ),
        }
        if len(set(seq)) == 3:
            for i, name in zip("123", ("roll", "pitch", "yaw"), strict=True):
                k = seq.index(i)
                data[name] = (
                    ("time",),
                    ang[:, k],
                    {"units": aunit, "long_name": f"{name}: angle about body axis {i} ({seq})"},
                )
        coords = {
            "time": time,
            "angle": ("angle", np.arange(3, dtype=np.int64), {"long_name": "Euler angle index"}),
            "angle_label": ("angle", np.array(labels), {"long_name": "Euler angle"}),
        }
        for c in ("component", "axis"):
            if c in ds.coords:
                coords[c] = ds[c].variable
        attrs = {"frame": frame.describe(), "euler_sequence": seq}
        if on_run:
            attrs["frame_orbit"] = "the run's propagated orbit (position, velocity)"
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def _on_propagated_orbit(self, frame: Any, t: np.ndarray) -> tuple[Any, bool]:
        """A frame on the orbit a spacecraft carried (a NumericalOrbit starting where the run
        did) is evaluated on the run's propagated orbit, which thrust, drag and the gravity
        gradient moved away from it; (frame, whether it was)."""
        from orbit import NumericalOrbit

        ds = self._ds
        if not isinstance(frame.orbit, NumericalOrbit) or not all(
            v in ds for v in ("position", "velocity")
        ):
            return frame, False
        r0 = np.asarray(ds["position"].values[0], dtype=np.float64)
        start = 1e3 * np.asarray(frame.orbit.position(np.array([t[0]])), dtype=np.float64)[0]
        if np.linalg.norm(start - r0) > 1e-3:  # another orbit (e.g. a target satellite's)
            return frame, False
        return frame.with_orbit(self.propagated_orbit()), True

    def propagated_orbit(self) -> Any:
        """The orbit a spacecraft carried (``mass=`` and a NumericalOrbit), as propagated with
        its attitude: an :class:`orbit.EphemerisOrbit` through the run's ``position`` and
        ``velocity`` samples (at a sample it is the sample).

        Returns
        -------
        orbit.EphemerisOrbit
            Usable wherever an orbit is (frames, ``GravityGradient``, a later run).
        """
        from orbit import EphemerisOrbit

        ds = self._ds
        if not all(v in ds for v in ("position", "velocity")):
            raise AttitudeValueError(
                "ds: no propagated orbit (position, velocity); only a spacecraft carrying its "
                "orbit (Spacecraft(..., mass=..., orbit=NumericalOrbit(...))) has one"
            )
        if "member" in ds["position"].dims:
            raise AttitudeValueError("ds: an ensemble; select a member first (ds.isel(member=i))")
        if ds.sizes["time"] < 2:
            raise AttitudeValueError("ds: one sample; an orbit needs at least two")
        t = self.quantity("time").to_value("s")
        r = self.quantity("position").to_value("km")
        v = self.quantity("velocity").to_value("km / s")
        return EphemerisOrbit(t, r, v, self.epoch, source="the run's propagated orbit")

    # -- orbit --------------------------------------------------------------------------------
    @property
    def has_orbit(self) -> bool:
        """Whether the run had an orbit (variables ``r``, ``f``, ``p``)."""
        return all(v in self._ds for v in ("r", "f", "p"))

    def _need_orbit(self) -> None:
        if not self.has_orbit:
            raise AttitudeValueError(
                "orbit: this run had no orbit (r, f, p exist only for the gravity-gradient "
                "potential)"
            )

    def radius(self) -> Any:
        """Orbit radius r(t) as a Quantity (km)."""
        self._need_orbit()
        return self.quantity("r")

    def true_anomaly(self) -> Any:
        """True anomaly f(t) as a Quantity (rad)."""
        self._need_orbit()
        return self.quantity("f")

    def orbit_frame(self) -> xr.DataArray:
        """Orbital-frame quaternion p(t): x_S = p∘x_O∘p̃ (x_O radial, z_O orbit normal)."""
        self._need_orbit()
        return self._ds["p"]

    def relative_to_orbit(self) -> xr.DataArray:
        """Attitude of the body relative to the orbital frame, p̃∘q (x_O = q_rel∘x_B∘q̃_rel).

        The identity means body axes along (radial, along-track, orbit normal).

        Returns
        -------
        DataArray, shape (time, 4)
        """
        self._need_orbit()
        p = np.asarray(self._ds["p"].values, dtype=np.float64)
        rel = _qt.multiply(_qt.conjugate(p), self._q())
        return xr.DataArray(
            rel,
            dims=("time", "component"),
            coords={"time": self._ds["time"], **self._ds["q"].coords},
            attrs={"units": "1", "long_name": "attitude relative to the orbital frame, p~ o q"},
            name="q_rel",
        )
