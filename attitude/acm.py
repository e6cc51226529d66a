"""CCSDS Attitude Comprehensive Messages (ACM, KVN): the estimated attitude with its covariance.

An ACM (CCSDS 504.0-B-2, ADM issue 2, January 2024, section 5) holds one object's attitude
in sections, in the order of table 5-1: the header (table 5-2: ``CCSDS_ACM_VERS = 2.0``,
``CREATION_DATE``, ``ORIGINATOR``, ``MESSAGE_ID``), the metadata (table 5-3, between
``META_START`` and ``META_STOP``: ``OBJECT_NAME``, ``TIME_SYSTEM``, ``EPOCH_TZERO``, ...), then
attitude state histories (``ATT_START`` ... ``ATT_STOP``, table 5-4), covariance histories
(``COV_START`` ... ``COV_STOP``, table 5-6) and an attitude determination section (``AD_START``
... ``AD_STOP``, table 5-8). Keywords appear in the order of their table. Data lines begin with
a time tag: here seconds since ``EPOCH_TZERO`` (relative time tags, which the standard allows).

:func:`write_acm` writes what the flight software's estimator (attitude.estimation.MEKF)
recorded at its ticks:

* ``ATT_ID = ESTIMATE``: ``ATT_TYPE = QUATERNION``, ``RATE_TYPE = GYRO_BIAS``: per tick
  ``Q1 Q2 Q3 QC`` (scalar last, annex B4) of ``estimate_q`` and the estimated gyro bias
  ``bias_estimate`` in deg/s (body axes);
* ``COV_ID = ESTIMATE_COVARIANCE``: ``COV_TYPE = ANGLE_GYROBIAS`` (or ``ANGLE``) in
  ``COV_REF_FRAME`` = the body frame: per tick the diagonal of the MEKF's 6×6 covariance of
  the error state (δθ, δβ): three angle variances in deg² and three bias variances in
  (deg/s)² (annex B6; clause 5.3.7.6: a covariance line holds the main diagonal only; the
  off-diagonal terms are not in the message). They are ``estimation_sigma`` squared;
* ``ATT_ID = TRUTH`` (optional): the simulated true attitude ``q`` at the run's samples;
* an ``AD`` section: ``AD_METHOD = EKF``, the states and the covariance type.

Frames and quaternions as the AEM export (:mod:`attitude.aem`): the quaternion from
REF_FRAME_A (inertial: GCRF for a run relative to the GCRS, EME2000 rotated by the frame bias
when asked) to REF_FRAME_B (the body, ``SC_BODY_1``) is this package's ``q`` with the scalar
last. The MEKF's attitude error δθ is a rotation vector in body axes (q = q̂∘δq(δθ)), so
``COV_REF_FRAME`` is the body frame.

:func:`read` reads such a message back (and ACMs of other producers with the same content).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import quaternion as qt
from ._aem_parse import _parse_epochs
from ._files import OutputFile, file_error, input_path
from ._validation import as_positive
from ._version import __version__
from .aem import _CONTROL, _abs_times, _frame_a, _kvn, _stamps
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["COV_TYPES", "read", "write_acm"]

#: Covariance types :func:`write_acm` writes (annex B6) and their number of diagonal elements.
COV_TYPES = {"ANGLE_GYROBIAS": 6, "ANGLE": 3}

#: Attitude and rate types :func:`read` reads (annex B4), with their number of elements.
_ATT_ELEMENTS = {"QUATERNION": 4}
_RATE_ELEMENTS = {"NONE": 0, "GYRO_BIAS": 3, "ANGVEL": 3}

#: Data lines formatted per block (bounded memory for long histories).
BLOCK = 50_000

_DEG = float(np.degrees(1.0))


def _number(x: float) -> str:
    """A float64 as the shortest decimal that reads back to it (17 significant digits)."""
    return f"{x:.16e}"


def _time_tag(x: float) -> str:
    """Seconds since EPOCH_TZERO, positional (no exponent), the shortest exact decimal."""
    return np.format_float_positional(x, unique=True, trim="0")


def _rate_to_deg_s(units: str, scale: float, dimensionless: bool) -> float:
    """Factor from a rate variable's units (rad per time unit) to deg/s."""
    if dimensionless or units in ("1", ""):
        return _DEG / scale
    from astropy import units as u

    try:
        return float(u.Unit(units).to("deg/s", equivalencies=u.dimensionless_angles()))
    except (ValueError, u.UnitConversionError):
        raise AttitudeValueError(f"units {units!r} are not an angular rate") from None


def _check_arguments(ds: Any, epoch: Any, cov_type: Any, truth: Any, names: dict) -> None:
    from astropy.time import Time

    if not isinstance(ds, xr.Dataset):
        raise AttitudeTypeError(f"ds: expected an xarray.Dataset, got {type(ds).__name__}")
    if epoch is not None and not isinstance(epoch, (str, Time)):
        raise AttitudeTypeError(
            f"epoch: expected an ISO 8601 UTC string or an astropy Time, got {type(epoch).__name__}"
        )
    if cov_type not in COV_TYPES:
        raise AttitudeValueError(f"cov_type: one of {', '.join(COV_TYPES)}, got {cov_type!r}")
    if not isinstance(truth, bool):
        raise AttitudeTypeError(f"truth: expected True or False, got {truth!r}")
    for key, v in names.items():
        if v is not None and not isinstance(v, str):
            raise AttitudeTypeError(f"{key}: expected a string, got {type(v).__name__}")
        if v is not None and _CONTROL.search(v):
            raise AttitudeValueError(
                f"{key}: {v!r} holds a control character (a line break would end the KVN line "
                "and start another: the file would not be an ACM)"
            )
        if v is not None and not v.strip():
            raise AttitudeValueError(f"{key}: an empty name")


def _estimate(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(tick times, q̂, β̂, σ) at the ticks where the estimator has an estimate."""
    from .results import time_values

    missing = [k for k in ("estimate_q", "bias_estimate", "estimation_sigma") if k not in ds]
    if missing:
        raise AttitudeValueError(
            f"ds: no attitude estimate ({', '.join(missing)} missing): an ACM exports what an "
            "estimator recorded; run the flight software with sensors and an estimator "
            "(FlightSoftware(..., sensors=[...], estimator=attitude.estimation.MEKF())), or "
            "export the attitude history as an AEM (attitude.aem.write_aem)"
        )
    if "tick" not in ds.coords:
        raise AttitudeValueError("ds: the estimate has no tick times (coordinate 'tick')")
    t = time_values(ds, "tick")
    q = np.asarray(ds["estimate_q"].transpose("tick", "component").values, dtype=np.float64)
    b = np.asarray(ds["bias_estimate"].transpose("tick", "axis").values, dtype=np.float64)
    s = np.asarray(ds["estimation_sigma"].transpose("tick", "error_state").values, dtype=np.float64)
    if s.shape[1:] != (6,) or q.shape[1:] != (4,) or b.shape[1:] != (3,):
        raise AttitudeValueError(
            "ds: estimate_q (tick, 4), bias_estimate (tick, 3) and estimation_sigma (tick, 6) "
            f"expected, got {q.shape}, {b.shape}, {s.shape}"
        )
    ok = np.isfinite(t) & np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(b), axis=1)
    ok &= np.all(np.isfinite(s), axis=1)
    if not ok.any():
        raise AttitudeValueError(
            "ds: the estimator has no estimate at any tick (it starts at the first valid star "
            "tracker measurement, or from MEKF(initial_attitude=...)); nothing to export"
        )
    t, q, b, s = t[ok], q[ok], b[ok], s[ok]
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise AttitudeValueError("ds: the tick times must increase (backward run?)")
    if not np.all(s > 0):
        i = int(np.argwhere(~(s > 0))[0, 0])
        raise AttitudeValueError(
            f"estimation_sigma: a standard deviation at tick time {t[i]:g} is not positive; the "
            "covariance is not positive definite"
        )
    return t, q, b, s


def write_acm(
    ds: xr.Dataset,
    path: str | os.PathLike,
    *,
    epoch: Any = None,
    object_name: str | None = None,
    international_designator: str | None = None,
    center_name: str | None = None,
    ref_frame_a: str | None = None,
    ref_frame_b: str = "SC_BODY_1",
    originator: str = "attitude",
    message_id: str | None = None,
    time_unit_seconds: float | None = None,
    cov_type: str = "ANGLE_GYROBIAS",
    truth: bool = True,
) -> Path:
    """Write the estimated attitude of ``ds`` with its covariance as a CCSDS ACM (KVN).

    The file is written atomically (to a temporary file, renamed when complete).

    Parameters
    ----------
    ds : xarray.Dataset
        A closed-loop result with an estimator: ``estimate_q`` (tick, component),
        ``bias_estimate`` (tick, axis, rad per time unit), ``estimation_sigma`` (tick,
        error_state: rad and rad per time unit), ``tick``. Ticks before the estimator has an
        estimate (NaN) are left out.
    path : str or Path
        Output file.
    epoch : str or astropy Time, optional
        UTC epoch of ``time = 0`` (EPOCH_TZERO); default the Dataset's ``epoch`` attr.
    object_name : str, optional
        Default: the run's ``object_name`` attr, else ``UNKNOWN``.
    international_designator : str, optional
        INTERNATIONAL_DESIGNATOR (``YYYY-NNNP{PP}``); default the run's ``object_id`` attr if
        it has one, else omitted.
    center_name : str, optional
        Default ``EARTH`` for a run with an orbit, else omitted.
    ref_frame_a : str, optional
        The inertial frame, as :func:`attitude.aem.write_aem` (default the run's
        ``inertial_frame``, else GCRF for a GCRS run, else EME2000).
    ref_frame_b : str
        The body frame (principal axes), default ``SC_BODY_1``; also ``COV_REF_FRAME``.
    originator, message_id : str
        Header fields.
    time_unit_seconds : float, optional
        Seconds per time unit, required for dimensionless runs.
    cov_type : {"ANGLE_GYROBIAS", "ANGLE"}
        The covariance lines: the six variances of the attitude error and the gyro bias
        (deg², (deg/s)²), or the three of the attitude error only.
    truth : bool
        Add the true attitude ``q`` at the run's samples as a second attitude block
        (``ATT_ID = TRUTH``, ``ATT_BASIS = SIMULATED``).

    Returns
    -------
    Path

    Raises
    ------
    AttitudeValueError
        ``ds`` without an estimator's records, a run without an epoch or in dimensionless time
        without ``time_unit_seconds``, a standard deviation that is not positive.
    """
    _check_arguments(
        ds, epoch, cov_type, truth,
        dict(object_name=object_name, international_designator=international_designator,
             center_name=center_name, ref_frame_a=ref_frame_a, ref_frame_b=ref_frame_b,
             originator=originator, message_id=message_id),
    )  # fmt: skip
    if time_unit_seconds is not None:
        time_unit_seconds = as_positive(time_unit_seconds, "time_unit_seconds")
    if "time" not in ds.coords:
        raise AttitudeValueError("ds: not a propagation result (no time coordinate)")
    t, q_est, b_est, sigma = _estimate(ds)
    if truth and "q" not in ds:
        raise AttitudeValueError("truth: ds has no true attitude 'q'; use truth=False")
    target = OutputFile(path, "path")  # checked before any work
    t0, scale = _abs_times(ds, epoch, time_unit_seconds)
    from .results import time_unit, time_values

    dimensionless = time_unit(ds["time"]) in ("1", "")
    # units of the error states: rad, and rad per time unit (error_state_units)
    units = (
        [str(x) for x in np.asarray(ds["error_state_units"].values)]
        if "error_state_units" in ds.coords
        else ["rad"] * 3 + [str(ds["bias_estimate"].attrs.get("units", "1"))] * 3
    )
    if any(x not in ("rad", "1") for x in units[:3]):
        raise AttitudeValueError(
            f"estimation_sigma: attitude errors in {units[:3]}, expected rad (error_state_units)"
        )
    bias_deg_s = _rate_to_deg_s(str(ds["bias_estimate"].attrs.get("units", "1")), scale,
                                dimensionless)  # fmt: skip
    sigma_deg_s = _rate_to_deg_s(units[3], scale, dimensionless)
    tt = t * scale
    t_truth = time_values(ds) * scale if truth else None
    if truth and t_truth.size > 1 and not np.all(np.diff(t_truth) > 0):
        raise AttitudeValueError("ds: the sample times must increase (backward run?)")

    def stamp(x: np.ndarray) -> list[str]:
        try:
            return _stamps(*t0, x)
        except (ValueError, OverflowError) as exc:
            raise AttitudeValueError(
                f"time: the tick times (epoch + t x {scale:g} s) are outside the dates a CCSDS "
                f"ACM can hold ({exc}); check epoch and time_unit_seconds"
            ) from None

    tzero = stamp(np.zeros(1))[0]
    span = np.concatenate([tt[[0, -1]], t_truth[[0, -1]]]) if truth else tt[[0, -1]]
    start, stop = stamp(np.array([span.min(), span.max()]))
    from datetime import datetime, timezone

    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    a = ds.attrs
    name = object_name or str(a.get("object_name") or "UNKNOWN")
    designator = international_designator or (str(a["object_id"]) if a.get("object_id") else None)
    frame_a, bias = _frame_a(ds, ref_frame_a)
    center = center_name or ("EARTH" if "r" in ds else None)
    n_cov = COV_TYPES[cov_type]

    head = [_kvn("CCSDS_ACM_VERS", "2.0")]
    head.append(
        f"COMMENT Estimated attitude and covariance from attitude {__version__}, scenario "
        f"{a.get('scenario', '-')}, method {a.get('method', '-')}"
    )
    head.append(_kvn("CREATION_DATE", created))
    head.append(_kvn("ORIGINATOR", originator))
    if message_id:
        head.append(_kvn("MESSAGE_ID", message_id))
    meta = ["", "META_START"]
    if bias is not None:
        meta.append(
            "COMMENT The run's inertial frame is the GCRS; its attitude is rotated to EME2000 "
            "by the IAU 2006 frame bias (ERFA bp06, 23 mas)"
        )
    meta.append(_kvn("OBJECT_NAME", name))
    if designator:
        meta.append(_kvn("INTERNATIONAL_DESIGNATOR", designator))
    if center:
        meta.append(_kvn("CENTER_NAME", center))
    meta.append(_kvn("TIME_SYSTEM", "UTC"))
    meta.append(_kvn("EPOCH_TZERO", tzero))
    elements = ["ATT", "ATT", "COV", "AD"] if truth else ["ATT", "COV", "AD"]
    meta.append(_kvn("ACM_DATA_ELEMENTS", ", ".join(elements)))
    meta.append(_kvn("START_TIME", start))
    meta.append(_kvn("STOP_TIME", stop))
    meta += ["META_STOP", ""]

    est = ["ATT_START"]
    est.append(
        f"COMMENT Attitude estimated by the MEKF at the flight-software ticks: quaternion from "
        f"{frame_a} to {ref_frame_b} (X_B = M_BA X_A), Q1 Q2 Q3 QC (scalar last), then the "
        f"estimated gyro bias (deg/s, {ref_frame_b} axes); time tags in s since EPOCH_TZERO"
    )
    est.append(_kvn("ATT_ID", "ESTIMATE"))
    est.append(_kvn("ATT_BASIS", "SIMULATED"))
    est.append(_kvn("REF_FRAME_A", frame_a))
    est.append(_kvn("REF_FRAME_B", ref_frame_b))
    est.append(_kvn("NUMBER_STATES", 7))
    est.append(_kvn("ATT_TYPE", "QUATERNION"))
    est.append(_kvn("RATE_TYPE", "GYRO_BIAS"))
    est_tail = ["ATT_STOP", ""]

    tru = []
    if truth:
        tru = ["ATT_START"]
        tru.append(
            f"COMMENT The simulated true attitude at the run's samples: quaternion from "
            f"{frame_a} to {ref_frame_b}, Q1 Q2 Q3 QC"
        )
        tru.append(_kvn("ATT_ID", "TRUTH"))
        tru.append(_kvn("ATT_BASIS", "SIMULATED"))
        tru.append(_kvn("REF_FRAME_A", frame_a))
        tru.append(_kvn("REF_FRAME_B", ref_frame_b))
        tru.append(_kvn("NUMBER_STATES", 4))
        tru.append(_kvn("ATT_TYPE", "QUATERNION"))

    cov = ["COV_START"]
    what = "attitude error (deg^2)" + (", gyro bias ((deg/s)^2)" if n_cov == 6 else "")
    cov.append(
        "COMMENT Diagonal of the MEKF covariance of the error state, "
        f"{what}, about the {ref_frame_b} axes (q = q_est * dq(dtheta)); the off-diagonal terms "
        "are not part of an ACM"
    )
    cov.append(_kvn("COV_ID", "ESTIMATE_COVARIANCE"))
    cov.append(_kvn("COV_BASIS", "SIMULATED"))
    cov.append(_kvn("COV_REF_FRAME", ref_frame_b))
    cov.append(_kvn("COV_TYPE", cov_type))
    cov_tail = ["COV_STOP", ""]

    ad = ["AD_START"]
    ad.append("COMMENT Multiplicative extended Kalman filter (attitude.estimation.MEKF)")
    ad.append(_kvn("AD_METHOD", "EKF"))
    ad.append(_kvn("ATTITUDE_SOURCE", "OBC"))
    ad.append(_kvn("NUMBER_STATES", 7))
    ad.append(_kvn("ATTITUDE_STATES", "QUATERNION"))
    ad.append(_kvn("COV_TYPE", cov_type))
    ad.append(_kvn("REF_FRAME_A", frame_a))
    ad.append(_kvn("REF_FRAME_B", ref_frame_b))
    ad.append(_kvn("RATE_STATES", "GYRO_BIAS"))
    ad.append("AD_STOP")

    for line in head + meta:  # values from the Dataset's attrs too (a scenario's names)
        if _CONTROL.search(line):
            raise AttitudeValueError(
                f"ds: the ACM header line {line.split('=')[0].strip()!r} would hold a control "
                f"character ({line!r}), from the Dataset's attrs; give the value as a parameter"
            )

    def rotated(q: np.ndarray) -> np.ndarray:
        return qt.multiply(bias, q) if bias is not None else q  # x_EME2000 = B x_GCRS

    with target.writing() as tmp:
        with open(tmp, "w", encoding="latin-1", errors="replace", newline="\n") as fh:
            fh.write("\n".join(head + meta + est) + "\n")
            for i in range(0, tt.size, BLOCK):
                sl = slice(i, i + BLOCK)
                q = rotated(q_est[sl])
                bb = b_est[sl] * bias_deg_s
                fh.write(
                    "".join(
                        f"{_time_tag(x)} {' '.join(map(_number, (qx, qy, qz, qw, *bv)))}\n"
                        for x, (qw, qx, qy, qz), bv in zip(
                            tt[sl].tolist(), q.tolist(), bb.tolist(), strict=True
                        )
                    )
                )
            fh.write("\n".join(est_tail) + "\n")
            if truth:
                fh.write("\n".join(tru) + "\n")
                for i in range(0, t_truth.size, BLOCK):
                    sl = slice(i, i + BLOCK)
                    q = rotated(np.asarray(ds["q"].isel(time=sl).values, dtype=np.float64))
                    fh.write(
                        "".join(
                            f"{_time_tag(x)} {' '.join(map(_number, (qx, qy, qz, qw)))}\n"
                            for x, (qw, qx, qy, qz) in zip(
                                t_truth[sl].tolist(), q.tolist(), strict=True
                            )
                        )
                    )
                fh.write("ATT_STOP\n\n")
            fh.write("\n".join(cov) + "\n")
            for i in range(0, tt.size, BLOCK):
                sl = slice(i, i + BLOCK)
                s = sigma[sl, :n_cov].copy()
                s[:, :3] *= _DEG
                s[:, 3:] *= sigma_deg_s
                fh.write(
                    "".join(
                        f"{_time_tag(x)} {' '.join(map(_number, v))}\n"
                        for x, v in zip(tt[sl].tolist(), (s * s).tolist(), strict=True)
                    )
                )
            fh.write("\n".join(cov_tail + ad) + "\n")
            fh.flush()
        target.commit()
    return target.path


# ------------------------------------------------------------------------------------------------
# Reading
# ------------------------------------------------------------------------------------------------

#: Section delimiters of an ACM's data (table 5-1), by the prefix of their START/STOP lines.
_SECTIONS = ("ATT", "PHYS", "COV", "MAN", "AD", "USER")


def _sections(lines: list[str], where: str) -> tuple[dict, dict, list[tuple[str, dict, list]]]:
    """Header, metadata and the data sections ``(kind, keywords, data lines)`` of a KVN ACM
    (nested SENSOR blocks of the AD section are skipped)."""
    header: dict[str, str] = {}
    meta: dict[str, str] = {}
    secs: list[tuple[str, dict[str, str], list[list[str]]]] = []
    state = "header"
    kw: dict[str, str] = {}
    data: list[list[str]] = []
    kind = ""
    for n, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line or line.startswith("COMMENT"):
            continue
        if state == "sensor":
            if line == "SENSOR_STOP":
                state = "section"
            continue
        if line == "META_START":
            if state != "header":
                raise AttitudeValueError(f"{where}:{n}: a second metadata section")
            state = "meta"
            continue
        if line == "META_STOP":
            state = "between"
            continue
        if line.endswith("_START") and line[:-6] in _SECTIONS:
            if state != "between":
                raise AttitudeValueError(f"{where}:{n}: {line} outside the data sections")
            kind, kw, data, state = line[:-6], {}, [], "section"
            continue
        if line.endswith("_STOP") and line[:-5] in _SECTIONS:
            if state != "section" or line[:-5] != kind:
                raise AttitudeValueError(f"{where}:{n}: {line} without {line[:-5]}_START")
            secs.append((kind, kw, data))
            state = "between"
            continue
        if line == "SENSOR_START" and state == "section" and kind == "AD":
            state = "sensor"
            continue
        if state in ("header", "meta") or (state == "section" and "=" in line):
            if "=" not in line:
                raise AttitudeValueError(f"{where}:{n}: expected KEYWORD = value, got {line!r}")
            k, v = (x.strip() for x in line.split("=", 1))
            v = v.split("[", 1)[0].strip()  # a unit in brackets is documentation (6.9.1)
            {"header": header, "meta": meta}.get(state, kw)[k] = v
        elif state == "section":
            data.append(line.split())
        else:
            raise AttitudeValueError(f"{where}:{n}: unexpected line {line!r}")
    if state in ("section", "sensor"):
        raise AttitudeValueError(f"{where}: {kind}_STOP missing (truncated file?)")
    if state in ("header", "meta") and "CCSDS_ACM_VERS" in header:
        raise AttitudeValueError(f"{where}: no complete metadata section (META_START/META_STOP)")
    return header, meta, secs


def _block_values(where: str, data: list, n: int) -> tuple[list[str], np.ndarray]:
    bad = [j for j, d in enumerate(data) if len(d) != n + 1]
    if bad:
        raise AttitudeValueError(
            f"{where}: data line {bad[0] + 1} has {len(data[bad[0]])} fields; expected a time "
            f"tag and {n} numbers"
        )
    try:
        vals = np.array([[float(x) for x in d[1:]] for d in data], dtype=np.float64)
    except ValueError as exc:
        raise AttitudeValueError(f"{where}: a data value is not a number ({exc})") from None
    if not np.all(np.isfinite(vals)):
        raise AttitudeValueError(f"{where}: a data value is not a finite number")
    return [d[0] for d in data], vals.reshape(len(data), n)


def _relative(where: str, tags: list[str], tzero: str, system: str) -> np.ndarray:
    """Seconds since EPOCH_TZERO of the time tags: relative (a number), or absolute epochs."""
    from decimal import Decimal

    try:
        return np.array([float(x) for x in tags], dtype=np.float64)
    except ValueError:
        pass
    try:
        w0, f0 = _parse_epochs([tzero], system)
        w, f = _parse_epochs(tags, system)
    except ValueError as exc:
        raise AttitudeValueError(f"{where}: bad time tag ({exc})") from None
    diff = np.round((w - w0[0]).to_value("s"))
    return np.array([float(Decimal(d) + x - f0[0]) for d, x in zip(diff.tolist(), f, strict=True)])


def _utc_epoch(where: Any, tzero: str, system: str) -> str:
    """EPOCH_TZERO as an ISO 8601 UTC string with a Z (its decimals kept)."""
    try:
        whole, fracs = _parse_epochs([tzero], system)
    except ValueError as exc:
        raise AttitudeValueError(f"{where}: EPOCH_TZERO = {tzero!r}: {exc}") from None
    w = whole[0].copy()
    w.precision = 0
    digits = f"{fracs[0]:f}"[2:] if fracs[0] else ""
    return f"{w.isot}.{digits.ljust(6, '0')}Z"


def read(path: str | os.PathLike) -> xr.Dataset:
    """Read a CCSDS ACM (KVN) with an estimated attitude and its covariance into a Dataset.

    Reads what :func:`write_acm` writes: an attitude block with ``RATE_TYPE = GYRO_BIAS`` (the
    estimate), a covariance block (``ANGLE_GYROBIAS`` or ``ANGLE``), and optionally an attitude
    block without rates (the truth). Quaternion blocks from REF_FRAME_A (inertial) to
    REF_FRAME_B (the body) only.

    Parameters
    ----------
    path : str or Path
        The ACM file.

    Returns
    -------
    xarray.Dataset
        On ``tick`` (s since EPOCH_TZERO, the ``epoch`` attr): ``estimate_q`` (tick, component,
        body to space, scalar first), ``bias_estimate`` (tick, axis; rad s^-1), and
        ``estimation_sigma`` (tick, error_state; rad and rad s^-1: square roots of the
        variances, NaN for the states a covariance type leaves out); with a truth block, ``q``
        on ``time``. Attrs: object, frames, version.

    Raises
    ------
    AttitudeValueError
        Not an ACM, blocks of other types, covariance lines at other times than the estimate's.
    """
    from .results import index_coords, time_attrs

    p = input_path(path, "path")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise file_error(exc, p, "read") from None
    header, meta, secs = _sections(raw.decode("latin-1").splitlines(), str(p))
    vers = header.get("CCSDS_ACM_VERS")
    if vers is None:
        raise AttitudeValueError(f"{p}: not a CCSDS ACM (no CCSDS_ACM_VERS header line)")
    if vers.split(".")[0] != "2":
        raise AttitudeValueError(f"{p}: ACM version {vers} (version 2 is read)")
    for k in ("OBJECT_NAME", "TIME_SYSTEM", "EPOCH_TZERO"):
        if k not in meta:
            raise AttitudeValueError(f"{p}: metadata keyword {k} missing")
    system = meta["TIME_SYSTEM"].upper()
    from ._aem_parse import _SCALES

    if system not in _SCALES and system != "GPS":
        raise AttitudeValueError(f"{p}: TIME_SYSTEM {system} is not read")
    tzero = meta["EPOCH_TZERO"]
    estimate = truth = covariance = None
    frames = None
    for i, (kind, kw, data) in enumerate(secs):
        where = f"{p}: {kind} section {i + 1}"
        if kind == "ATT":
            for k in ("REF_FRAME_A", "REF_FRAME_B", "NUMBER_STATES", "ATT_TYPE"):
                if k not in kw:
                    raise AttitudeValueError(f"{where}: keyword {k} missing")
            att, rate = kw["ATT_TYPE"].upper(), kw.get("RATE_TYPE", "NONE").upper()
            if att not in _ATT_ELEMENTS or rate not in _RATE_ELEMENTS:
                raise AttitudeValueError(
                    f"{where}: ATT_TYPE {att} with RATE_TYPE {rate} is not read (QUATERNION "
                    "with GYRO_BIAS, ANGVEL or NONE)"
                )
            n = _ATT_ELEMENTS[att] + _RATE_ELEMENTS[rate]
            if kw["NUMBER_STATES"] != str(n):
                raise AttitudeValueError(
                    f"{where}: NUMBER_STATES = {kw['NUMBER_STATES']}, but {att} and {rate} make {n}"
                )
            fr = (kw["REF_FRAME_A"], kw["REF_FRAME_B"])
            if frames is not None and fr != frames:
                raise AttitudeValueError(f"{where}: frames {fr} differ from the first block's")
            frames = fr
            tags, vals = _block_values(where, data, n)
            block = (_relative(where, tags, tzero, system), vals, rate)
            if rate == "GYRO_BIAS":
                if estimate is not None:
                    raise AttitudeValueError(f"{where}: a second estimate (GYRO_BIAS) block")
                estimate = block
            else:
                if truth is not None:
                    raise AttitudeValueError(f"{where}: a second attitude block without bias")
                truth = block
        elif kind == "COV":
            ct = kw.get("COV_TYPE", "").upper()
            if ct not in COV_TYPES:
                raise AttitudeValueError(
                    f"{where}: COV_TYPE {ct or '(missing)'} is not read ({', '.join(COV_TYPES)})"
                )
            if covariance is not None:
                raise AttitudeValueError(f"{where}: a second covariance block")
            tags, vals = _block_values(where, data, COV_TYPES[ct])
            if np.any(vals <= 0):
                raise AttitudeValueError(f"{where}: a variance is not positive")
            covariance = (_relative(where, tags, tzero, system), vals, kw.get("COV_REF_FRAME"))
    if estimate is None:
        raise AttitudeValueError(f"{p}: no estimated attitude (ATT block with RATE_TYPE GYRO_BIAS)")
    t, vals, _ = estimate
    if covariance is not None and not np.array_equal(covariance[0], t):
        raise AttitudeValueError(f"{p}: the covariance lines are not at the estimate's times")
    if covariance is not None and covariance[2] not in (None, frames[1]):
        raise AttitudeValueError(
            f"{p}: COV_REF_FRAME {covariance[2]} is not the body frame {frames[1]}"
        )
    rad = np.radians(1.0)
    epoch = _utc_epoch(p, tzero, system)
    ta = {**time_attrs("s", epoch), "long_name": "time of the flight-software tick"}
    coords = {"tick": ("tick", t, ta), **index_coords()}
    data_vars: dict[str, Any] = {
        "estimate_q": (
            ("tick", "component"),
            vals[:, [3, 0, 1, 2]],
            {"units": "1", "long_name": "estimated attitude quaternion, body to space"},
        ),
        "bias_estimate": (
            ("tick", "axis"),
            vals[:, 4:7] * rad,
            {"units": "rad s^-1", "long_name": "estimated gyro bias (body axes)"},
        ),
    }
    if covariance is not None:
        var = covariance[1]
        sig = np.full((t.size, 6), np.nan)
        sig[:, : var.shape[1]] = np.sqrt(var) * rad
        data_vars["estimation_sigma"] = (
            ("tick", "error_state"),
            sig,
            {"long_name": "1-sigma of the error states (sqrt of the covariance diagonal)"},
        )
        coords["error_state"] = ("error_state", np.arange(6, dtype=np.int32))
        coords["error_state_units"] = ("error_state", np.array(["rad"] * 3 + ["rad s^-1"] * 3))
    if truth is not None:
        tt, tv, _ = truth
        coords["time"] = ("time", tt, time_attrs("s", epoch))
        data_vars["q"] = (
            ("time", "component"),
            tv[:, [3, 0, 1, 2]],
            {"units": "1", "long_name": "attitude quaternion, body to space, scalar first"},
        )
    attrs = {
        "Conventions": "CF-1.11",
        "title": f"CCSDS ACM {p.name}",
        "source": f"CCSDS ACM version {vers}, originator {header.get('ORIGINATOR', '-')}",
        "history": f"read by attitude {__version__} (attitude.acm.read) from {p}",
        "epoch": epoch,
        "object_name": meta["OBJECT_NAME"],
        "inertial_frame": frames[0],
        "body_frame": frames[1],
        "acm_version": vers,
        "acm_time_system": system,
        "quaternion_convention": (
            "scalar first (w, x, y, z), Hamilton product, q maps body to space"
        ),
    }
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
