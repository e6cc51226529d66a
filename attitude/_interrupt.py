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
import signal
import sys
from collections.abc import Iterator

__all__ = ["check", "clear", "handling", "request", "requested"]

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
