"""Reading CCSDS OEM files for :meth:`orbit.EphemerisOrbit.from_oem`: the file name checked,
the segments of a KVN message (read by ccsds-ndm-py) or an XML one (:mod:`orbit.ccsds`) as
(metadata, epoch strings, states), and epochs in a form astropy reads. The checks of what the
segments say (frames, centres, time systems, velocities) stay with ``from_oem``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from .errors import OrbitTypeError, OrbitValueError

__all__: list[str] = []


_DOY = re.compile(r"^(\d{4})-(\d{3})T(.*)$")


def _oem_time(s: str, scale: str) -> str:
    """A CCSDS epoch string in a form astropy reads (day-of-year -> 'yday')."""
    m = _DOY.match(s.strip())
    if m:
        return f"{m.group(1)}:{m.group(2)}:{m.group(3).replace('Z', '')}"
    return s.strip().rstrip("Z")


def _oem_path(path: Any) -> Path:
    """The OEM file to read: a str, bytes or path-like naming an existing file."""
    if isinstance(path, (bool, int, float)) or path is None:
        raise OrbitTypeError(
            f"path: expected a file name (str or pathlib.Path), got {type(path).__name__} {path!r}"
        )
    try:
        name = os.fsdecode(os.fspath(path))
    except TypeError:
        raise OrbitTypeError(
            f"path: expected a file name (str or pathlib.Path), got {type(path).__name__}"
        ) from None
    if not name or "\x00" in name:
        raise OrbitValueError(f"path: {name!r} is not a file name (empty, or a NUL byte)")
    p = Path(name)
    try:
        ok = p.is_file()
    except OSError as exc:  # a name too long, a loop of links...
        shown = name if len(name) <= 80 else name[:60] + "..."
        raise OrbitValueError(f"path: cannot read {shown!r}: {exc.strerror or exc}") from None
    if not ok:
        raise OrbitValueError(f"path: no such OEM file: {p}")
    return p


def _oem_kvn(p: Path) -> list[tuple[dict[str, str], list[str], np.ndarray]]:
    """The segments of a KVN OEM, read by ccsds-ndm-py: (metadata, epoch strings, states)."""
    try:
        import ccsds_ndm
    except ImportError:  # pragma: no cover - declared dependency
        raise OrbitValueError(
            "path: reading an OEM needs the ccsds-ndm-py package (pip install ccsds-ndm-py)"
        ) from None
    try:
        msg = ccsds_ndm.Oem.from_file(str(p))
    except Exception as exc:  # the reader's own exception classes
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise OrbitValueError(f"path: {p} is not a readable CCSDS OEM: {first}") from None
    out = []
    for seg in msg.segments:
        m = seg.metadata
        meta = {
            "OBJECT_NAME": str(m.object_name),
            "CENTER_NAME": str(m.center_name),
            "REF_FRAME": str(m.ref_frame),
            "TIME_SYSTEM": str(m.time_system),
        }
        states = np.asarray(seg.data.state_vector_numpy, dtype=np.float64)
        out.append((meta, [str(e) for e in seg.data.state_vector_epochs], states))
    return out


#: Units of the state-vector elements of an XML OEM (the only ones CCSDS 502.0-B-3 allows).
_OEM_XML_UNITS = {"km": ("X", "Y", "Z"), "km/s": ("X_DOT", "Y_DOT", "Z_DOT")}


def _oem_xml(raw: bytes, p: Path) -> list[tuple[dict[str, str], list[str], np.ndarray]]:
    """The segments of an XML OEM (NDM/XML, :mod:`orbit.ccsds`): (metadata, epochs, states)."""
    from .ccsds import leaves, read_xml

    try:
        msg = read_xml(raw, p.name)
    except ValueError as exc:
        raise OrbitValueError(f"path: {p} is not a readable CCSDS OEM: {exc}") from None
    if msg.kind != "OEM":
        raise OrbitValueError(f"path: {p} is an XML {msg.kind} message, not an OEM")
    unit_of = {k: u for u, keys in _OEM_XML_UNITS.items() for k in keys}
    out = []
    for k, (meta, entries) in enumerate(msg.segments):
        where = f"{p.name} segment {k + 1}"
        for key in ("CENTER_NAME", "REF_FRAME", "TIME_SYSTEM"):
            if key not in meta:
                raise OrbitValueError(f"{key}: {where} has no {key} (a mandatory OEM keyword)")
        epochs, rows = [], []
        for j, entry in enumerate(entries):
            if entry.tag.rsplit("}", 1)[-1] != "stateVector":
                continue  # covariance and other optional blocks
            values = {name: (text, attrs) for name, text, attrs in leaves(entry)}
            try:
                row = []
                for key in ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT"):
                    text, attrs = values[key]
                    unit = attrs.get("units", unit_of[key])
                    if unit != unit_of[key]:
                        raise OrbitValueError(
                            f"path: {where} state {j + 1}: {key} in {unit!r}; an OEM gives "
                            f"{unit_of[key]}"
                        )
                    row.append(float(text))
                epochs.append(values["EPOCH"][0])
            except KeyError as exc:
                raise OrbitValueError(
                    f"path: {where} state {j + 1} has no {exc.args[0]} element"
                ) from None
            except ValueError as exc:
                if isinstance(exc, OrbitValueError):
                    raise
                raise OrbitValueError(
                    f"path: {where} state {j + 1}: a value is not a number ({exc})"
                ) from None
            rows.append(row)
        out.append((meta, epochs, np.array(rows, dtype=np.float64).reshape(-1, 6)))
    return out
