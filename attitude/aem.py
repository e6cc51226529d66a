"""CCSDS Attitude Ephemeris Messages (AEM, KVN): export of a result and reading back.

Keyword set and order follow CCSDS 504.0-B-2 (ADM issue 2, January 2024) tables 4-2 (header)
and 4-3 (metadata), and table 4-4 for the data lines: ``EPOCH Q1 Q2 Q3 QC`` (scalar last,
always, in version 2.0) for ``ATTITUDE_TYPE = QUATERNION`` and
``EPOCH Q1 Q2 Q3 QC ANGVEL_X ANGVEL_Y ANGVEL_Z`` (deg/s, in ``ANGVEL_FRAME``, here the body
frame REF_FRAME_B) for ``QUATERNION/ANGVEL``. Version 1.0 (504.0-B-1, 2008) adds
``ATTITUDE_DIR`` and ``QUATERNION_TYPE``, for older readers.

:func:`read` reads AEM versions 1 and 2 (QUATERNION, QUATERNION/ANGVEL, v1 QUATERNION/RATE and
QUATERNION/DERIVATIVE; scalar FIRST or LAST; A2B or B2A; any number of segments) back into a
Dataset with the variables of a result (``q``, and ``omega`` when the file has rates), so
reference attitudes from other tools can be compared (``ds.attitude.angle_between``).

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
import re
from decimal import ROUND_FLOOR, ROUND_HALF_EVEN, Decimal
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import quaternion as qt
from ._files import OutputFile, file_error, input_path
from ._validation import as_positive
from ._version import __version__
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["ATTITUDE_TYPES", "read", "write_aem"]

#: Attitude types :func:`write_aem` writes (QUATERNION/ANGVEL: AEM version 2 only).
ATTITUDE_TYPES = ("QUATERNION", "QUATERNION/ANGVEL")

#: Data lines formatted per block (bounded memory for long histories).
BLOCK = 50_000


#: Control characters (C0, DEL, C1): never in a KVN header or metadata value.
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


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
                "time_unit_seconds: this run is dimensionless (time unit '1'); a CCSDS message "
                "needs seconds: give the length of one time unit in seconds (--time-unit-seconds)"
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
    return _epoch_parts(e, t0.utc), scale


#: REF_FRAME_A names of the GCRS axes (the ICRF's axes; the GCRF is the ICRF at the geocentre).
_GCRS_NAMES = ("GCRF", "ICRF")


def _frame_a(ds: xr.Dataset, ref_frame_a: str | None) -> tuple[str, Any]:
    """REF_FRAME_A and the rotation to apply to q (None, or the frame bias quaternion).

    A run with an orbit with an epoch is relative to the GCRS (``orbit_frame``): it is labelled
    GCRF by default, and EME2000 when asked for (argument or the run's ``inertial_frame``),
    rotated by the frame bias; another label would not be true and is refused. A run without
    one has an abstract inertial frame: the label is the one given (default EME2000).
    """
    a = ds.attrs
    gcrs = str(a.get("orbit_frame", "")).upper() == "GCRS"
    frame_a = ref_frame_a or str(a.get("inertial_frame") or ("GCRF" if gcrs else "EME2000"))
    if not gcrs or frame_a.upper() in _GCRS_NAMES:
        return frame_a, None
    if frame_a.upper() != "EME2000":
        raise AttitudeValueError(
            f"ref_frame_a: {frame_a!r}: this run's attitude is relative to the GCRS (its "
            "orbit's frame); an AEM can label it GCRF (or ICRF), or EME2000 (rotated by the "
            "frame bias)"
        )
    from orbit.frames import frame_bias

    return frame_a, qt.from_matrix(frame_bias())


def _check_arguments(ds, version, epoch, interpolation, **names) -> None:
    """Types of the arguments of :func:`write_aem`, before any work."""
    from astropy.time import Time

    if not isinstance(ds, xr.Dataset):
        raise AttitudeTypeError(f"ds: expected an xarray.Dataset, got {type(ds).__name__}")
    if (
        isinstance(version, bool)
        or not isinstance(version, (int, np.integer))
        or version not in (1, 2)
    ):
        raise AttitudeValueError(f"version: AEM version 1 or 2, got {version!r}")
    if epoch is not None and not isinstance(epoch, (str, Time)):
        raise AttitudeTypeError(
            f"epoch: expected an ISO 8601 UTC string or an astropy Time, got {type(epoch).__name__}"
        )
    for key, v in names.items():
        if v is not None and not isinstance(v, str):
            raise AttitudeTypeError(f"{key}: expected a string, got {type(v).__name__}")
        if v is not None and _CONTROL.search(v):
            raise AttitudeValueError(
                f"{key}: {v!r} holds a control character (a line break would end the KVN line "
                "and start another: the file would not be an AEM)"
            )
    if interpolation is not None and not (
        isinstance(interpolation, (tuple, list))
        and len(interpolation) == 2
        and isinstance(interpolation[0], str)
        and isinstance(interpolation[1], (int, np.integer))
        and not isinstance(interpolation[1], bool)
        and interpolation[1] >= 1
    ):
        raise AttitudeTypeError(
            f"interpolation: expected (method, degree) such as ('LAGRANGE', 7) or None, got "
            f"{interpolation!r}"
        )


# -- epochs --------------------------------------------------------------------------------------
# An epoch is written as whole UTC seconds (astropy: leap seconds, "23:59:60") and a decimal
# fraction computed exactly (decimal.Decimal of epoch fraction + the float64 time): with enough
# digits the reader gets the time back bit for bit, with as few as 6 when that is enough.

#: Fewest and most decimals of the seconds of a data line's epoch.
_MIN_DIGITS, _MAX_DIGITS = 6, 24
_ISO = re.compile(r"^(\d{4}-\d{2}-\d{2})[T ](\d{2}:\d{2}:\d{2})(?:\.(\d+))?Z?$")


def _epoch_parts(e: Any, t0: Any) -> tuple[Any, Decimal]:
    """The epoch as (whole UTC seconds, astropy Time; decimal fraction of a second), the
    fraction with the digits the epoch was given with (a Time: ``format_epoch``'s)."""
    from astropy.time import Time

    from orbit.timescales import format_epoch

    text = e if isinstance(e, str) and _ISO.match(e.strip()) else format_epoch(t0)
    m = _ISO.match(text.strip())
    whole = Time(f"{m.group(1)}T{m.group(2)}", scale="utc")
    return whole, Decimal("0." + m.group(3)) if m.group(3) else Decimal(0)


def _stamps(whole: Any, frac: Decimal, t: np.ndarray) -> list[str]:
    """CCSDS epochs of epoch + t (SI seconds): the fewest decimals (at least 6) with which
    :func:`read` gives each t back exactly (the reader counts from the first epoch, so with
    a first sample at t = 0 the round trip is bit for bit)."""
    from astropy.time import TimeDelta

    k = np.empty(t.size)
    fracs = []
    for i, x in enumerate(t.tolist()):
        total = frac + Decimal(x)  # exact
        whole_s = total.to_integral_value(rounding=ROUND_FLOOR)
        f = total - whole_s
        for digits in range(_MIN_DIGITS, _MAX_DIGITS + 1):
            fd = f.quantize(Decimal(1).scaleb(-digits), rounding=ROUND_HALF_EVEN)
            if float(whole_s + fd - frac) == x:
                break
        if fd >= 1:  # rounded up to the next second
            whole_s, fd = whole_s + 1, fd - 1
        k[i] = float(whole_s)
        fracs.append(f"{fd:.{max(digits, _MIN_DIGITS)}f}"[1:])  # ".ffffff"
    times = whole + TimeDelta(k, format="sec")
    times.precision = 0
    return [w + f for w, f in zip(np.atleast_1d(times.isot).tolist(), fracs, strict=True)]


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
    attitude_type: str = "QUATERNION",
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
        The inertial frame; default the run's ``inertial_frame`` attr, else ``GCRF`` for a run
        whose orbit frame is the GCRS, else ``EME2000``. A GCRS run written as ``EME2000`` is
        rotated by the IAU 2006 frame bias (23 mas); other labels of a GCRS run are refused.
    ref_frame_b : str
        The body frame (principal axes), default ``SC_BODY_1``.
    originator, message_id : str
        Header fields (MESSAGE_ID only in version 2).
    interpolation : (str, int) or None
        INTERPOLATION_METHOD and INTERPOLATION_DEGREE (degree capped at samples − 1).
    time_unit_seconds : float, optional
        Seconds per time unit, required for dimensionless runs.
    attitude_type : {"QUATERNION", "QUATERNION/ANGVEL"}
        ``QUATERNION/ANGVEL`` (version 2 only) adds the body angular velocity ``omega`` on every
        data line, in deg/s, with ``ANGVEL_FRAME = ref_frame_b`` (the body frame).

    Returns
    -------
    Path
    """
    _check_arguments(
        ds, version, epoch, interpolation,
        object_name=object_name, object_id=object_id, center_name=center_name,
        ref_frame_a=ref_frame_a, ref_frame_b=ref_frame_b, originator=originator,
        message_id=message_id,
    )  # fmt: skip
    if time_unit_seconds is not None:
        time_unit_seconds = as_positive(time_unit_seconds, "time_unit_seconds")
    if attitude_type not in ATTITUDE_TYPES:
        raise AttitudeValueError(
            f"attitude_type: one of {', '.join(ATTITUDE_TYPES)}, got {attitude_type!r}"
        )
    angvel = attitude_type == "QUATERNION/ANGVEL"
    if angvel and version != 2:
        raise AttitudeValueError(
            "attitude_type: QUATERNION/ANGVEL is an AEM version 2 type (504.0-B-2); use "
            "version=2, or attitude_type='QUATERNION' for version 1"
        )
    if angvel and "omega" not in ds:
        raise AttitudeValueError("ds: QUATERNION/ANGVEL needs the angular velocity 'omega'")
    if "q" not in ds or "time" not in ds.coords:
        raise AttitudeValueError("ds: not a propagation result (needs variables time and q)")
    target = OutputFile(path, "path")  # checked before any work; atomic, devices written through
    t0, scale = _abs_times(ds, epoch, time_unit_seconds)
    n = ds.sizes["time"]
    if n < 1:
        raise AttitudeValueError("ds: no samples")
    from .results import time_values

    tt = time_values(ds) * scale
    if n > 1 and not np.all(np.diff(tt) > 0):
        raise AttitudeValueError("ds: AEM data lines must have increasing times (backward run?)")

    deg_per_s = None
    if angvel:  # omega in rad per time unit -> deg/s
        from .results import time_unit

        rate = str(ds["omega"].attrs.get("units", "1"))
        if time_unit(ds["time"]) == "1" or rate in ("1", ""):
            deg_per_s = np.degrees(1.0) / scale
        else:
            from astropy import units as u

            deg_per_s = float(u.Unit(rate).to("deg/s", equivalencies=u.dimensionless_angles()))

    def stamp(x: np.ndarray) -> list[str]:
        try:
            return _stamps(*t0, x)
        except (ValueError, OverflowError) as exc:  # erfa: "unacceptable date"
            raise AttitudeValueError(
                f"time: the sample times (epoch + t x {scale:g} s) are outside the dates a "
                f"CCSDS AEM can hold ({exc}); check epoch and time_unit_seconds"
            ) from None

    start, stop = stamp(tt[[0, -1]])
    from datetime import datetime, timezone

    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    a = ds.attrs
    name = object_name or str(a.get("object_name") or "UNKNOWN")
    oid = object_id or str(a.get("object_id") or "UNKNOWN")
    frame_a, bias = _frame_a(ds, ref_frame_a)
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
    if bias is not None:
        meta.append(
            "COMMENT The run's inertial frame is the GCRS; its attitude is rotated to EME2000 "
            "by the IAU 2006 frame bias (ERFA bp06, 23 mas)"
        )
    if angvel:
        meta.append(
            "COMMENT Data lines: EPOCH Q1 Q2 Q3 QC (vector part first, scalar QC last) "
            f"ANGVEL_X ANGVEL_Y ANGVEL_Z (deg/s, angular velocity of {ref_frame_b} relative to "
            f"{frame_a}, in {ref_frame_b} axes)"
        )
    else:
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
    meta.append(_kvn("ATTITUDE_TYPE", attitude_type))
    if angvel:
        meta.append(_kvn("ANGVEL_FRAME", ref_frame_b))
    if version == 1:
        meta.append(_kvn("QUATERNION_TYPE", "LAST"))
    if interpolation is not None and n > 1:
        meta.append(_kvn("INTERPOLATION_METHOD", interpolation[0]))
        meta.append(_kvn("INTERPOLATION_DEGREE", min(int(interpolation[1]), n - 1)))
    meta += ["META_STOP", "", "DATA_START"]
    for line in head + meta:  # values from the Dataset's attrs too (a scenario's names)
        if _CONTROL.search(line):
            raise AttitudeValueError(
                f"ds: the AEM header line {line.split('=')[0].strip()!r} would hold a control "
                f"character ({line!r}), from the Dataset's attrs; give the value as a parameter"
            )

    with target.writing() as tmp:
        with open(tmp, "w", encoding="latin-1", errors="replace", newline="\n") as fh:
            fh.write("\n".join(head + meta) + "\n")
            for i in range(0, n, BLOCK):
                sl = slice(i, i + BLOCK)
                q = np.asarray(ds["q"].isel(time=sl).values, dtype=np.float64)
                if bias is not None:  # x_EME2000 = B x_GCRS: the body -> EME2000 quaternion
                    q = qt.multiply(bias, q)
                epochs = stamp(tt[sl])
                # 17 significant digits: every float64 quaternion component round-trips.
                if deg_per_s is None:
                    fh.write(
                        "".join(
                            f"{e} {x:.16e} {y:.16e} {z:.16e} {w:.16e}\n"
                            for e, (w, x, y, z) in zip(epochs, q.tolist(), strict=False)
                        )
                    )
                else:
                    wv = np.asarray(ds["omega"].isel(time=sl).values, dtype=np.float64)
                    wv = wv * deg_per_s
                    fh.write(
                        "".join(
                            f"{e} {x:.16e} {y:.16e} {z:.16e} {w:.16e} {a:.16e} {b:.16e} {c:.16e}\n"
                            for e, (w, x, y, z), (a, b, c) in zip(
                                epochs, q.tolist(), wv.tolist(), strict=False
                            )
                        )
                    )
            fh.write("DATA_STOP\n")
            fh.flush()
        target.commit()
    return target.path


# ------------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------------

from ._aem_parse import (  # noqa: E402 (the reader's parts, beside its entry point)
    _NVALUES,
    _SCALES,
    _check_segment,
    _parse_epochs,
    _seconds_since_first,
    _segments,
    _xml_segments,
)


def read(path: str | os.PathLike, *, body_frame: str | None = None) -> xr.Dataset:
    """Read a CCSDS AEM (KVN or XML, version 1 or 2) into a Dataset of the result schema.

    Parameters
    ----------
    path : str or Path
        The AEM file.
    body_frame : str, optional
        Which of REF_FRAME_A / REF_FRAME_B is the spacecraft body. Default: the one whose name
        starts with ``SC_BODY``, else REF_FRAME_B.

    Returns
    -------
    xarray.Dataset
        ``time`` (SI seconds since the first epoch, which is the ``epoch`` attr, UTC; CF time
        units), ``q`` (time, component): the attitude body → inertial, scalar first, in this
        package's convention (docs/conventions.md), and ``omega`` (time, axis): the body
        angular velocity in rad s^-1, for the types with rates. Attrs: the object, frames,
        attitude type and version. Segments are concatenated (a sample repeated at a segment
        boundary is kept once).

    Raises
    ------
    AttitudeValueError
        Not an AEM, an attitude type other than the quaternion ones, inconsistent segments,
        or a time system astropy does not know.
    """

    from .results import index_coords, time_attrs

    p = input_path(path, "path")  # type, NUL bytes, a directory: errors naming the path
    if body_frame is not None and not isinstance(body_frame, str):
        raise AttitudeTypeError(
            f"body_frame: expected a frame name (str) or None, got {type(body_frame).__name__}"
        )
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise file_error(exc, p, "read") from None
    from orbit.ccsds import is_xml

    if is_xml(raw):  # NDM/XML (Orekit writes it): the same header and segments as KVN
        header, segs = _xml_segments(raw, str(p))
    else:
        header, segs = _segments(raw.decode("latin-1").splitlines(), str(p))
    vers = header.get("CCSDS_AEM_VERS")
    if vers is None:
        raise AttitudeValueError(f"{p}: not a CCSDS AEM (no CCSDS_AEM_VERS header line)")
    major = vers.split(".")[0]
    if major not in ("1", "2"):
        raise AttitudeValueError(f"{p}: AEM version {vers} (versions 1 and 2 are read)")
    if not segs:
        raise AttitudeValueError(f"{p}: no data segment (META_START ... DATA_STOP)")

    times, qs, ws = [], [], []
    systems: set[str] = set()
    first = segs[0][0]
    kinds = set()
    for i, (meta, data) in enumerate(segs):
        where = f"{p}: segment {i + 1}"
        for k in ("REF_FRAME_A", "REF_FRAME_B", "TIME_SYSTEM", "ATTITUDE_TYPE"):
            if k not in meta:
                raise AttitudeValueError(f"{where}: metadata keyword {k} missing")
        for k in ("REF_FRAME_A", "REF_FRAME_B", "OBJECT_NAME"):
            if meta.get(k) != first.get(k):
                raise AttitudeValueError(
                    f"{where}: {k} = {meta.get(k)} differs from the first segment's "
                    f"({first.get(k)}); read one object and frame pair per file"
                )
        kind = meta["ATTITUDE_TYPE"].upper()
        if kind not in _NVALUES:
            raise AttitudeValueError(
                f"{where}: ATTITUDE_TYPE {kind} is not read (quaternion types only: "
                + ", ".join(_NVALUES)
                + ")"
            )
        kinds.add("rates" if kind != "QUATERNION" else "q")
        fa, fb = meta["REF_FRAME_A"], meta["REF_FRAME_B"]
        # v2 data lines are always scalar last; v1 says so in QUATERNION_TYPE
        qtype = meta.get("QUATERNION_TYPE", "LAST").upper()
        direction = meta.get("ATTITUDE_DIR", "A2B").upper()
        if qtype not in ("FIRST", "LAST") or direction not in ("A2B", "B2A"):
            raise AttitudeValueError(
                f"{where}: QUATERNION_TYPE must be FIRST or LAST and ATTITUDE_DIR A2B or B2A"
            )
        ts = meta["TIME_SYSTEM"].upper()
        if ts not in _SCALES and ts != "GPS":
            raise AttitudeValueError(
                f"{where}: TIME_SYSTEM {ts} is not read (UTC, TAI, TT, TDB, TCG, TCB, GPS)"
            )
        n = _NVALUES[kind]
        bad = [j for j, d in enumerate(data) if len(d) != n + 1]
        if bad:
            raise AttitudeValueError(
                f"{where}: data line {bad[0] + 1} has {len(data[bad[0]])} fields; "
                f"{kind} lines have an epoch and {n} numbers"
            )
        if not data:
            continue
        try:
            vals = np.array([[float(x) for x in d[1:]] for d in data], dtype=np.float64)
        except ValueError as exc:
            raise AttitudeValueError(f"{where}: a data value is not a number ({exc})") from None
        try:
            parsed = _parse_epochs([d[0] for d in data], ts)
        except ValueError as exc:
            raise AttitudeValueError(f"{where}: bad epoch ({exc})") from None
        _check_segment(where, major, meta, vals, parsed, ts)
        times.append(parsed)
        systems.add(ts)
        # The quaternion "from A to B" (annex F) as scalar first.
        if qtype == "FIRST":
            q = vals[:, 0:4].copy()
            rest = vals[:, 4:]
        else:
            q = vals[:, [3, 0, 1, 2]]
            rest = vals[:, 4:]
        if kind == "QUATERNION/DERIVATIVE":
            qd = rest[:, 0:4].copy() if qtype == "FIRST" else rest[:, [3, 0, 1, 2]]
        if direction == "B2A":  # the file's quaternion rotates B onto A
            q = qt.conjugate(q)
            if kind == "QUATERNION/DERIVATIVE":
                qd = qt.conjugate(qd)
        # Now q maps A → B (X_B = M_BA X_A, M_BA = R(q)ᵀ). With A inertial and B the body
        # that is this package's q (aem.write_aem); with A the body, its conjugate.
        body = body_frame or (
            fa if fa.upper().startswith("SC_BODY") and not fb.upper().startswith("SC_BODY") else fb
        )
        if body not in (fa, fb):
            raise AttitudeValueError(
                f"body_frame: {body!r} is neither REF_FRAME_A ({fa}) nor REF_FRAME_B ({fb})"
            )
        body_is_a = body == fa and fa != fb
        if body_is_a:
            q = qt.conjugate(q)
            if kind == "QUATERNION/DERIVATIVE":
                qd = qt.conjugate(qd)
        qs.append(q)
        if kind == "QUATERNION":
            continue
        if kind == "QUATERNION/DERIVATIVE":  # ω_B = 2 q̃∘q̇ (docs/conventions.md sect. 5), 1/s
            w = 2.0 * qt.multiply(qt.conjugate(q), qd)[:, 1:]
        else:  # deg/s, angular velocity of B relative to A, in the ANGVEL_FRAME / RATE_FRAME
            w = np.radians(rest[:, 0:3])
            frame = meta.get("ANGVEL_FRAME", meta.get("RATE_FRAME", fb))
            frame = {"REF_FRAME_A": fa, "REF_FRAME_B": fb}.get(frame.upper(), frame)
            if frame not in (fa, fb):
                raise AttitudeValueError(
                    f"{where}: rates in frame {frame}, neither REF_FRAME_A nor REF_FRAME_B"
                )
            if body_is_a:  # the file gives the inertial frame's rate relative to the body
                w = -w
            if frame != body:  # in inertial axes: read in body axes
                w = qt.rotate_inverse(q, w)
        ws.append(w)
    if len(kinds) > 1:
        raise AttitudeValueError(f"{p}: segments mix types with and without rates")
    if not qs:
        raise AttitudeValueError(f"{p}: no data lines")
    rel, epoch = _seconds_since_first(times, systems)
    q_all = np.concatenate(qs)
    w_all = np.concatenate(ws) if ws else None
    keep = np.ones(rel.shape, bool)
    keep[1:] = rel[1:] != rel[:-1]  # a boundary sample repeated by the next segment
    if np.any(rel[1:][keep[1:]] < rel[:-1][keep[1:]]):
        raise AttitudeValueError(f"{p}: epochs must increase through the file")
    rel, q_all = rel[keep], q_all[keep]
    coords = {"time": ("time", rel, time_attrs("s", epoch)), **index_coords()}
    data_vars = {
        "q": (
            ("time", "component"),
            q_all,
            {
                "units": "1",
                "long_name": "attitude quaternion (Euler parameters), body to space, scalar first",
            },
        )
    }
    if w_all is not None:
        data_vars["omega"] = (
            ("time", "axis"),
            w_all[keep],
            {"units": "rad s^-1", "long_name": "angular velocity in body axes"},
        )
    fa, fb = first["REF_FRAME_A"], first["REF_FRAME_B"]
    body = body_frame or (
        fa if fa.upper().startswith("SC_BODY") and not fb.upper().startswith("SC_BODY") else fb
    )
    attrs = {
        "Conventions": "CF-1.11",
        "title": f"CCSDS AEM {p.name}",
        "source": f"CCSDS AEM version {vers}, originator {header.get('ORIGINATOR', '-')}",
        "history": f"read by attitude {__version__} (attitude.aem.read) from {p}",
        "epoch": epoch,
        "object_name": first.get("OBJECT_NAME", "UNKNOWN"),
        "object_id": first.get("OBJECT_ID", "UNKNOWN"),
        "inertial_frame": fa if body == fb else fb,
        "body_frame": body,
        "aem_version": vers,
        "aem_attitude_type": ", ".join(sorted({m["ATTITUDE_TYPE"] for m, _ in segs})),
        "aem_time_system": first.get("TIME_SYSTEM", ""),
        "quaternion_convention": (
            "scalar first (w, x, y, z), Hamilton product, q maps body to space"
        ),
    }
    if first.get("CENTER_NAME"):
        attrs["center_name"] = first["CENTER_NAME"]
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
