"""The ``attitude`` command (also ``python -m attitude``). See docs/cli.md.

One concept, the command line (argument parsing, the run/info/plot/export commands and what they
print); the work is done by the library modules it calls.

Exit codes: 0 success, 2 bad input (scenario, arguments, files), 1 failure (the propagation
stopped, or an unexpected error). Errors are one line on stderr; ``--debug`` shows tracebacks.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import warnings

from .._progress import Progress
from ._common import EXIT_BAD_INPUT, EXIT_BROKEN_PIPE, EXIT_FAILURE, BadInput, _show_warning
from ._figures import cmd_export, cmd_plot, cmd_view
from ._info import cmd_info
from ._parser import build_parser
from ._run import cmd_run, cmd_warmup

__all__ = [
    "Progress", "build_parser", "cmd_export", "cmd_info", "cmd_plot", "cmd_run", "cmd_view",
    "cmd_warmup", "main",
]  # fmt: skip


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
    from .. import _interrupt

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
    if argv is None:  # the command, done: its files are closed; skip the interpreter's teardown
        _exit_after_atexit(code)
    return code


def _exit_after_atexit(code: int) -> None:
    """End the command's process with ``code`` once the ``atexit`` functions have run (logging
    flushed, worker pools joined), without the interpreter's teardown of every module: freeing
    numba's compiled libraries and LLVM engines took 0.5 s of each run of the README's main job
    (2.95 s against 2.45 s, measured in turn)."""
    import atexit

    with contextlib.suppress(Exception):
        atexit._run_exitfuncs()
    _exit_now(code)


def _run_command(args: argparse.Namespace) -> int:
    from .. import _interrupt

    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return int(globals()[f"cmd_{args.command}"](args))  # (a test may patch one)
    except BrokenPipeError:
        # the reader of the output went away (`attitude info out.nc | head`): stop quietly, as
        # a command killed by SIGPIPE does (and let nothing flush to the closed pipe at exit)
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):  # no real stdout (a test's capture)
            pass
        return EXIT_BROKEN_PIPE
    except Exception as exc:
        if _interrupt.requested():  # an error caused by the interrupt (e.g. numba's compiler
            raise KeyboardInterrupt from None  # stopped midway): report the interrupt
        if args.debug:
            raise
        return _report_error(exc)


def _report_error(exc: Exception) -> int:
    """Write the one-line message of a failed command; its exit status."""
    from ..errors import AttitudeError, PropagationError

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
