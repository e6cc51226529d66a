"""The ``attitude`` command (also ``python -m attitude``). See docs/cli.md.

One concept, the command line (argument parsing, the run/info/plot/export commands and what they
print); the work is done by the library modules it calls.

Exit codes: 0 success, 2 bad input (scenario, arguments, files), 1 failure (the propagation
stopped, or an unexpected error). Errors are one line on stderr; ``--debug`` shows tracebacks.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ._progress import Progress
from ._version import __version__

__all__ = ["main"]

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


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


# ------------------------------------------------------------------------------------------------
# commands
# ------------------------------------------------------------------------------------------------


def _fmt_attrs_number(x: Any) -> str:
    try:
        return f"{float(x):.3g}"
    except (TypeError, ValueError):
        return str(x)


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
    ]
    return [f"{label} = {_fmt_attrs_number(attrs[k])}" for k, label in labels if k in attrs]


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


def _ensemble_summary(
    sc: Any, info: dict[str, Any], wall: float, startup: float = 0.0
) -> list[str]:
    """The ``attitude run`` summary of an ensemble run."""
    p = Path(info["path"])
    size = p.stat().st_size / 1e6 if p.exists() else 0.0
    n = int(info.get("n_members_written", 0))
    steps = int(info.get("n_steps", 0))
    unit = "" if sc.body.is_dimensionless else " s"
    lines = [
        f"scenario    {info.get('scenario')}: {info.get('title', '')}",
        f"ensemble    {n} members (seed {info.get('ensemble_seed')}), chunks of "
        f"{info.get('chunk_size')}, {info.get('execution')}",
        f"time span   {float(sc.t[0]):g} .. {float(sc.t[-1]):g}{unit} ({len(sc.t)} samples)",
        f"stored      {_stored_text(info, len(sc.t))}",
        f"method      {info.get('method')}, rtol {info.get('rtol')}, atol {info.get('atol')}: "
        f"{steps} steps ({steps / max(n, 1):.1f} per member), {info.get('n_rejected')} rejected",
        f"speed       {steps / max(wall, 1e-9):.3g} member-steps/s",
    ]
    inv = _invariant_lines(info)
    lines.append(
        "invariants  "
        + ("\n            ".join(inv) if inv else "-")
        + ("\n            (maxima over members)" if inv else "")
    )
    if info.get("events"):
        lines.append(f"events      {info['events']} (attitude info for the percentiles)")
    lines.append(f"output      {p} ({size:.2f} MB) {_timing(startup)}")
    return lines


def _stored_text(info: dict[str, Any], m: int) -> str:
    """What an ensemble file holds, in words (its output choice)."""
    output = str(info.get("ensemble_output", "samples"))
    k = int(info.get("output_every", 1))
    times = "every output time" if k == 1 else f"one output time in {k} ({-(-m // k)} times)"
    if output == "final":
        return "every member's final state"
    if output == "statistics":
        pct = ", ".join(f"{x:g}" for x in np.atleast_1d(info.get("statistics_percentiles", [])))
        return (
            f"percentiles {pct} over members of the pointing error (from the nominal "
            f"attitude) and of |omega|, at {times}; no member trajectories"
        )
    return f"every member at {times}"


def _size_option_hint(exc: Any, sc: Any = None) -> str:
    """The command's words for an ensemble above its size limit: only the remedies that work
    for this scenario (a spacecraft's stores its members: no statistics; its flight software
    recording every k-th tick: record_every)."""
    from .ensemble._plan import format_size

    want = format_size(exc.expected * 1.1).replace(" ", "")
    craft = sc is not None and getattr(sc, "spacecraft", None) is not None
    every = getattr(getattr(sc, "software", None), "record_every", None)
    fixes = []
    if every is not None and "tick records" in str(exc):
        fixes.append('record fewer ticks with record_every = "samples" (the default) in [software]')
    fixes.append(
        "store less with --ensemble-output final or --every K"
        if craft
        else "store less with --ensemble-output final, --ensemble-output statistics or --every K"
    )
    return (
        f"the ensemble's output file would take about {format_size(exc.expected)}, above the "
        f"limit of {format_size(exc.limit)} (--max-output-size, or max_output_size in the "
        f"scenario's [ensemble] table); {'; '.join(fixes)}; or allow it: --max-output-size "
        f"{want} (none: no limit)"
    )


def _run_ensemble(sc: Any, out: Path, args: Any) -> None:
    """``attitude run`` of a scenario with an ``[ensemble]`` table (progress per chunk)."""
    # As the single-run progress bar: "auto" reports when stderr is a terminal.
    mode = getattr(args, "progress", "auto")
    tty = bool(getattr(sys.stderr, "isatty", lambda: False)())
    show = mode == "always" or (mode == "auto" and tty and not getattr(args, "quiet", False))
    startup = _elapsed()
    t0 = time.monotonic()
    chunks = [0]

    def report(done: int, total: int, steps: int) -> None:
        chunks[0] += 1
        if not show:
            return
        el = time.monotonic() - t0
        left = el * (total - done) / done if done else math.inf
        sys.stderr.write(
            f"ensemble chunk {chunks[0]}: {done}/{total} members done, {steps} steps, "
            f"{el:.1f} s elapsed, ~{left:.0f} s left\n"
        )
        sys.stderr.flush()

    from .ensemble import run_scenario
    from .ensemble._plan import format_size, parse_size
    from .errors import AttitudeError, OutputSizeError

    opts: dict[str, Any] = {}
    if getattr(args, "ensemble_output", None):
        opts["output"] = args.ensemble_output
    if getattr(args, "every", None) is not None:
        opts["every"] = args.every
    if getattr(args, "percentiles", None) is not None:
        opts["percentiles"] = args.percentiles
    if getattr(args, "max_output_size", None) is not None:
        try:
            opts["max_output_size"] = parse_size(args.max_output_size, "--max-output-size")
        except AttitudeError as exc:
            raise BadInput(str(exc)) from None

    def estimate(nbytes: int) -> None:
        if not getattr(args, "quiet", False):
            print(f"output      {out}: expected about {format_size(nbytes)}", flush=True)

    try:
        info = run_scenario(
            sc,
            out,
            client=getattr(args, "scheduler", None),
            progress=report,
            method=args.method,
            rtol=args.rtol,
            atol=args.atol,
            on_estimate=estimate,
            **opts,
        )
    except OutputSizeError as exc:
        raise BadInput(_size_option_hint(exc, sc)) from None
    except AttitudeError as exc:  # an output option given on the command line
        msg = str(exc)
        if msg.startswith("client:") and getattr(args, "scheduler", None):
            raise BadInput(
                "--scheduler: a scenario with actuators or flight software runs its ensemble's "
                "members on local threads (Dask clusters run rigid-body ensembles); drop "
                "--scheduler"
            ) from None
        for key, opt in (
            ("output:", "--ensemble-output:"),
            ("every:", "--every:"),
            ("percentiles:", "--percentiles:"),
        ):
            if msg.startswith(key) and key[:-1] in opts:
                raise BadInput(opt + msg[len(key) :]) from None
        raise
    if not getattr(args, "quiet", False):
        print("\n".join(_ensemble_summary(sc, info, time.monotonic() - t0, startup)))


def _output_path(given: str | None, default: Path) -> Path:
    """``-o``: a file name; a directory (existing, or given with a trailing '/') gets the
    scenario's file name inside it."""
    if not given:
        return default
    out = Path(given)
    try:
        is_dir = os.path.isdir(out)
    except (OSError, ValueError):  # a name too long, a NUL byte: reported by the writer
        is_dir = False
    if given.endswith(("/", os.sep)) or is_dir:
        return out / default.name
    return out


#: Methods that take a fixed step (--dt, --order) and ignore the tolerances.
_FIXED_STEP = ("nosquish", "splitting")
#: Methods without a step-size control (the tolerances do not apply).
_NO_TOLERANCES = (*_FIXED_STEP, "exact")
_ENSEMBLE_ONLY = ("ensemble_output", "every", "percentiles", "max_output_size")


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def _warn_unused_options(sc: Any, args: argparse.Namespace) -> None:
    """Warn about command-line options that do not apply to this run (they are ignored)."""
    method = args.method or sc.method
    if sc.ensemble is not None:
        for name in ("dt", "order", "formulation"):
            if getattr(args, name) is not None:
                _warn(
                    f"{_option(name)} does not apply to an ensemble (the members run the "
                    "canonical equations with dop853); ignored"
                )
    else:
        for name in _ENSEMBLE_ONLY:
            if getattr(args, name, None) is not None:
                _warn(f"{_option(name)} applies to scenarios with an [ensemble] table; ignored")
        for name in ("dt", "order"):
            if getattr(args, name) is not None and method not in _FIXED_STEP:
                _warn(
                    f"{_option(name)} applies to the fixed-step methods (nosquish, splitting), "
                    f"not to {method}; ignored"
                )
        for name in ("rtol", "atol"):
            if getattr(args, name) is not None and method in _NO_TOLERANCES:
                _warn(f"{_option(name)} does not apply to the method {method} (no step-size "
                      "control); ignored")  # fmt: skip


def cmd_run(args: argparse.Namespace) -> int:
    from . import scenario as S
    from ._files import OutputFile, is_stdout
    from ._times import TimeGrid

    sc = S.load(args.scenario)
    _warn_unused_options(sc, args)
    if args.stop is not None:
        if not math.isfinite(args.stop):
            raise BadInput(f"--stop {args.stop}: must be a finite time")
        stop = args.stop * sc.time_scale
        limit = stop * (1 + 1e-12) + 1e-300
        end = float(sc.t[-1])
        if stop > end * (1 + 1e-12) + 1e-300:
            unit = "" if sc.time_unit == "1" else f" {_time_unit_name(sc)}"
            _warn(
                f"--stop {args.stop:g}: beyond the scenario's time span (time.stop = "
                f"{end / sc.time_scale:g}{unit}); the run ends at time.stop"
            )
        if isinstance(sc.t, TimeGrid):
            n_keep = len(sc.t.head(limit)) if sc.t[0] <= limit else 0
        else:
            n_keep = int(np.count_nonzero(np.asarray(sc.t) <= limit))
        if n_keep < 2:
            raise BadInput(f"--stop {args.stop:g}: leaves fewer than 2 output samples")
        sc.t = sc.t.head(limit) if isinstance(sc.t, TimeGrid) else sc.t[sc.t <= limit]
    for name in ("rtol", "atol", "dt"):
        v = getattr(args, name)
        if v is not None and not (v > 0 and math.isfinite(v)):
            raise BadInput(f"--{name}: must be a positive number, got {v}")
    if args.method is not None:
        from .propagate import _lookup_method

        try:
            _lookup_method(args.method)
        except ValueError as exc:
            raise BadInput(f"--method: {str(exc).split(': ', 1)[-1]}") from None
    if args.formulation is not None and sc.ensemble is None:
        from .formulations import get_formulation

        if args.formulation != "canonical":
            try:
                get_formulation(args.formulation, args.method or sc.method)
            except ValueError as exc:
                raise BadInput(f"--formulation: {str(exc).split(': ', 1)[-1]}") from None
    method = args.method or sc.method
    if sc.ensemble is None and method in _FIXED_STEP and args.dt is None and sc.dt is None:
        raise BadInput(
            f"--method {method}: a fixed-step method needs its step: give --dt H (in the "
            "scenario's time unit) or dt in the scenario's [integrator] table"
        )
    out = _output_path(args.output, sc.output)
    OutputFile(out, "-o" if args.output else "output.path")  # checked before any work
    args._to_stdout = is_stdout(out)
    if sc.ensemble is not None:  # [ensemble] table: docs/ensemble.md
        _run_ensemble(sc, out, args)
        args._written = out
        return EXIT_OK
    if args.scheduler:
        raise BadInput("--scheduler: only for scenarios with an [ensemble] table")
    progress = Progress(args.progress)
    startup = _elapsed()
    wall_start = time.time()
    from .errors import PropagationError

    try:
        info = sc.run_to_file(
            out,
            progress=progress,
            method=args.method,
            rtol=args.rtol,
            atol=args.atol,
            dt=None if args.dt is None else args.dt * sc.time_scale,
            order=args.order,
            formulation=args.formulation,
        )
    except PropagationError as exc:  # the file holds what was computed: say where
        written = out.exists() and out.stat().st_mtime >= wall_start - 1.0
        where = f"; the samples computed are in {out} (run_status failed)" if written else ""
        raise PropagationError(f"{exc}{where}", time=exc.time) from None
    finally:
        progress.close()
    args._written = out
    if not args.quiet:
        _summary(sc, info, startup, file=sys.stderr if args._to_stdout else sys.stdout)
    return EXIT_OK


def _time_unit_name(sc: Any) -> str:
    """The unit of the scenario's [time] table as written there (e.g. 'min')."""
    from .scenario import tomllib

    try:
        return str(tomllib.loads(sc.source)["time"]["unit"])
    except (KeyError, TypeError, ValueError):
        return "s"


def _numerics(a: dict[str, Any]) -> str:
    """'rtol .., atol ..' for adaptive methods, 'dt .., order ..' for the fixed-step ones."""
    if "dt" in a:
        return f"dt {a['dt']}, order {a.get('order', '-')}"
    return f"rtol {a.get('rtol', '-')}, atol {a.get('atol', '-')}"


def _statistics(a: dict[str, Any]) -> str:
    """Step statistics of the run, leaving out what the method does not count."""
    parts = [f"{a['n_steps']} steps"] if "n_steps" in a else []
    if "n_rejected" in a:
        parts.append(f"{a['n_rejected']} rejected")
    if "n_rhs" in a:
        parts.append(f"{a['n_rhs']} right-hand sides")
    return ", ".join(parts) or "-"


def _summary(sc: Any, a: dict[str, Any], startup: float, file: Any = None) -> None:
    p = Path(a["path"])
    try:
        size = os.path.getsize(p) / 1e6 if p.is_file() else 0.0
    except OSError:
        size = 0.0
    unit = "s" if not sc.body.is_dimensionless else "1"
    n = int(a.get("n_samples", len(sc.t)))
    # the span computed (a terminal event ends the run at its own time, not on the grid)
    t0, t1 = a.get("time_span", (float(sc.t[0]), float(sc.t[n - 1])))
    lines = [
        f"scenario    {a.get('scenario')}: {a.get('title', '')}",
        f"time span   {_span(a, t0, t1, n, unit)}",
        f"method      {a.get('method')}, {_numerics(a)}: {_statistics(a)}",
    ]
    if float(a.get("initial_projection", 0.0)) > 0:
        lines.append(
            f"initial     state projected onto |q| = 1, q.Q = 0 "
            f"(correction {float(a['initial_projection']):.2g})"
        )
    inv = _invariant_lines(a)
    lines.append("invariants  " + ("\n            ".join(inv) if inv else "-"))
    if a.get("events"):
        lines.append("events      " + "\n            ".join(str(a["events"]).split(" | ")))
        if a.get("terminal_event"):
            lines.append(f"            run ended by {a['terminal_event']}")
    lines.append(f"output      {p} ({size:.2f} MB) {_timing(startup)}")
    print("\n".join(lines), file=file)


#: Errors of reading a file that is not a (complete) result file: exit code 2.
_READ_ERRORS = (OSError, RuntimeError, ValueError, KeyError, IndexError, TypeError)


#: Bytes of HDF5 chunk cache per variable of a file the commands read.
READ_CHUNK_CACHE = 1 << 20


def _open(path: str) -> Any:
    """A result file, lazily; a clear error (exit 2) for anything else."""
    import netCDF4

    from . import io

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


def cmd_info(args: argparse.Namespace) -> int:
    ds = _open(args.file)
    try:
        try:
            rows, inv = _info_rows(args, ds)
            budget = _torque_budget(ds)
            wheels = _wheel_lines(ds)
            from ._pointing_stats import pointing_lines
            from .errors import AttitudeValueError

            try:
                pointing = pointing_lines(ds, args.settle)
            except AttitudeValueError as exc:
                raise BadInput(str(exc)) from None
            events = ds.attrs.get("events") or "detector" in ds.dims
            ev = _event_lines(ds) if events else []
        except BadInput:
            raise
        except _READ_ERRORS as exc:
            raise _unreadable(args.file, exc) from None
        for k, v in rows:
            print(f"{k:<11} {v}")
        print("invariants  " + ("\n            ".join(inv) if inv else "-"))
        print("torques     " + ("\n            ".join(budget) if budget else "-"))
        if pointing:
            print("pointing    " + "\n            ".join(pointing))
        if wheels:
            print("wheels      " + "\n            ".join(wheels))
        if events:
            print("events      " + ("\n            ".join(ev) if ev else "-"))
    finally:
        ds.close()
    return EXIT_OK


def _info_rows(args: argparse.Namespace, ds: Any) -> tuple[list[tuple[str, Any]], list[str]]:
    a = dict(ds.attrs)
    n = ds.sizes["time"]
    t = ds["time"].values
    from .results import time_unit

    unit = time_unit(ds["time"])
    if "max_abs_norm_error" not in a and "q" in ds.data_vars:  # (io.write: computed here)
        a.update(_invariants(ds, str(a.get("potential_name", ""))))
    inertia = a.get("inertia")
    rows = [
        ("file", args.file),
        ("scenario", f"{a.get('scenario', '-')}: {a.get('title', '')}"),
        ("status", a.get("run_status", "complete")),
        ("time span", _span(a, float(t[0]), float(t[-1]), n, str(unit))),
        (
            "body",
            f"inertia {np.asarray(inertia).tolist() if inertia is not None else '-'} "
            f"{a.get('inertia_units', '')}",
        ),
        ("potential", a.get("potential", "-")),
        *([("orbit", a["orbit"]), ("frame", a.get("orbit_frame", "-"))] if a.get("orbit") else []),
        ("epoch", a.get("epoch") or "- (times are relative)"),
        ("initial", a.get("initial_state_form", "-")),
        (
            "method",
            f"{a.get('method')} ({a.get('formulation', 'canonical')}), {_numerics(a)}",
        ),
        (
            "statistics",
            _statistics(a),
        ),
        (
            "variables",
            ", ".join(f"{v} [{ds[v].attrs.get('units', '?')}]" for v in ds.data_vars),
        ),
        ("version", a.get("source", "-")),
        ("history", a.get("history", "-")),
    ]
    return rows, _invariant_lines(a)


def _invariants(ds: Any, potential_name: str) -> dict[str, Any]:
    """The invariant diagnostics of a file that does not store them (streamed over its time
    chunks; an ensemble's over blocks of members: the largest over the members that
    succeeded)."""
    from ._invariants import InvariantTracker

    counts = tuple(ds.sizes.get(d, 0) for d in ("wheel", "magnetorquer", "thruster"))
    if "member" in ds["q"].dims:
        from .ensemble._output import member_invariant_attrs

        n = ds.sizes["member"]
        step = max(1, 2**24 // (8 * 16 * max(1, ds.sizes["time"])))
        out: dict[str, Any] = {}
        for i in range(0, n, step):
            part = ds.isel(member=slice(i, i + step))
            st = part["member_status"].values if "member_status" in part else None
            ok = np.ones(part.sizes["member"], bool) if st is None else np.isin(st, (0, 4))
            for k, v in member_invariant_attrs(part, ok, potential_name, counts).items():
                out[k] = max(out.get(k, 0.0), v)
        return out
    from .io import iter_chunks

    tr = InvariantTracker()
    for c in iter_chunks(ds):
        tr.update(c)
    return tr.attrs(potential_name, counts)


def _event_lines(ds: Any, limit: int = 20) -> list[str]:
    """The event detectors of a run and what they found (single runs and ensembles)."""
    a = ds.attrs
    out = [str(x).strip() for x in str(a.get("events", "")).split(" | ") if str(x).strip()]
    if "detector_label" not in ds.variables:
        return out
    from .results import time_unit, time_values

    labels = [str(x) for x in ds["detector_label"].values]
    unit = time_unit(ds["time"])
    unit = "" if unit in ("1", "") else unit
    if "event_first_time" in ds and "member" in ds["event_first_time"].dims:  # ensemble
        first = time_values(ds, "event_first_time")
        n = first.shape[0]
        for j, name in enumerate(labels):
            col = first[:, j]
            have = np.isfinite(col)
            if have.any():
                p5, p50, p95 = np.percentile(col[have], [5, 50, 95])
                out.append(
                    f"{name}: in {int(have.sum())} of {n} members; first at "
                    f"{p5:.6g} / {p50:.6g} / {p95:.6g} {unit} (5/50/95 %)"
                )
            else:
                out.append(f"{name}: in none of {n} members")
        return out
    if "detector_count" in ds:
        counts = np.asarray(ds["detector_count"].values)
        out.append(", ".join(f"{name}: {int(c)}" for name, c in zip(labels, counts, strict=True)))
    if "event_time" in ds:
        t = time_values(ds, "event_time")
        which = np.asarray(ds["event_detector"].values)
        sign = np.asarray(ds["event_direction"].values)
        for i in range(min(t.size, limit)):
            d = "rising" if sign[i] > 0 else "falling"
            out.append(f"t = {t[i]:.12g} {unit}  {labels[int(which[i])]} ({d})")
        if t.size > limit:
            out.append(f"... {t.size - limit} more (variables event_time, event_detector)")
    if a.get("terminal_event"):
        out.append(f"run ended by the terminal event {a['terminal_event']}")
    return out


def _samples(da: Any, *dims: str) -> np.ndarray:
    """A variable's values as (sample, *dims): an ensemble's (member, time) flattened (the
    NaN samples of failed members left out)."""
    lead = [d for d in da.dims if d not in dims]
    v = np.asarray(da.transpose(*lead, *dims).values)
    v = v.reshape(-1, *v.shape[len(lead) :])
    if v.dtype.kind == "f" and lead:  # the samples after a member's failure: left out
        v = v[np.isfinite(v).all(axis=tuple(range(1, v.ndim)))]
    return v


def _wheel_lines(ds: Any) -> list[str]:
    """Per reaction wheel: speed range (rpm), largest applied torque, and how often each limit
    acted (streamed over the file's chunks)."""
    if "wheel_speed" not in ds.data_vars:
        return []
    labels = [str(x) for x in ds["wheel_label"].values]
    n_w = len(labels)
    lo = np.full(n_w, np.inf)
    hi = np.full(n_w, -np.inf)
    umax = np.zeros(n_w)
    flags = np.zeros((n_w, 4), dtype=np.int64)
    n = 0
    step = 65536
    for i in range(0, ds.sizes["time"], step):
        sl = slice(i, i + step)
        # (an ensemble's members are more samples: (member, time, wheel) flattened)
        w = _samples(ds["wheel_speed"].isel(time=sl), "wheel").astype(np.float64)
        u = _samples(ds["wheel_torque"].isel(time=sl), "wheel").astype(np.float64)
        f = _samples(ds["wheel_limit"].isel(time=sl), "wheel").astype(np.int64)
        lo = np.minimum(lo, w.min(axis=0, initial=np.inf))
        hi = np.maximum(hi, w.max(axis=0, initial=-np.inf))
        umax = np.maximum(umax, np.abs(u).max(axis=0, initial=0.0))
        for b in range(4):
            flags[:, b] += ((f >> b) & 1).sum(axis=0)
        n += w.shape[0]
    rpm = 60.0 / (2.0 * np.pi)
    names = ("torque", "speed", "power", "dead band")
    width = max(len(x) for x in labels)
    unit = ds["wheel_torque"].attrs.get("units", "")
    out = [f"{'wheel':<{width}}  {'speed min .. max [rpm]':>24}  {'max |u| [' + unit + ']':>13}  "
           "limits (share of samples)"]  # fmt: skip
    for k in range(n_w):
        lim = ", ".join(
            f"{names[b]} {flags[k, b] / max(n, 1):.1%}" for b in range(4) if flags[k, b]
        )
        out.append(
            f"{labels[k]:<{width}}  {lo[k] * rpm:>11.6g} .. {hi[k] * rpm:<10.6g}  "
            f"{umax[k]:13.4g}  {lim or 'none'}"
        )
    return out


def _torque_budget(ds: Any) -> list[str]:
    """Max and RMS of the torque magnitude per model term (streamed over the file's chunks)."""
    if "torque" not in ds.data_vars or "model" not in ds.dims:
        return []
    labels = [str(x) for x in ds["model_label"].values] if "model_label" in ds else []
    n_model = ds.sizes["model"]
    peak = np.zeros(n_model)
    sq = np.zeros(n_model)
    n = 0
    step = 65536
    for i in range(0, ds.sizes["time"], step):
        tau = _samples(ds["torque"].isel(time=slice(i, i + step)), "model", "axis")
        mag = np.sqrt(np.sum(tau * tau, axis=-1))  # (time, model)
        peak = np.maximum(peak, np.max(mag, axis=0, initial=0.0))
        sq += np.sum(mag * mag, axis=0)
        n += mag.shape[0]
    unit = ds["torque"].attrs.get("units", "")
    width = max((len(x) for x in labels), default=5)
    out = [f"{'model':<{width}}  {'max |tau|':>11}  {'rms |tau|':>11}  [{unit}]"]
    for j in range(n_model):
        name = labels[j] if j < len(labels) else str(j)
        out.append(f"{name:<{width}}  {peak[j]:11.4g}  {np.sqrt(sq[j] / max(n, 1)):11.4g}")
    return out


def cmd_plot(args: argparse.Namespace) -> int:
    try:
        import matplotlib  # noqa: F401 - optional: the plot extra
    except ImportError:
        raise BadInput(
            "plot: matplotlib is not installed; install the plot extra: "
            "pip install 'attitude[plot]'"
        ) from None
    from matplotlib.figure import Figure

    from ._files import OutputFile
    from .errors import AttitudeError
    from .plotting import plot_ensemble, plot_result, plot_torque_budget

    default = Path(args.file).with_suffix(".png")
    out = _output_path(args.output, Path(default.name)) if args.output else default
    formats = Figure().canvas.get_supported_filetypes()
    if not out.suffix:  # matplotlib would add ".png": name the file that is written
        out = out.with_name(out.name + ".png")
    fmt = out.suffix[1:].lower()
    if fmt not in formats:
        raise BadInput(
            f"-o {out}: unknown figure format {out.suffix!r}; use one of "
            + ", ".join(f".{f}" for f in sorted(formats))
        )
    if not (isinstance(args.dpi, int) and 1 <= args.dpi <= 2400):
        raise BadInput(f"--dpi {args.dpi}: expected an integer 1..2400")
    target = OutputFile(out, "-o")  # checked before drawing; written atomically
    ds = _open(args.file)
    try:
        try:
            if getattr(args, "torques", False):
                if "torque" not in ds.data_vars:
                    raise BadInput(f"plot: {args.file} has no per-model torque variable")
                if "member" in ds.dims:
                    raise BadInput(
                        f"plot --torques: draws the torque budget of one run, and {args.file} "
                        "is an ensemble; attitude info prints its torque budget over members"
                    )
                fig = plot_torque_budget(ds)
            elif "member" in ds.dims:  # percentile bands over the members
                fig = plot_ensemble(ds)
            else:
                panels = None
                if args.panels:
                    panels = [p.strip() for p in args.panels.split(",") if p.strip()]
                fig = plot_result(ds, layout=args.layout, frame=args.frame, panels=panels)
        except AttitudeError as exc:  # --frame, --panels, --layout that do not fit the run
            raise BadInput(f"plot: {exc}") from None
        except _READ_ERRORS as exc:
            raise _unreadable(args.file, exc) from None
    finally:
        ds.close()
    import matplotlib.pyplot as plt

    try:
        with target.writing() as tmp:
            fig.savefig(tmp, dpi=args.dpi, format=fmt)
            target.commit()
    finally:
        plt.close(fig)
    args._written = out
    print(f"figure      {out}")
    return EXIT_OK


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


def cmd_export(args: argparse.Namespace) -> int:
    from .acm import write_acm
    from .aem import write_aem

    if not args.ccsds_aem and not args.ccsds_acm:
        raise BadInput("export: give a format, e.g. --ccsds-aem FILE.aem or --ccsds-acm FILE.acm")
    ds = _open(args.file)
    written = []
    try:
        if "member" in ds.dims or args.member is not None:
            ds = _one_member(ds, args)
        common = dict(
            epoch=args.epoch,
            object_name=args.object_name,
            center_name=args.center_name,
            ref_frame_a=args.ref_frame_a,
            ref_frame_b=args.ref_frame_b,
            originator=args.originator,
            time_unit_seconds=args.time_unit_seconds,
        )
        try:
            if args.ccsds_aem:
                path = write_aem(
                    ds,
                    args.ccsds_aem,
                    version=args.aem_version,
                    object_id=args.object_id,
                    attitude_type=args.aem_type,
                    **common,
                )
                written.append(f"CCSDS AEM   {path}")
            if args.ccsds_acm:
                path = write_acm(
                    ds,
                    args.ccsds_acm,
                    international_designator=args.object_id,
                    cov_type=args.acm_cov_type,
                    **common,
                )
                written.append(f"CCSDS ACM   {path}")
        except ValueError as exc:
            raise BadInput(str(exc)) from None
        except (OSError, RuntimeError, KeyError, IndexError, TypeError) as exc:
            raise _unreadable(args.file, exc) from None
    finally:
        ds.close()
    print("\n".join(written))
    return EXIT_OK


# ------------------------------------------------------------------------------------------------
# argument parsing and main
# ------------------------------------------------------------------------------------------------


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit code 2
        self.print_usage(sys.stderr)
        sys.stderr.write(f"attitude: error: {message}\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _percentile_list(text: str) -> list[float]:
    try:
        vals = [float(x) for x in text.replace(" ", "").split(",") if x]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected numbers in [0, 100] separated by commas, e.g. 5,50,95,100, got {text!r}"
        ) from None
    if not vals or not all(0 <= v <= 100 for v in vals):
        raise argparse.ArgumentTypeError(
            f"expected numbers in [0, 100] separated by commas, e.g. 5,50,95,100, got {text!r}"
        )
    return vals


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="attitude",
        description="Rigid-body attitude propagation in canonical quaternion variables "
        "(Arribas, Elipe & Palacios 2006). See docs/cli.md.",
    )
    p.add_argument("--version", action="version", version=f"attitude {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    r = sub.add_parser(
        "run",
        help="run a scenario and write netCDF",
        description=("Run a TOML scenario (docs/scenarios.md) and write the result as netCDF4."),
    )
    r.add_argument("scenario", metavar="SCENARIO", help="scenario TOML file")
    r.add_argument(
        "-o",
        "--output",
        metavar="OUT.nc",
        help="output file (default: the scenario's output.path, else NAME.nc)",
    )
    r.add_argument("--method", help="integration method (auto, taylor, dop853, scipy:DOP853, ...)")
    r.add_argument("--rtol", type=float, help="relative tolerance")
    r.add_argument(
        "--dt", type=float, help="step of the fixed-step methods (nosquish, splitting), time unit"
    )
    r.add_argument("--order", type=int, choices=(2, 4, 6), help="order of nosquish/splitting")
    r.add_argument(
        "--formulation",
        help="equations: canonical (default), euler_angles, schwab, euler_equations",
    )
    r.add_argument("--atol", type=float, help="absolute tolerance")
    r.add_argument(
        "--stop",
        type=float,
        metavar="T",
        help="stop at time T (in the scenario's time unit) instead of time.stop: a shorter run",
    )
    r.add_argument(
        "--progress",
        choices=("auto", "always", "never"),
        default="auto",
        help="progress bar on runs longer than 1 s (auto: when stderr is a terminal)",
    )
    r.add_argument("-q", "--quiet", action="store_true", help="no summary")
    r.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run an [ensemble] scenario on a Dask cluster (e.g. tcp://host:8786; needs "
        "pip install 'attitude[dask]'); default: local threads",
    )
    r.add_argument(
        "--ensemble-output",
        choices=("samples", "final", "statistics"),
        help="[ensemble] scenarios: store every member's samples, every member's final state, "
        "or only percentiles over members of the pointing error and |omega| (default: the "
        "scenario's ensemble.output, else samples)",
    )
    r.add_argument(
        "--every",
        type=_positive_int,
        metavar="K",
        help="[ensemble] scenarios: store every K-th output time",
    )
    r.add_argument(
        "--percentiles",
        type=_percentile_list,
        metavar="P,P,...",
        help="[ensemble] scenarios with --ensemble-output statistics: the percentiles "
        "(default 5,50,95,100; 100 is the maximum)",
    )
    r.add_argument(
        "--max-output-size",
        metavar="SIZE",
        help="[ensemble] scenarios: refuse to write a file expected to be larger (e.g. 500MB, "
        "2GB; none: no limit; default: the scenario's ensemble.max_output_size, else 1 GB)",
    )
    r.set_defaults(func=cmd_run)

    pl = sub.add_parser(
        "plot",
        help="plot a result file",
        description=(
            "A run with an orbit or a reference frame: pointing error and roll/pitch/yaw "
            "against the frame, body rates in deg/s, the Earth's shadow and the events on a "
            "time axis in s, min, h or days. A run with actuators or flight software: the "
            "attitude error at every tick (or |omega| for rate damping), wheel speeds in rpm "
            "with their limits and saturation, motor torques, dipoles and thrust with their "
            "limits, the flight-software modes, the estimation error inside its 3-sigma "
            "bounds and the gyro bias. The paper's layout (q left, Q right, angular "
            "velocity and energy: Figs. 1-3) with --layout paper (the paper's scenarios ask "
            "for it). Ensembles: percentile bands over the members."
        ),
    )
    pl.add_argument("file", metavar="OUT.nc")
    pl.add_argument("-o", "--output", metavar="FIG.png", help="figure file (default OUT.png)")
    pl.add_argument("--dpi", type=int, default=110)
    pl.add_argument(
        "--torques",
        action="store_true",
        help="the torque budget instead: |torque| per model against time, max and RMS",
    )
    pl.add_argument(
        "--layout",
        choices=("auto", "engineer", "paper"),
        default="auto",
        help="engineer (pointing, angles, rates...) or paper (q, Q, omega, energy); default: "
        "the scenario's plot_layout, else engineer for a run with an orbit, actuators or "
        "flight software",
    )
    pl.add_argument(
        "--frame",
        choices=("inertial", "orbital", "rsw", "lvlh", "vnc", "nadir", "sun_pointing", "none"),
        help="reference frame of the pointing error and the angles (default: the scenario's: "
        "its initial state's frame, else its pointing event's, else lvlh on an orbit)",
    )
    pl.add_argument(
        "--panels",
        metavar="P1,P2,...",
        help="engineer's panels, in order: pointing, angles, rates, rates_relative, energy, "
        "torque; closed loop: control_error, rate_norm, wheel_speeds, wheel_torque, dipoles, "
        "thrust, estimation, gyro_bias",
    )
    pl.set_defaults(func=cmd_plot)

    i = sub.add_parser("info", help="what was run and the invariant diagnostics")
    i.add_argument("file", metavar="OUT.nc")
    i.add_argument(
        "--settle",
        metavar="T|P%",
        default=None,
        help="closed loop: the pointing error's statistics leave out the run's first T seconds "
        "(60, 2min) or P %% of it (default 10%%)",
    )
    i.set_defaults(func=cmd_info)

    e = sub.add_parser(
        "export",
        help="export the attitude history (CCSDS AEM) or the estimate (CCSDS ACM)",
        description=(
            "Write the attitude history as a CCSDS Attitude Ephemeris Message (KVN, CCSDS "
            "504.0-B-2): quaternion from REF_FRAME_A (inertial) to REF_FRAME_B (body); and/or "
            "the estimator's attitude, gyro bias and covariance as a CCSDS Attitude "
            "Comprehensive Message (ACM, 504.0-B-2 sect. 5), with the true attitude."
        ),
    )
    e.add_argument("file", metavar="OUT.nc")
    e.add_argument("--ccsds-aem", metavar="FILE.aem", help="AEM file to write")
    e.add_argument(
        "--ccsds-acm",
        metavar="FILE.acm",
        help="ACM file to write: the estimate and its covariance (a run with an estimator)",
    )
    e.add_argument(
        "--acm-cov-type",
        choices=("ANGLE_GYROBIAS", "ANGLE"),
        default="ANGLE_GYROBIAS",
        help="COV_TYPE of the ACM: attitude and gyro-bias variances (default) or attitude only",
    )
    e.add_argument(
        "--aem-version",
        type=int,
        choices=(1, 2),
        default=2,
        help="2: CCSDS 504.0-B-2 (default); 1: 504.0-B-1 (older readers, e.g. GMAT)",
    )
    e.add_argument(
        "--aem-type",
        choices=("QUATERNION", "QUATERNION/ANGVEL"),
        default="QUATERNION",
        help="ATTITUDE_TYPE: quaternions only (default) or with the body angular velocity "
        "(QUATERNION/ANGVEL, deg/s; AEM version 2)",
    )
    e.add_argument("--epoch", help="UTC epoch of time 0 (ISO 8601), if the run has none")
    e.add_argument(
        "--time-unit-seconds",
        type=float,
        metavar="S",
        help="seconds per time unit, to export a dimensionless run",
    )
    e.add_argument(
        "--member",
        type=int,
        metavar="K",
        help="ensemble files: export member K (its stored samples)",
    )
    e.add_argument("--object-name")
    e.add_argument("--object-id", help="OBJECT_ID (AEM), INTERNATIONAL_DESIGNATOR (ACM)")
    e.add_argument("--center-name")
    e.add_argument("--ref-frame-a", help="inertial frame (default: the run's, else EME2000)")
    e.add_argument("--ref-frame-b", default="SC_BODY_1", help="body frame (default SC_BODY_1)")
    e.add_argument("--originator", default="attitude")
    e.set_defaults(func=cmd_export)

    w = sub.add_parser(
        "warmup",
        help="compile the kernels the scenarios need, ahead of their first run",
        description="Run each scenario for its first samples in parallel worker processes, so "
        "that numba compiles (and caches) every kernel they need; later runs load them. "
        "Idempotent: a second warmup compiles nothing. Default: the shipped scenarios/*.toml.",
    )
    w.add_argument("scenarios", nargs="*", metavar="SCENARIO", help="scenario files (TOML)")
    w.add_argument("-j", "--jobs", type=int, help="worker processes (default: the CPUs)")
    w.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    w.set_defaults(func=cmd_warmup)
    return p


def cmd_warmup(args: argparse.Namespace) -> int:
    from ._warmup import warmup

    bar: Any = None

    def progress(done: int, total: int, name: str) -> None:
        nonlocal bar
        if args.quiet:
            return
        if bar is None:
            from tqdm import auto

            bar = auto.tqdm(total=total, desc="warmup", unit="scenario", file=sys.stderr)
        bar.set_postfix_str(name, refresh=False)
        bar.update(done - bar.n)

    try:
        report = warmup(args.scenarios or None, jobs=args.jobs, progress=progress)
    except ValueError as exc:
        raise BadInput(str(exc)) from None
    finally:
        if bar is not None:
            bar.close()
    for name, err in report.failed.items():
        _warn(f"warmup: {name} did not run: {err}")
    n = report.n_compiled
    what = "nothing to compile (all cached)" if n == 0 else f"compiled {n} functions"
    failed = f" ({len(report.failed)} did not run)" if report.failed else ""
    print(f"warmup: {what} for {len(report.compiled)} scenarios{failed} in {report.seconds:.1f} s")
    return EXIT_FAILURE if report.failed else EXIT_OK


def _reset_unhandled_interrupt() -> None:
    """Forget a KeyboardInterrupt that escaped an ``exec`` of a string (CPython 3.8-3.13).

    CPython sets a global flag when a KeyboardInterrupt escapes *any* code run by ``exec`` of
    a string (numba, dataclasses and others exec generated source), and on exit kills the
    process with SIGINT if the flag is set, even though :func:`main` handled the interrupt:
    the exit status was then -2 (killed by SIGINT), not 130. An ``exec`` of our own resets it.
    """
    exec("None")


def _exit_now(code: int) -> None:
    """End the process without the interpreter's teardown (~1 s of freeing numba's LLVM
    engines and HDF5 under load, 3 s measured): after Ctrl-C the prompt comes back at once."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``attitude`` command. Returns the exit code.

    Called without ``argv`` (as the command), an interrupted command ends the process at once
    with status 130 instead of returning.
    """
    from . import _interrupt

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        # Ctrl-C and SIGTERM are recorded before KeyboardInterrupt is raised, so one that is
        # swallowed on the way (a ctypes callback, a __del__) is raised again at the next check
        # between compiled calls, or before the output file is renamed into place.
        # Called as the command (argv None), a signal after the command is ignored: the
        # process is exiting with the command's status.
        with _interrupt.handling(then_ignore=argv is None):
            code = _run_command(args)
            _interrupt.check()  # a request that was swallowed after the last check
            return code
    except KeyboardInterrupt:
        written = getattr(args, "_written", None)
        if written is not None:
            sys.stderr.write(f"attitude: interrupted after {written} was written (complete)\n")
        else:
            sys.stderr.write("attitude: interrupted (no output file written)\n")
        _reset_unhandled_interrupt()
        if argv is None:  # the command: exit now (the output is cleaned up, files are closed)
            _exit_now(130)
        return 130
    finally:
        _interrupt.clear()


def _run_command(args: argparse.Namespace) -> int:
    from . import _interrupt

    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return int(args.func(args))
    except Exception as exc:
        if _interrupt.requested():  # an error caused by the interrupt (e.g. numba's compiler
            raise KeyboardInterrupt from None  # stopped midway): report the interrupt
        if args.debug:
            raise
        return _report_error(exc)


def _report_error(exc: Exception) -> int:
    """Write the one-line message of a failed command; its exit status."""
    from .errors import AttitudeError, PropagationError

    if isinstance(exc, PropagationError):
        sys.stderr.write(f"attitude: failed: {exc}\n")
        return EXIT_FAILURE
    if isinstance(exc, MemoryError):  # (estimated before a run: this is what was not)
        sys.stderr.write(
            f"attitude: error: out of memory ({exc or 'MemoryError'}); nothing was written. "
            "Ask for less: fewer output samples ([time] step), less flight-software telemetry "
            '([software] record_every = "samples", the default), or a shorter span\n'
        )
        return EXIT_BAD_INPUT
    if isinstance(exc, (BadInput, AttitudeError, FileNotFoundError)):
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        sys.stderr.write(f"attitude: error: {msg}\n")
        return EXIT_BAD_INPUT
    sys.stderr.write(f"attitude: failed: {type(exc).__name__}: {exc}\n")
    return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
