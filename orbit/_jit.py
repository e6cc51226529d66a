"""The one place where numba compilation is configured, for both packages.

Every compiled kernel in ``orbit`` and ``attitude`` is decorated with :func:`jit` from this
module. ``orbit`` is the bottom layer (``attitude`` imports it, never the reverse), so the
module lives here.

* Kernels are compiled lazily, on first call, and cached on disk (``cache=True``); nothing is
  compiled at import time.
* The on-disk cache is keyed on a fingerprint of *all* the Python sources of both packages,
  not only of the function's own file (numba's default): the cached integrators inline kernels
  from several modules, and a change to any of them must invalidate the cached machine code.
* ``ATTITUDE_CACHE_DIR=/path`` moves the cache out of the source tree.
* Setting the environment variable ``ATTITUDE_DISABLE_JIT=1`` (or numba's own
  ``NUMBA_DISABLE_JIT=1``) before import turns every kernel into plain Python: slow, but with
  readable tracebacks (tests/test_propagate.py checks a propagation in that mode).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

__all__ = ["JIT_DISABLED", "jit", "parallel_jit"]

JIT_DISABLED: bool = os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0") or bool(
    numba.config.DISABLE_JIT
)


_PACKAGE_DIRS = tuple(
    str(Path(__file__).resolve().parent.parent / name) + os.sep for name in ("orbit", "attitude")
)


def _sources_fingerprint() -> bytes:
    """SHA-256 over every .py file of the ``orbit`` and ``attitude`` packages."""
    h = hashlib.sha256()
    for d in _PACKAGE_DIRS:
        for path in sorted(Path(d).rglob("*.py")):
            h.update(str(path.relative_to(d)).encode())
            h.update(path.read_bytes())
    return h.digest()


def _install_cache_locators() -> None:
    from numba.core import caching

    def cls(name):  # numba < 0.61 spells these with a leading underscore
        return getattr(caching, name, None) or getattr(caching, "_" + name)

    fingerprint: list[bytes] = []

    def stamp() -> bytes:
        if not fingerprint:
            fingerprint.append(_sources_fingerprint())
        return fingerprint[0]

    def ours(py_file: str) -> bool:
        return os.path.abspath(py_file).startswith(_PACKAGE_DIRS)

    class _InTree(cls("InTreeCacheLocator")):
        def get_source_stamp(self):
            return stamp()

        @classmethod
        def from_function(cls, py_func, py_file):
            return super().from_function(py_func, py_file) if ours(py_file) else None

    class _UserWide(cls("UserWideCacheLocator")):
        def get_source_stamp(self):
            return stamp()

        @classmethod
        def from_function(cls, py_func, py_file):
            return super().from_function(py_func, py_file) if ours(py_file) else None

    class _EnvDir(cls("UserProvidedCacheLocator")):
        # ATTITUDE_CACHE_DIR=/some/dir puts the cache there (benchmarks use it for cold starts).
        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            root = os.path.abspath(os.environ["ATTITUDE_CACHE_DIR"])
            self._cache_path = os.path.join(root, self.get_suitable_cache_subpath(py_file))

        def get_source_stamp(self):
            return stamp()

        @classmethod
        def from_function(cls, py_func, py_file):
            if not os.environ.get("ATTITUDE_CACHE_DIR") or not ours(py_file):
                return None
            return cls(py_func, py_file)

    classes = cls("CacheImpl")._locator_classes
    if not any(getattr(c, "__module__", "") == __name__ for c in classes):
        classes[0:0] = [_EnvDir, _InTree, _UserWide]


if not JIT_DISABLED:
    try:
        _install_cache_locators()
    except (ImportError, AttributeError) as exc:  # pragma: no cover - numba internals moved
        import warnings

        warnings.warn(
            f"attitude: could not install the source-fingerprint numba cache locator ({exc}); "
            "falling back to numba's per-file cache: clear __pycache__ after editing kernels",
            stacklevel=1,
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
