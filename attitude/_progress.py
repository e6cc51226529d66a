"""The command's progress line on stderr (``attitude run``)."""

from __future__ import annotations

import math
import sys
import time
from typing import Any

__all__ = ["Progress"]


class Progress:
    """A one-line progress bar on stderr, shown only once a run has taken more than ``delay`` s.

    The time left is estimated from the reports after the first (the first chunk done), and
    again after a compilation (:meth:`restart`): compiling is not the run's pace. Notices
    (:meth:`note`: a run about to compile its kernels) are lines on stderr in every mode but
    ``never``.

    Parameters
    ----------
    mode : {"auto", "always", "never"}
        ``auto`` draws only when stderr is a terminal.
    """

    def __init__(self, mode: str = "auto", *, delay: float = 1.0, stream: Any = None, clock=None):
        self.stream = stream if stream is not None else sys.stderr
        tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.enabled = mode == "always" or (mode == "auto" and tty)
        self.notes = mode != "never"
        self.delay = delay
        self.clock = clock or time.monotonic
        self.start = self.clock()
        self.shown = False
        self.last = -math.inf
        self.base: tuple[float, int] | None = None  # (time, samples done) the pace counts from

    def restart(self) -> None:
        """Estimate the time left from the next report on."""
        self.base = None

    def note(self, text: str) -> None:
        """One line on stderr (above the bar when one is drawn)."""
        if not self.notes:
            return
        clear = "\r\033[K" if self.shown else ""
        self.stream.write(f"{clear}attitude: {text}\n")
        self.stream.flush()

    def __call__(self, done: int, total: int, t: float) -> None:
        if not self.enabled:
            return
        now = self.clock()
        if self.base is None:
            self.base = (now, done)
        elapsed = now - self.start
        if elapsed < self.delay or (now - self.last < 0.1 and done < total):
            return
        self.last = now
        frac = done / total if total else 1.0
        width = 30
        fill = round(width * frac)
        t0, done0 = self.base
        eta = (now - t0) * (total - done) / (done - done0) if done > done0 else math.inf
        eta_s = f"{eta:5.0f} s left" if math.isfinite(eta) else "      "
        self.stream.write(
            f"\r[{'#' * fill}{'.' * (width - fill)}] {100 * frac:5.1f}%  "
            f"{done}/{total} samples  {elapsed:6.1f} s  {eta_s}"
        )
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()


class ProgressBar:
    """``progress=True``: a tqdm bar over the output samples (tqdm imported only here).

    Its rate and time left count from the first report (the first chunk done), and again from
    the report after a compilation (:meth:`restart`): the time before, compiling or loading
    kernels, is not the run's pace.
    """

    def __init__(self, total: int):
        from tqdm import auto

        self.bar = auto.tqdm(total=total, desc="propagate", unit="sample", leave=True)
        self._fresh = True

    def __call__(self, done: int, total: int, t: float) -> None:
        b = self.bar
        if not self._fresh:
            b.update(done - b.n)
            return
        self._fresh = False
        b.reset()  # the clock and the rate's moving averages from now
        b.initial = b.n = b.last_print_n = done  # the rate counts the samples after this
        if b.dynamic_miniters:
            b.miniters = 0
        b.refresh()

    def restart(self) -> None:
        """The rate and time left from the next report on."""
        self._fresh = True

    def note(self, text: str) -> None:
        """A line above the bar (the compilation notices of attitude._compiling)."""
        self.bar.write(f"attitude: {text}", file=sys.stderr)

    def close(self) -> None:
        self.bar.close()
