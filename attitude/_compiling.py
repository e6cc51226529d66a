"""Saying when a run compiles: the closed-loop kernels take most of a minute the first time.

The first closed-loop run of a fresh install (or after any edit of the package's sources, which
keys the cache) compiles its driver, with the flight software's tick, the integrator and the
diagnostics, in about a minute of CPU; every later run loads them from the disk cache in a fraction
of a second. :func:`watch` wraps a run's progress report: when the driver is neither compiled
in this process nor in the cache (:func:`orbit._shared_jit.will_compile`), it says so before
the run, and says how long numba compiled once it is done. The notices go to the progress
object's ``note(text)`` (the tqdm bar of ``progress=True``, the command's progress line); a
progress object with ``restart()`` is told to start its rate estimate again after a compilation
(the time it took is not the run's pace).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

from orbit._shared_jit import will_compile

__all__ = ["CLOSED_LOOP_COMPILE_CPU_S", "CompileWatch", "compile_estimate", "watch"]

#: CPU seconds of a first closed-loop run's compilation: 61 s for `dop853` on the 2-core
#: development machine at load 1.2 (38-39 s before the drivers carried the coupled orbit).
CLOSED_LOOP_COMPILE_CPU_S = 60


def compile_estimate(cpu_seconds: float) -> float:
    """Wall-clock seconds of a compilation of ``cpu_seconds``: numba compiles on one core, so a
    busy machine stretches it by the load per core (measured: 50-54 s at load 2.7 on 2 cores,
    122 s at load 5.5)."""
    try:
        load = os.getloadavg()[0] / (os.cpu_count() or 1)
    except (OSError, AttributeError):  # pragma: no cover - no load average (Windows)
        load = 1.0
    return cpu_seconds * max(1.0, load)


#: The closed-loop driver each method calls (attributes of the run's entry-point module).
_DRIVERS = {"dop853": "dop853_spacecraft_fsw", "taylor": "taylor_spacecraft_fsw"}


class _Compiles:
    """numba's compile events (``numba:compile``): wall-clock seconds of the outermost ones,
    their number, and the number of functions compiled in all (``functions``)."""

    def __init__(self) -> None:
        from numba.core import event

        class Listener(event.Listener):
            def on_start(inner, ev):
                if self.depth == 0:
                    self.t0 = time.perf_counter()
                self.depth += 1

            def on_end(inner, ev):
                self.depth -= 1
                self.functions += 1
                if self.depth == 0:
                    self.seconds += time.perf_counter() - self.t0
                    self.count += 1

        self.depth = 0
        self.t0 = 0.0
        self.seconds = 0.0
        self.count = 0
        self.functions = 0
        self._event = event
        self._listener = Listener()
        event.register("numba:compile", self._listener)

    def close(self) -> None:
        self._event.unregister("numba:compile", self._listener)


class CompileWatch:
    """A progress callable around another that reports the run's compilation (see module)."""

    def __init__(self, progress: Callable[[int, int, float], None], what: str, estimate: float):
        self.progress = progress
        self.what = what
        self._note = getattr(progress, "note", None)
        self._compiles = _Compiles()
        self._seen = 0  # compilations finished at the last report
        self._pending = False  # compiled since the last report, not yet said
        self._closed = False
        self.note(f"compiling {what}, once (cached afterwards): ~{estimate:.0f} s")

    def note(self, text: str) -> None:
        if self._note is not None:
            self._note(text)

    def _check(self) -> None:
        c = self._compiles
        if c.depth:
            return
        if c.count > self._seen:  # compiled since the last report: the pace starts again
            self._seen = c.count
            self._pending = True
            restart = getattr(self.progress, "restart", None)
            if restart is not None:
                restart()
        elif self._pending:  # a report without a compilation since: say how long it took
            self._pending = False
            self.note(f"compiled {self.what} in {c.seconds:.1f} s")

    def __call__(self, done: int, total: int, t: float) -> None:
        self._check()
        self.progress(done, total, t)

    def close(self) -> None:
        """Stop listening; say how long the compilation took if not said yet."""
        if self._closed:
            return
        self._closed = True
        self._compiles.close()
        if self._pending or self._compiles.count > self._seen:
            self.note(f"compiled {self.what} in {self._compiles.seconds:.1f} s")


def watch(progress: Any, problem: Any, method: str) -> CompileWatch | None:
    """A :class:`CompileWatch` around ``progress`` when the closed-loop run ``problem`` will
    compile its driver, else None (nothing to say)."""
    sr = getattr(problem, "spacecraft", None)
    if progress is None or sr is None or sr.program is None:
        return None
    driver = getattr(problem.entry, _DRIVERS.get(method, ""), None)
    if driver is None or not will_compile(driver):
        return None
    estimate = compile_estimate(CLOSED_LOOP_COMPILE_CPU_S)
    return CompileWatch(progress, "the closed-loop kernels", estimate)
