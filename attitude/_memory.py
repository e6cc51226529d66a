"""Sizes: parsing a size limit, and the memory a single run's result will take, estimated
before any work (:func:`check_run_memory`): a run that would exhaust the machine is refused
with the estimate and the remedies that work for it, never found out by the operating system.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from .errors import AttitudeTypeError, AttitudeValueError, OutputSizeError

__all__ = [
    "MEMORY_FRACTION",
    "check_run_memory",
    "default_memory_limit",
    "format_size",
    "parse_size",
]

#: The default limit of a result held in memory: this fraction of the machine's physical memory
#: (the result is built from buffers of about its own size, so the peak is near twice it).
MEMORY_FRACTION = 0.25
#: Bytes of a result Dataset per output sample and per float column of the compiled output row
#: (the state and its diagnostics, measured: 1.9-2.6 times the row); a conservative 3.
SAMPLE_FACTOR = 3
#: Bytes in memory per tick record column: the records (8) and their Dataset variables (8).
TICK_BYTES = 16


def default_memory_limit() -> float:
    """:data:`MEMORY_FRACTION` of the machine's physical memory (bytes; 4 GB if unknown)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 4e9
    return MEMORY_FRACTION * float(total) if total > 0 else 4e9


def parse_size(value: Any, name: str = "max_output_size") -> float:
    """A size in bytes from a number (bytes), a string such as ``"2 GB"`` or ``"500 MiB"``, an
    astropy Quantity in bytes, or None / ``"none"`` / ``inf`` (no limit: ``math.inf``)."""
    hint = "e.g. 2e9 (bytes), '2 GB', '500 MiB', or None for no limit"
    if value is None or (isinstance(value, str) and value.strip().lower() in ("none", "inf")):
        return math.inf
    from astropy import units as u

    if isinstance(value, str):
        try:
            q = u.Quantity(value.strip())
        except (TypeError, ValueError):
            raise AttitudeValueError(f"{name}: {value!r} is not a size ({hint})") from None
        if q.unit == u.dimensionless_unscaled:
            q = q * u.byte
        value = q
    if isinstance(value, u.Quantity):
        if not value.unit.is_equivalent(u.byte) or value.size != 1:
            raise AttitudeTypeError(f"{name}: expected a size in bytes ({hint}), got {value}")
        v = float(value.to_value(u.byte))
    elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        v = float(value)
    else:
        raise AttitudeTypeError(f"{name}: expected a size ({hint}), got {type(value).__name__}")
    if math.isnan(v) or v <= 0:
        raise AttitudeValueError(f"{name}: must be a positive size ({hint}), got {value}")
    return v


def format_size(nbytes: float) -> str:
    """``12.3 MB``-style (decimal units, as file managers and ``ls -h --si`` show them)."""
    if math.isinf(nbytes):
        return "no limit"
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{int(nbytes)} bytes"


def run_memory(n_samples: int, row_width: int, n_ticks: int, tick_width: int) -> float:
    """The bytes a single run's result takes in memory: ``n_samples`` output samples of
    ``row_width`` float columns (0 when streamed) and ``n_ticks`` tick records of
    ``tick_width`` columns (0 when streamed)."""
    return 8.0 * SAMPLE_FACTOR * n_samples * row_width + TICK_BYTES * n_ticks * tick_width


def check_run_memory(
    limit: float,
    n_samples: int,
    row_width: int,
    n_ticks: int,
    tick_width: int,
    *,
    every: int | None,
    streamable: bool,
) -> float:
    """Refuse a run whose result in memory would exceed ``limit`` bytes (before any work),
    naming the remedies that work for it; returns the estimate.

    ``n_samples`` / ``n_ticks``: what the run keeps in memory (0 for what it streams);
    ``every``: the software's ``record_every`` (None: at the samples; no software: ``n_ticks``
    is 0); ``streamable``: whether ``on_chunk`` streams this run (else it too holds the
    samples in memory).
    """
    samples = run_memory(n_samples, row_width, 0, 0)
    ticks = run_memory(0, 0, n_ticks, tick_width)
    total = samples + ticks
    if total <= limit:
        return total
    what = []
    if n_samples:
        what.append(f"{n_samples} output samples ({format_size(samples)})")
    if n_ticks:
        rec = "every tick" if every == 1 else f"every {every}th tick"
        what.append(f"{n_ticks} tick records, {rec} ({format_size(ticks)})")
    fixes = []
    if ticks > samples:
        fixes.append(
            "record fewer ticks: FlightSoftware(record_every=None), the default, records the "
            "ticks in effect at the output samples; record_every=k every k-th"
        )
    if streamable:
        fixes.append(
            "stream the result to a file: `attitude run`, or propagate(..., "
            "on_chunk=writer.append) with writer = attitude.io.StreamWriter(path) "
            "(memory for 4096 samples and ticks at a time)"
        )
    if samples >= ticks:
        fixes.append("ask for fewer output samples (t)")
    fixes.append("raise the limit: max_output_size='20 GB' (None: no limit)")
    raise OutputSizeError(
        f"max_output_size: the result in memory would take about {format_size(total)} "
        f"({' and '.join(what)}), above the limit of {format_size(limit)}; " + "; or ".join(fixes),
        expected=total,
        limit=limit,
    )
