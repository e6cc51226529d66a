"""The one place where numba compilation is configured, for both packages.

Every compiled kernel in ``orbit`` and ``attitude`` is decorated with :func:`jit` from this
module. ``orbit`` is the bottom layer (``attitude`` imports it, never the reverse), so the
module lives here.

* Kernels are compiled lazily, on first call, and cached on disk (``cache=True``); nothing is
  compiled at import time.
* Setting the environment variable ``ATTITUDE_DISABLE_JIT=1`` (or numba's own
  ``NUMBA_DISABLE_JIT=1``) before import turns every kernel into plain Python: slow, but with
  readable tracebacks, and the test-suite runs in that mode too.
"""

from __future__ import annotations

import os

import numba

__all__ = ["JIT_DISABLED", "jit", "parallel_jit"]

JIT_DISABLED: bool = os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0") or bool(
    numba.config.DISABLE_JIT
)


def jit(func=None, /, **options):
    """Compile ``func`` with numba in nopython mode, cached, or return it unchanged.

    Usable bare (``@jit``) or with extra numba options (``@jit(inline="always")``).
    """
    opts = {"cache": True, "nopython": True, "fastmath": False, "error_model": "numpy"}
    opts.update(options)

    def wrap(f):
        if JIT_DISABLED:
            return f
        return numba.jit(**opts)(f)

    return wrap if func is None else wrap(func)


def parallel_jit(func=None, /, **options):
    """Like :func:`jit` with ``parallel=True`` (for ``prange`` loops over independent members)."""
    options.setdefault("parallel", True)
    return jit(func, **options)
