"""``attitude run`` and ``attitude warmup``: running scenarios, and what a run prints."""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._progress import Progress
from ._common import (
    EXIT_FAILURE,
    EXIT_OK,
    BadInput,
    _elapsed,
    _invariant_lines,
    _span,
    _terminal_event,
    _timing,
    _warn,
)


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
    from ..ensemble._plan import format_size

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

    from ..ensemble import run_scenario
    from ..ensemble._plan import format_size, parse_size
    from ..errors import AttitudeError, OutputSizeError

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
    from .. import scenario as S
    from .._files import OutputFile, is_stdout
    from .._times import TimeGrid

    sc = S.load(args.scenario)
    _warn_unused_options(sc, args)
    if args.stop is not None:
        stop, given = _stop_time(str(args.stop), sc)
        limit = stop * (1 + 1e-12) + 1e-300
        end = float(sc.t[-1])
        if stop > end * (1 + 1e-12) + 1e-300:
            unit = "" if sc.time_unit == "1" else f" {_time_unit_name(sc)}"
            _warn(
                f"--stop {given}: beyond the scenario's time span (time.stop = "
                f"{end / sc.time_scale:g}{unit}); the run ends at time.stop"
            )
        if isinstance(sc.t, TimeGrid):
            n_keep = len(sc.t.head(limit)) if sc.t[0] <= limit else 0
        else:
            n_keep = int(np.count_nonzero(np.asarray(sc.t) <= limit))
        if n_keep < 2:
            raise BadInput(f"--stop {given}: leaves fewer than 2 output samples")
        sc.t = sc.t.head(limit) if isinstance(sc.t, TimeGrid) else sc.t[sc.t <= limit]
    for name in ("rtol", "atol", "dt"):
        v = getattr(args, name)
        if v is not None and not (v > 0 and math.isfinite(v)):
            raise BadInput(f"--{name}: must be a positive number, got {v}")
    if args.method is not None:
        from ..propagate import _lookup_method

        try:
            _lookup_method(args.method)
        except ValueError as exc:
            raise BadInput(f"--method: {str(exc).split(': ', 1)[-1]}") from None
    if args.formulation is not None and sc.ensemble is None:
        from ..formulations import get_formulation

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
    from ..errors import PropagationError

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


def _stop_time(spec: str, sc: Any) -> tuple[float, str]:
    """``--stop``: a number in the scenario's time unit, or a time with its unit (``10min``,
    ``1.5 h``); the time on the run's axis and the text as given."""
    s = spec.strip()
    try:
        value = float(s) * sc.time_scale
    except ValueError:
        value = None
    if value is None:
        if sc.time_unit == "1":
            raise BadInput(
                f"--stop {s}: this scenario's times are plain numbers (a dimensionless body); "
                "give a number"
            )
        from .._times import seconds_of

        value = seconds_of(s)
        if math.isnan(value):
            raise BadInput(
                f"--stop {s}: expected a time, a number in the scenario's time unit "
                f"({_time_unit_name(sc)}) or with its own unit (e.g. 600s, 10min, 1.5h)"
            )
    if not math.isfinite(value):
        raise BadInput(f"--stop {s}: must be a finite time")
    return value, s


def _time_unit_name(sc: Any) -> str:
    """The unit of the scenario's [time] table as written there (e.g. 'min')."""
    from ..scenario import tomllib

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
            lines.append(f"            run ended by {_terminal_event(a['terminal_event'])}")
    lines.append(f"output      {p} ({size:.2f} MB) {_timing(startup)}")
    print("\n".join(lines), file=file)


def cmd_warmup(args: argparse.Namespace) -> int:
    from .._warmup import warmup

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
