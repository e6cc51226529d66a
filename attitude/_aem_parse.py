"""The parts of :func:`attitude.aem.read`: CCSDS epochs in every AEM time system (whole
seconds through astropy, fractions of a second kept exact in decimal), the segments of a KVN
or an XML message as metadata and data lines, and what a segment may not say (non-finite
values, a version-1 keyword in a version-2 file, START_TIME/STOP_TIME that do not bound the
data).
"""

from __future__ import annotations

from decimal import Decimal
from typing import Any

import numpy as np

from .errors import AttitudeValueError

__all__: list[str] = []


#: AEM time systems read (astropy time scales); GPS is TAI − 19 s.
_SCALES = {"UTC": "utc", "TAI": "tai", "TT": "tt", "TDB": "tdb", "TCG": "tcg", "TCB": "tcb"}
#: Number of values on a data line after the epoch, per attitude type.
_NVALUES = {
    "QUATERNION": 4,
    "QUATERNION/ANGVEL": 7,
    "QUATERNION/RATE": 7,
    "QUATERNION/DERIVATIVE": 8,
}


#: Time systems whose epochs an integer number of SI seconds apart have whole seconds apart
#: (the fractions of a second are then subtracted exactly, in decimal).
_SI_SCALES = ("UTC", "TAI", "TT", "GPS")


def _parse_epochs(stamps: list[str], system: str) -> tuple[Any, list[Decimal]]:
    """CCSDS epochs (``YYYY-MM-DDThh:mm:ss[.d]`` or day of year ``YYYY-DDDThh:mm:ss[.d]``) in
    a time system, as (whole seconds: astropy Time in UTC, decimal fractions of a second).

    GPS time is TAI − 19 s: an epoch labelled in GPS is the instant labelled 19 s later in TAI.
    """
    from astropy.time import Time, TimeDelta

    iso, yday, fracs = [], [], []
    for s in stamps:
        s = s.strip().rstrip("Z")
        s, dot, digits = s.partition(".")
        if dot and not digits.isdigit():
            raise ValueError(f"{s}.{digits}: the fraction of a second is not a number")
        fracs.append(Decimal("0." + digits) if dot else Decimal(0))
        date, _, rest = s.partition("T")
        parts = date.split("-")
        if len(parts) == 2:  # day of year
            yday.append(f"{parts[0]}:{parts[1]}:{rest or '00:00:00'}")
        else:
            iso.append(s)
    if iso and yday:
        raise ValueError("calendar and day-of-year epochs mixed in one segment")
    scale = _SCALES.get(system, "tai")
    if yday:
        whole = Time(yday, format="yday", scale=scale)
    else:
        whole = Time(iso, format="isot", scale=scale)
    if system == "GPS":
        whole = whole + TimeDelta(19.0, format="sec")
    return whole.utc, fracs


def _seconds_since_first(times: list[tuple[Any, list[Decimal]]], systems: set[str]) -> Any:
    """SI seconds since the first epoch (leap seconds included) and that epoch (UTC, ISO with
    a Z), from the segments' (whole seconds, fractions): the nearest float64 of the exact
    decimal difference, so the epochs :func:`write_aem` writes give its times back bit for bit.
    """
    from astropy.time import TimeDelta

    whole = times[0][0] if len(times) == 1 else np.concatenate([w for w, _ in times])
    fracs = [f for _, fs in times for f in fs]
    diff = (whole - whole[0]).to_value("s")
    if systems <= set(_SI_SCALES):  # whole seconds apart: exact integers
        diff = np.round(diff)
    f0 = fracs[0]
    rel = np.array([float(Decimal(d) + f - f0) for d, f in zip(diff.tolist(), fracs, strict=True)])
    if systems <= set(_SI_SCALES):
        first = whole[0].copy()
        first.precision = 0
        digits = f"{f0:f}"[2:] if f0 else ""
        digits = digits.ljust(6 if len(digits) <= 6 else max(9, len(digits)), "0")
        epoch = f"{first.isot}.{digits}Z"
    else:
        from orbit.timescales import format_epoch

        epoch = format_epoch(whole[0] + TimeDelta(float(f0), format="sec"))
    return rel, epoch


def _segments(lines: list[str], where: str) -> tuple[dict[str, str], list[tuple[dict, list]]]:
    header: dict[str, str] = {}
    segs: list[tuple[dict[str, str], list[list[str]]]] = []
    state = "header"
    meta: dict[str, str] = {}
    data: list[list[str]] = []
    for n, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line or line.startswith("COMMENT"):
            continue
        if line == "META_START":
            state, meta = "meta", {}
        elif line == "META_STOP":
            state = "between"
        elif line == "DATA_START":
            if state != "between":
                raise AttitudeValueError(f"{where}:{n}: DATA_START without a metadata block")
            state, data = "data", []
        elif line == "DATA_STOP":
            segs.append((meta, data))
            state = "after"
        elif state in ("header", "meta"):
            if "=" not in line:
                raise AttitudeValueError(f"{where}:{n}: expected KEYWORD = value, got {line!r}")
            k, v = (x.strip() for x in line.split("=", 1))
            (header if state == "header" else meta)[k] = v
        elif state == "data":
            data.append(line.split())
        else:
            raise AttitudeValueError(f"{where}:{n}: unexpected line {line!r}")
    if state == "data":
        raise AttitudeValueError(f"{where}: DATA_STOP missing (truncated file?)")
    return header, segs


def _check_segment(
    where: str, major: str, meta: dict, vals: np.ndarray, parsed: tuple, system: str
) -> None:
    """What :func:`read` refuses in a segment besides its layout: a NaN, inf or overflowing
    value (``nan``, ``inf``, ``1e999``), QUATERNION_TYPE in a version-2 file (its data lines
    are scalar last), and START_TIME / STOP_TIME that are not times or do not bound the data
    (they are the span the data lines cover: within the largest interval between epochs).
    ``parsed``: the data epochs as :func:`_parse_epochs` gives them, in ``system``."""
    from astropy.time import TimeDelta

    from orbit.timescales import quiet_erfa

    def instants(p):
        whole, fracs = p
        return whole + TimeDelta(np.array([float(f) for f in fracs]), format="sec")

    bad = ~np.isfinite(vals)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        raise AttitudeValueError(
            f"{where}: data line {row + 1}, value {col + 1} is not a finite number "
            f"({vals[row, col]!r})"
        )
    if major == "2" and "QUATERNION_TYPE" in meta:
        raise AttitudeValueError(
            f"{where}: QUATERNION_TYPE is a version 1 keyword; a version 2 AEM's data lines are "
            "always scalar last (remove it, or write CCSDS_AEM_VERS = 1.0)"
        )
    tt = instants(parsed)
    n = len(tt)
    gap = float(np.max(np.abs(np.diff((tt - tt[0]).to_value("s"))))) if n > 1 else 0.0
    for key, i in (("START_TIME", 0), ("STOP_TIME", n - 1)):
        if key not in meta:
            continue
        try:
            with quiet_erfa():  # (a date before 1960: ERFA's "dubious year")
                edge = instants(_parse_epochs([meta[key]], system))[0]
                off = float((edge - tt[i]).to_value("s"))
        except ValueError:
            raise AttitudeValueError(
                f"{where}: {key} = {meta[key]!r} is not a CCSDS epoch (YYYY-MM-DDThh:mm:ss or "
                "YYYY-DDDThh:mm:ss)"
            ) from None
        if not abs(off) <= max(1e-3, gap):
            raise AttitudeValueError(
                f"{where}: {key} = {meta[key]} is {abs(off):.6g} s from the "
                f"{'first' if i == 0 else 'last'} data epoch {_epoch_text(tt[i])}: it must "
                "bound the span the data lines cover"
            )


def _epoch_text(t: Any) -> str:
    t = t.copy()
    t.precision = 3
    return str(t.isot)


#: Element names of an XML AEM's data entry, in the order of a KVN data line: the quaternion
#: (scalar last; first when the metadata say QUATERNION_TYPE = FIRST), then the rates or the
#: quaternion's derivative (CCSDS 505.0-B-3: quaternionEphemeris, quaternionAngVel,
#: quaternionDerivative; v1 quaternionState, quaternionEulerRate).
_XML_QUATERNION = ("Q1", "Q2", "Q3", "QC")
_XML_RATES = (("ANGVEL_X", "ANGVEL_Y", "ANGVEL_Z"), ("X_RATE", "Y_RATE", "Z_RATE"))


def _xml_segments(raw: bytes, where: str) -> tuple[dict[str, str], list[tuple[dict, list]]]:
    """An XML AEM as :func:`_segments` reads a KVN one: the header (with CCSDS_AEM_VERS from
    the root's version) and per segment the metadata and data lines ``[EPOCH, values...]``."""
    from orbit.ccsds import leaves, read_xml

    try:
        msg = read_xml(raw, where)
    except ValueError as exc:
        raise AttitudeValueError(str(exc)) from None
    if msg.kind != "AEM":
        raise AttitudeValueError(f"{where}: an XML {msg.kind} message, not an AEM")
    header = {"CCSDS_AEM_VERS": msg.version, **msg.header}
    segs = []
    for k, (meta, entries) in enumerate(msg.segments):
        first = meta.get("QUATERNION_TYPE", "LAST").upper() == "FIRST"
        order = ("QC", "Q1", "Q2", "Q3") if first else _XML_QUATERNION
        lines = []
        for j, entry in enumerate(entries):
            values = {name: text for name, text, _ in leaves(entry)}
            try:
                line = [values["EPOCH"]] + [values[c] for c in order]
            except KeyError as exc:
                raise AttitudeValueError(
                    f"{where}: segment {k + 1}, attitude state {j + 1} has no {exc.args[0]}"
                ) from None
            for names in _XML_RATES:
                line += [values[c] for c in names if c in values]
            line += [values[c + "_DOT"] for c in order if c + "_DOT" in values]
            lines.append(line)
        segs.append((meta, lines))
    return header, segs
