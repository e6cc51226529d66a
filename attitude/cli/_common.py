"""What the commands share: errors and warnings, exit codes, timings, reading result files."""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Any

import numpy as np

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2
#: The status of a command whose output's reader went away (128 + SIGPIPE, as the shell's).
EXIT_BROKEN_PIPE = 141


class BadInput(Exception):
    """An error in what the user gave us (exit code 2)."""


def _warn(message: str) -> None:
    """A one-line warning on stderr (as the library's warnings are shown by :func:`main`)."""
    sys.stderr.write(f"attitude: warning: {message}\n")
    sys.stderr.flush()


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the command: one line, no source location."""
    text = str(message).splitlines()[0] if str(message) else category.__name__
    _warn(text)


def _fmt_attrs_number(x: Any) -> str:
    try:
        return f"{float(x):.3g}"
    except (TypeError, ValueError):
        return str(x)


def _terminal_event(text: str) -> str:
    """The ``terminal_event`` attr ('shadow_out at t = 3666.3802822284633', the time kept to
    the bit in the file) with its time to 12 digits, as the events are listed."""
    import re

    return re.sub(r"(at t = )([-+0-9.eE]+)", lambda m: f"{m[1]}{float(m[2]):.12g}", text)


def _invariant_lines(attrs: dict[str, Any]) -> list[str]:
    # q.Q relative to |Q| (q.Q alone is in the momenta's units); files written before the
    # relative maximum existed show the absolute one
    qQ = ("max_rel_qQ", "max |q.Q| / |Q|") if "max_rel_qQ" in attrs else ("max_abs_qQ", "max |q.Q|")
    labels = [
        ("max_abs_norm_error", "max | |q| - 1 |"),
        qQ,
        ("max_rel_energy_error", "max |H - H0|/|H0| (conserved)"),
        ("max_rel_G_error", "max |G - G0|/|G0| (conserved)"),
        ("max_rel_Gz_error", "max |Gz - Gz0|/|G0| (conserved)"),
        ("max_rel_energy_variation", "max |H - H0|/|H0| (time-dependent potential: not conserved)"),
        ("max_rel_energy_work", "max |H - H0|/|H0| (actuators do work: not conserved)"),
        ("max_rel_total_energy_error", "max |E - E0|/|E0|, E of orbit and attitude (total)"),
    ]
    lines = []
    for k, label in labels:
        if k not in attrs:
            continue
        line = f"{label} = {_fmt_attrs_number(attrs[k])}"
        if k in ("max_rel_energy_variation", "max_rel_energy_work") and (
            "max_abs_energy_change" in attrs
        ):
            # not conserved: the change itself first, then H0 and the ratio (a body starting
            # near rest makes any ratio large: 7.2e+05 for the orbit-raising burn)
            unit = f" {attrs['energy_units']}" if attrs.get("energy_units") else ""
            why = label[label.index("(") + 1 : -1]
            line = (
                f"max |H - H0| = {_fmt_attrs_number(attrs['max_abs_energy_change'])}{unit} "
                f"({why}; H0 = {_fmt_attrs_number(attrs['initial_energy'])}{unit}, relative "
                f"{_fmt_attrs_number(attrs[k])})"
            )
        lines.append(line)
    return lines


def _process_age() -> float | None:
    """Seconds since this process started (Linux: /proc), else None."""
    try:
        with open("/proc/self/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        return uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: starttime
    except (OSError, ValueError, IndexError, AttributeError):
        return None


#: When the command started: the process's start (interpreter and imports included) where the
#: system says, else the import of this module.
_T_IMPORT = time.monotonic()


def _elapsed() -> float:
    """Seconds since the command started (the process, else the import of the CLI)."""
    age = _process_age()
    return age if age is not None else time.monotonic() - _T_IMPORT


def _timing(startup: float) -> str:
    """'in 5.62 s (0.71 s of it start-up: ...)', measured from the command's start."""
    total = _elapsed()
    start = min(startup, total)
    return f"in {total:.2f} s ({start:.2f} s of it start-up: Python, imports, scenario)"


def _span(attrs: dict[str, Any], t0: float, t1: float, n: int, unit: str) -> str:
    u = "" if unit in ("1", "") else f" {unit}"
    s = f"{t0:g} .. {t1:g}{u} ({n} sample{'' if n == 1 else 's'})"
    if attrs.get("epoch"):
        s += f" from epoch {attrs['epoch']}"
    return s


#: Errors of reading a file that is not a (complete) result file: exit code 2.
_READ_ERRORS = (OSError, RuntimeError, ValueError, KeyError, IndexError, TypeError)

#: Bytes of HDF5 chunk cache per variable of a file the commands read.
READ_CHUNK_CACHE = 1 << 20


def _open(path: str) -> Any:
    """A result file, lazily; a clear error (exit 2) for anything else."""
    import netCDF4

    from .. import io

    # The file's variables opened with a 1 MiB chunk cache each, not netCDF's 64 MiB: the
    # commands read each chunk once (0.8 -> 0.33 GB of RSS reading a 294 MB file through).
    cache = netCDF4.get_chunk_cache()
    netCDF4.set_chunk_cache(READ_CHUNK_CACHE, *cache[1:])
    try:
        ds = io.read(path, load=False)
    except ValueError as exc:
        raise BadInput(str(exc)) from None
    finally:
        netCDF4.set_chunk_cache(*cache)
    problem = None
    if "time" not in ds.dims or ds.sizes["time"] == 0:
        problem = "no 'time' dimension with samples"
    elif ("q" not in ds.data_vars or ds["q"].dims[-2:] != ("time", "component")) and not (
        "member" in ds.dims and "pointing_error_percentiles" in ds.data_vars
    ):  # an ensemble's statistics-only file has percentiles instead of q
        problem = "no attitude quaternion variable q(time, component)"
    if problem:
        ds.close()
        raise BadInput(f"{path}: not an attitude result file ({problem})")
    try:
        _read_through(ds)
    except _READ_ERRORS as exc:
        ds.close()
        raise _unreadable(path, exc) from None
    return ds


def _read_through(ds: Any, block: int = 1 << 20) -> None:
    """Read every value of a lazily opened file once, in blocks of about ``block`` values
    (bounded memory): every command then refuses a corrupt file alike, whichever variables it
    needs (the writers checksum every chunk)."""
    for v in ds.variables.values():
        if v.ndim == 0 or v.shape[0] == 0:
            v.values  # noqa: B018
            continue
        step = max(1, block // max(1, v.size // v.shape[0]))
        for i in range(0, v.shape[0], step):
            v[i : i + step].values  # noqa: B018


def _unreadable(path: str, exc: BaseException) -> BadInput:
    why = str(exc).splitlines()[0] if str(exc) else ""
    return BadInput(
        f"{path}: cannot be read ({type(exc).__name__}: {why}); the file is truncated, corrupt "
        "or not an attitude result file"
    )


def _one_member(ds: Any, args: argparse.Namespace) -> Any:
    """The member ``--member K`` of an ensemble file (export writes one attitude history)."""
    if "member" not in ds.dims:
        raise BadInput(f"--member: {args.file} is a single run, not an ensemble; drop --member")
    n = ds.sizes["member"]
    if "q" not in ds:
        raise BadInput(
            f"export: {args.file} holds the statistics of an ensemble of {n} members, not their "
            "attitudes; run the ensemble storing the members (--ensemble-output samples) to "
            "export one of them"
        )
    if ds.sizes["time"] < 2:
        raise BadInput(
            f"export: {args.file} holds each member's final state only; an AEM needs an "
            "attitude history (run with --ensemble-output samples)"
        )
    if args.member is None:
        raise BadInput(
            f"export: {args.file} is an ensemble of {n} members; a CCSDS AEM holds one attitude "
            f"history: choose a member with --member K (0..{n - 1})"
        )
    members = np.asarray(ds["member"].values)
    if not np.any(members == args.member):
        raise BadInput(
            f"--member {args.member}: no such member in {args.file} (members "
            f"{int(members[0])}..{int(members[-1])})"
        )
    return ds.sel(member=args.member)
