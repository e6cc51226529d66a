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

numba compiles on one core. While a closed-loop driver compiles, :func:`closed_loop_helper`
compiles the flight software's kernels (the tick's sensors, estimator, guidance and frames) in a
second process (:func:`_main`), which saves them to the disk cache; the run's
own compilation reaches them later, waits for the helper if it is still at them (the kernels'
lock files, :mod:`orbit._shared_jit`) and loads them. Set ``ATTITUDE_COMPILE_HELPER=0`` to
compile in one process (``attitude warmup``'s workers do: they already fill the cores).
"""

from __future__ import annotations

import atexit
import os
import pickle
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from orbit._shared_jit import will_compile

__all__ = [
    "CLOSED_LOOP_COMPILE_CPU_S",
    "CompileWatch",
    "closed_loop_helper",
    "closed_loop_items",
    "compile_estimate",
    "helper",
    "helper_on",
    "open_loop_helper",
    "watch",
    "where",
]

#: Seconds of a first closed-loop run's compilation on one core (`dop853`, 2-core development
#: machine, load ~1.1: 70.8-73.8 s), and with the compile helper on the other (49.4-51.5 s).
CLOSED_LOOP_COMPILE_CPU_S = 70
CLOSED_LOOP_COMPILE_HELPED_S = 50


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

    def __init__(
        self,
        progress: Callable[[int, int, float], None],
        what: str,
        estimate: float,
        ready: Callable[[], bool] | None = None,
    ):
        self.progress = progress
        self._ready = ready  # whether what was announced is compiled (or loaded) in the process
        self.what = what
        self._note = getattr(progress, "note", None)
        self._compiles = _Compiles()
        self._seen = 0  # compilations finished at the last report
        self._pending = False  # compiled since the last report, not yet said
        self._closed = False
        self._t0 = time.perf_counter()
        self._loaded = False  # said that another process compiled it
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
        elif c.count == 0 and not self._loaded and self._is_ready():
            self._said_loaded()

    def _is_ready(self) -> bool:
        return self._ready is not None and self._ready()

    def _said_loaded(self) -> None:
        # Nothing compiled here: another process compiled it meanwhile (a test worker, a second
        # run), and this one waited for its lock files and loaded it.
        self._loaded = True
        wait = time.perf_counter() - self._t0
        self.note(f"loaded {self.what}, compiled by another process meanwhile, in {wait:.1f} s")
        restart = getattr(self.progress, "restart", None)
        if restart is not None:
            restart()

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
        elif self._compiles.count == 0 and not self._loaded and self._is_ready():
            self._said_loaded()


def watch(progress: Any, problem: Any, method: str) -> CompileWatch | None:
    """A :class:`CompileWatch` around ``progress`` when the closed-loop run ``problem`` will
    compile its driver, else None (nothing to say)."""
    sr = getattr(problem, "spacecraft", None)
    if progress is None or sr is None or sr.program is None:
        return None
    from ._core import fsw

    driver = getattr(problem.entry, _DRIVERS.get(method, ""), None)
    if driver is None or not will_compile(driver):
        return None
    helped = helper_on() and will_compile(fsw.fsw_boundary.dispatcher)
    estimate = compile_estimate(
        CLOSED_LOOP_COMPILE_HELPED_S if helped else CLOSED_LOOP_COMPILE_CPU_S
    )
    return CompileWatch(
        progress, "the closed-loop kernels", estimate, lambda: bool(driver.signatures)
    )


#: The helper's first lines: this package, from the tree this process imported it from.
_BOOT = """\
import importlib.util, os, sys
here = sys.argv[1]
spec = importlib.util.find_spec("attitude")
if spec is None or os.path.dirname(os.path.realpath(spec.origin)) != here:
    sys.path.insert(0, os.path.dirname(here))
importlib.import_module("attitude._compiling")._main()
"""

#: The environment variable that turns the compile helper off ("0").
HELPER_ENV = "ATTITUDE_COMPILE_HELPER"
_HELPERS: list[subprocess.Popen] = []


def helper(items: Sequence[tuple[str, str, tuple, bool]]) -> subprocess.Popen | None:
    """Start a process that compiles ``items`` into the disk cache, one after the other.

    Parameters
    ----------
    items : sequence of (str or tuple, str, tuple, bool or "call")
        (module, name, signature, from Python): the kernel ``module.name`` (an
        ``orbit._shared_jit.jit`` kernel) for the numba types ``signature``, as Python calls it
        if the last item is true, else as other kernels call it; ``module`` a module's name,
        or ``(module, function, args)`` for the module that function returns (:func:`where`).
        With ``"call"`` last, ``module.name(*signature)`` is called instead (what it calls
        compiles).

    Returns
    -------
    subprocess.Popen or None
        The process (ended with this one if still running), or None when the helper is off
        (:func:`helper_on`) or could not start.
    """
    if not helper_on() or not items:
        return None
    try:
        data = pickle.dumps(list(items))
        proc = subprocess.Popen(
            [sys.executable, "-c", _BOOT, str(Path(__file__).resolve().parent)],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        # the items, then the pipe left open: the helper ends when it closes (this process
        # ended, even killed), see _main
        proc.stdin.write(len(data).to_bytes(8, "little") + data)
        proc.stdin.flush()
    except (OSError, pickle.PicklingError, ValueError):  # no helper: this process compiles all
        return None
    if not _HELPERS:
        atexit.register(_end_helpers)
    _HELPERS[:] = [p for p in _HELPERS if p.poll() is None]
    _HELPERS.append(proc)
    return proc


def closed_loop_helper(
    driver: Any,
    P: tuple,
    ctl: tuple,
    after: Callable[[], list[tuple]] = list,
    software: bool = True,
) -> subprocess.Popen | None:
    """The helper of a closed-loop run whose ``driver`` will compile: :func:`closed_loop_items`
    of its ``P`` and ``ctl``, then ``after()`` (what the run compiles after its driver); the
    latter alone when not ``software`` (the Taylor driver reaches the software's kernels first,
    and would only wait for the helper there). None when the driver is compiled already, or
    the helper is off."""
    from ._core import fsw

    if not helper_on() or not will_compile(driver) or not _on_disk(driver):
        return None  # (without a disk cache the helper's work would stay in the helper)
    if software and will_compile(fsw.fsw_boundary.dispatcher):
        # the numerical orbit before the diagnostics: the run needs those only after its
        # integration, and waits for them if the helper is still at them
        return helper(closed_loop_items(P, ctl, [NUMERICAL_ORBIT_ITEM, *after()]))
    items = after()
    if items and will_compile(_kernel(items[0])):
        return helper([*items, NUMERICAL_ORBIT_ITEM])
    return None


#: An item of a closed-loop run's helper, a call, not a kernel (:func:`_compile`): what a
#: run on a numerical orbit compiles from Python before its driver
#: (:func:`attitude._warmup.build_numerical_orbit_scenario`).
NUMERICAL_ORBIT_ITEM = ("attitude._warmup", "build_numerical_orbit_scenario", (), "call")


def closed_loop_items(P: tuple, ctl: tuple, after: Sequence[tuple] = ()) -> list[tuple]:
    """What the helper of a closed-loop run compiles: the flight software's boundary
    (:func:`attitude._core.fsw.fsw_boundary`, the command source the drivers inline) for the
    run's ``P`` and ``ctl``, which compiles the kernels the inlined tick calls (sensors,
    estimator, frames, modes), then the items ``after`` (what the run compiles after its
    driver)."""
    from numba import typeof
    from numba.core import types

    y = types.Array(types.float64, 1, "C")  # (the state row of the driver's work array)
    sig = (typeof(P), y, types.float64, types.float64, typeof(ctl))
    return [("attitude._core.fsw", "fsw_boundary", sig, False), *after]


def where(module: Any) -> str | tuple | None:
    """How the helper finds the compiled entry points ``module``: its name if importable, the
    call that makes a specialised copy (:func:`attitude._core.models.entry_points`), or None
    (a user's module)."""
    name = module.__name__
    if sys.modules.get(name) is module:
        return name
    args = vars(module).get("__entry_args__")
    return None if args is None else ("attitude._core.models", "entry_points", args)


def open_loop_helper(kernel: Any, items: Callable[[], list[tuple]]) -> subprocess.Popen | None:
    """The helper of a run without flight software: ``items()`` (what it compiles after its
    integrator, ``kernel`` the first of them) when ``kernel`` will compile."""
    if not helper_on() or not will_compile(kernel) or not _on_disk(kernel):
        return None
    return helper(items())


def _on_disk(kernel: Any) -> bool:
    """Whether ``kernel`` has a disk cache (what the helper compiles reaches the run there)."""
    return getattr(getattr(kernel, "_cache", None), "_cache_file", None) is not None


def helper_on() -> bool:
    """Whether runs start compile helpers: two CPUs or more, a Python interpreter to start
    (not an application embedding one), lock files between processes (POSIX: elsewhere both
    would compile the same kernels), and not ``ATTITUDE_COMPILE_HELPER=0``."""
    from orbit import _shared_jit

    python = Path(sys.executable or "").name.lower().startswith("python")  # (not embedded)
    return (
        python
        and _shared_jit.fcntl is not None
        and os.environ.get(HELPER_ENV, "1") != "0"
        and _cpus() >= 2
    )


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - no affinity (macOS, Windows)
        return os.cpu_count() or 1


def _end_helpers() -> None:
    for proc in _HELPERS:
        try:
            proc.stdin.close()  # (the helper stops: what it saved so far is whole)
        except OSError:
            pass
        proc.wait()


def _kernel(item: tuple) -> Any:
    """The kernel of a helper's item (as Python calls it)."""
    import importlib

    module, name = item[:2]
    if isinstance(module, tuple):
        home, make, args = module
        return getattr(getattr(importlib.import_module(home), make)(*args), name)
    return getattr(importlib.import_module(module), name)


def _compile(items: Sequence[tuple[str, str, tuple, bool]]) -> None:
    """In the helper: compile each item (loaded instead where another process saved it)."""
    from orbit._shared_jit import _compile_lock

    for item in items:
        if item[3] == "call":  # a function that compiles what it calls
            _kernel(item)(*item[2])
            continue
        kernel, sig, from_python = _kernel(item), item[2], item[3]
        if from_python:
            with _compile_lock(kernel):
                kernel.compile(sig)
        else:
            kernel.dispatcher.compile(sig)  # (under its lock: orbit._shared_jit._KernelCopy)


def _main() -> None:
    """The helper: the items from standard input, compiled while its other end is open."""
    import threading

    stdin = sys.stdin.buffer
    items = pickle.loads(stdin.read(int.from_bytes(stdin.read(8), "little")))

    def watch() -> None:
        while os.read(0, 4096):  # (unbuffered: no lock held at the interpreter's exit)
            pass  # until the run's process closes the pipe or ends
        os._exit(0)  # (numba saves each cache file whole: nothing is left half-written)

    threading.Thread(target=watch, daemon=True).start()
    _compile(items)
