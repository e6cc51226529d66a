"""CCSDS Attitude Ephemeris Message (AEM, KVN) export of a result.

Keyword set and order follow CCSDS 504.0-B-2 (ADM issue 2, January 2024) tables 4-2 (header)
and 4-3 (metadata), and table 4-4 for the data line ``EPOCH Q1 Q2 Q3 QC`` (scalar last, always,
in version 2.0). Version 1.0 (504.0-B-1, 2008) adds ``ATTITUDE_DIR`` and ``QUATERNION_TYPE``,
for older readers.

Frames: the quaternion "from frame A to frame B" (504.0-B-2 annex F2) rotates the basis vectors
of A onto those of B, i.e. X_B = M_BA X_A with M_BA = R(q)ᵀ. With REF_FRAME_A the inertial
frame and REF_FRAME_B the body's principal axes, that is exactly this package's q (x_S = R x_B),
so (Q1, Q2, Q3, QC) = (q_x, q_y, q_z, q_w).

Times: AEM needs absolute epochs. They are ``epoch + time`` in UTC (astropy.time, leap seconds
included); the epoch is the result's ``epoch`` attr (the scenario's) or ``epoch=``. A
dimensionless run needs ``time_unit_seconds=``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._version import __version__
from .errors import AttitudeValueError

__all__ = ["write_aem"]

#: Data lines formatted per block (bounded memory for long histories).
BLOCK = 50_000


def _kvn(key: str, value: Any) -> str:
    return f"{key:<20} = {value}"


def _abs_times(ds: xr.Dataset, epoch: Any, time_unit_seconds: float | None) -> tuple[Any, Any]:
    from astropy import units as u
    from astropy.time import Time

    from .results import time_unit

    units = time_unit(ds["time"])
    if units in ("1", ""):
        if time_unit_seconds is None:
            raise AttitudeValueError(
                "time_unit_seconds: this run is dimensionless (time unit '1'); an AEM needs "
                "seconds: give the length of one time unit in seconds (--time-unit-seconds)"
            )
        scale = float(time_unit_seconds)
    else:
        try:
            scale = float(u.Unit(units).to("s"))
        except (ValueError, u.UnitConversionError):
            raise AttitudeValueError(f"time: units {units!r} are not a time unit") from None
        if time_unit_seconds is not None:
            raise AttitudeValueError(
                "time_unit_seconds: only for dimensionless runs (this one is in " + units + ")"
            )
    e = epoch if epoch is not None else ds.attrs.get("epoch")
    if not e:
        raise AttitudeValueError(
            "epoch: this run has no epoch (the scenario gave none); give the UTC epoch of "
            "time 0, e.g. --epoch 2024-01-01T00:00:00"
        )
    try:
        t0 = e if isinstance(e, Time) else Time(str(e).rstrip("Z"), scale="utc")
    except ValueError:
        raise AttitudeValueError(f"epoch: {e!r} is not an ISO 8601 UTC time") from None
    return t0.utc, scale


def _iso(times: Any) -> np.ndarray:
    times.precision = 6
    return np.asarray(times.isot)


def write_aem(
    ds: xr.Dataset,
    path: str | os.PathLike,
    *,
    epoch: Any = None,
    version: int = 2,
    object_name: str | None = None,
    object_id: str | None = None,
    center_name: str | None = None,
    ref_frame_a: str | None = None,
    ref_frame_b: str = "SC_BODY_1",
    originator: str = "attitude",
    message_id: str | None = None,
    interpolation: tuple[str, int] | None = ("LAGRANGE", 7),
    time_unit_seconds: float | None = None,
) -> Path:
    """Write the attitude history of ``ds`` as a CCSDS AEM (KVN) file, atomically.

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (``q``, ``time``); may be lazily loaded (written in blocks).
    path : str or Path
        Output file (written to a temporary file and renamed when complete).
    epoch : str or astropy Time, optional
        UTC epoch of ``time = 0``; default the Dataset's ``epoch`` attr.
    version : {2, 1}
        AEM version: 2 (CCSDS 504.0-B-2, default) or 1 (504.0-B-1).
    object_name, object_id : str, optional
        Default: the run's ``object_name``/``object_id`` attrs, else ``UNKNOWN``.
    center_name : str, optional
        Default ``EARTH`` for a run with an orbit, else omitted.
    ref_frame_a : str, optional
        The inertial frame; default the run's ``inertial_frame`` attr, else ``EME2000``.
    ref_frame_b : str
        The body frame (principal axes), default ``SC_BODY_1``.
    originator, message_id : str
        Header fields (MESSAGE_ID only in version 2).
    interpolation : (str, int) or None
        INTERPOLATION_METHOD and INTERPOLATION_DEGREE (degree capped at samples − 1).
    time_unit_seconds : float, optional
        Seconds per time unit, required for dimensionless runs.

    Returns
    -------
    Path
    """
    if version not in (1, 2):
        raise AttitudeValueError(f"version: AEM version 1 or 2, got {version!r}")
    if "q" not in ds or "time" not in ds.coords:
        raise AttitudeValueError("ds: not a propagation result (needs variables time and q)")
    t0, scale = _abs_times(ds, epoch, time_unit_seconds)
    from astropy.time import TimeDelta

    n = ds.sizes["time"]
    if n < 1:
        raise AttitudeValueError("ds: no samples")
    from .results import time_values

    tt = time_values(ds) * scale
    if n > 1 and not np.all(np.diff(tt) > 0):
        raise AttitudeValueError("ds: AEM data lines must have increasing times (backward run?)")

    def stamp(x: np.ndarray) -> np.ndarray:
        return _iso(t0 + TimeDelta(x, format="sec"))

    start, stop = stamp(tt[[0, -1]])
    from datetime import datetime, timezone

    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    a = ds.attrs
    name = object_name or str(a.get("object_name") or "UNKNOWN")
    oid = object_id or str(a.get("object_id") or "UNKNOWN")
    frame_a = ref_frame_a or str(a.get("inertial_frame") or "EME2000")
    center = center_name or ("EARTH" if "r" in ds else None)

    head = [_kvn("CCSDS_AEM_VERS", f"{version}.0")]
    head.append(
        f"COMMENT Attitude history from attitude {__version__}, scenario "
        f"{a.get('scenario', '-')}, method {a.get('method', '-')}"
    )
    head.append(_kvn("CREATION_DATE", created))
    head.append(_kvn("ORIGINATOR", originator))
    if version == 2 and message_id:
        head.append(_kvn("MESSAGE_ID", message_id))
    meta = ["", "META_START"]
    meta.append(
        f"COMMENT Quaternion from {frame_a} to {ref_frame_b} (body principal axes): it rotates "
        f"the {frame_a} axes onto the body axes, X_B = M_BA X_A"
    )
    meta.append("COMMENT Data lines: EPOCH Q1 Q2 Q3 QC (vector part first, scalar QC last)")
    meta.append(_kvn("OBJECT_NAME", name))
    meta.append(_kvn("OBJECT_ID", oid))
    if center:
        meta.append(_kvn("CENTER_NAME", center))
    meta.append(_kvn("REF_FRAME_A", frame_a))
    meta.append(_kvn("REF_FRAME_B", ref_frame_b))
    if version == 1:
        meta.append(_kvn("ATTITUDE_DIR", "A2B"))
    meta.append(_kvn("TIME_SYSTEM", "UTC"))
    meta.append(_kvn("START_TIME", start))
    meta.append(_kvn("STOP_TIME", stop))
    meta.append(_kvn("ATTITUDE_TYPE", "QUATERNION"))
    if version == 1:
        meta.append(_kvn("QUATERNION_TYPE", "LAST"))
    if interpolation is not None and n > 1:
        meta.append(_kvn("INTERPOLATION_METHOD", interpolation[0]))
        meta.append(_kvn("INTERPOLATION_DEGREE", min(int(interpolation[1]), n - 1)))
    meta += ["META_STOP", "", "DATA_START"]

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="latin-1", errors="replace", newline="\n") as fh:
            fh.write("\n".join(head + meta) + "\n")
            for i in range(0, n, BLOCK):
                sl = slice(i, i + BLOCK)
                q = np.asarray(ds["q"].isel(time=sl).values, dtype=np.float64)
                epochs = stamp(tt[sl])
                # 17 significant digits: every float64 quaternion component round-trips.
                fh.write(
                    "".join(
                        f"{e} {x:.16e} {y:.16e} {z:.16e} {w:.16e}\n"
                        for e, (w, x, y, z) in zip(epochs, q.tolist(), strict=False)
                    )
                )
            fh.write("DATA_STOP\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, out)
    except BaseException:
        if tmp.exists():
            tmp.unlink()
        raise
    return out
