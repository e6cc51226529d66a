"""Interrupt requests that survive being swallowed (Ctrl-C and SIGTERM in the ``attitude`` command).

Python raises ``KeyboardInterrupt`` wherever the interpreter happens to be when it runs the
signal handler, and some of those places swallow it: a ctypes callback (llvmlite calls one
while numba loads machine code: "Exception ignored on calling ctypes callback function"), a
``__del__`` method or weakref finalizer, C code that clears any error of an attribute lookup.
The run then goes on and ends with exit code 0, as if Ctrl-C had never been pressed.

:func:`handling` installs handlers that *record* the request before raising, and the
long-running loops call :func:`check` between compiled calls (every few thousand steps or
output samples; see :data:`attitude._methods.STEP_BUDGET`), as do the file writers before an
output file is renamed into place: a request whose ``KeyboardInterrupt`` was lost is raised
again there. Without :func:`handling` (the library imported by a user's program) nothing is
recorded and :func:`check` never raises: Python's own handler applies.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from collections.abc import Iterator

__all__ = ["check", "clear", "guard_command_start", "handling", "request", "requested"]

_requested: list[int] = []  # the signals received (empty: no request)


def request(signum: int = signal.SIGINT) -> None:
    """Record an interrupt request (what the handlers of :func:`handling` do first)."""
    _requested.append(int(signum))


def requested() -> bool:
    """Whether an interrupt was requested since the last :func:`clear`."""
    return bool(_requested)


def clear() -> None:
    """Forget the requests (a new command starts)."""
    _requested.clear()


def check() -> None:
    """Raise ``KeyboardInterrupt`` if an interrupt was requested (whether or not it was lost)."""
    if _requested:
        raise KeyboardInterrupt


def _handler(signum, frame):
    request(signum)
    raise KeyboardInterrupt


def _quiet_unraisable(info) -> None:
    """``sys.unraisablehook`` while :func:`handling` is active: a ``KeyboardInterrupt`` that
    Python could not raise (in a ctypes callback, a finalizer) is recorded already and raised
    again at the next :func:`check`; its "Exception ignored" traceback is not printed. Anything
    else goes to the default hook."""
    if isinstance(info.exc_value, KeyboardInterrupt) and _requested:
        return
    sys.__unraisablehook__(info)


@contextlib.contextmanager
def handling(
    signals: tuple[str, ...] = ("SIGINT", "SIGTERM"), *, then_ignore: bool = False
) -> Iterator[None]:
    """Install recording handlers for ``signals``; no-op off the main thread.

    On exit the previous handlers are restored, or, with ``then_ignore`` (a process that is
    about to exit: the command line), the signals are ignored: one that arrives after the
    command has finished must not kill the process on its way out (exit status -2 with a
    complete output file).
    """
    clear()
    old = {}
    hook = sys.unraisablehook
    sys.unraisablehook = _quiet_unraisable  # a swallowed interrupt is recorded: no traceback
    for name in signals:
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            old[sig] = signal.signal(sig, _handler)
        except ValueError:  # not in the main thread: leave the process's handlers alone
            break
    try:
        yield
    finally:
        sys.unraisablehook = hook
        for sig, h in old.items():
            with contextlib.suppress(ValueError, TypeError):
                signal.signal(sig, signal.SIG_IGN if then_ignore else h)


def _running_as_the_command() -> bool:
    """Whether this process is the ``attitude`` command being started: ``python -m attitude``
    (while the package is imported, ``sys.argv[0]`` is ``"-m"``) or the console script
    ``attitude`` (the ``__main__`` script of that name)."""
    a0 = sys.argv[0] if sys.argv else ""
    if a0 == "-m":
        argv = list(getattr(sys, "orig_argv", ()))
        for i, a in enumerate(argv):
            if a == "-m":
                return i + 1 < len(argv) and argv[i + 1] == "attitude"
            if a.startswith("-m"):
                return a[2:] == "attitude"
        return False
    main = sys.modules.get("__main__")
    return (
        os.path.basename(a0) in ("attitude", "attitude.exe", "attitude-script.py")
        and getattr(main, "__file__", None) == a0
    )


def _exit_early(signum, frame):
    """Ctrl-C or SIGTERM while the command imports the package: nothing is written yet."""
    with contextlib.suppress(Exception):
        sys.stderr.write("attitude: interrupted (no output file written)\n")
        sys.stderr.flush()
    os._exit(130)


def guard_command_start() -> None:
    """Exit 130 on SIGINT or SIGTERM from now until the command installs its own handlers
    (:func:`handling`), when this process is the ``attitude`` command: the package's imports
    take ~0.7 s, and a signal there printed a ``KeyboardInterrupt`` traceback and killed the
    process by the signal. Called first thing by ``attitude/__init__``; a no-op for a program
    that imports the library."""
    if not _running_as_the_command():
        return
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            signal.signal(sig, _exit_early)
        except ValueError:  # not the main thread
            return
