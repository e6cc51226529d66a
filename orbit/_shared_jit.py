"""The numba configuration shared by ``orbit`` and ``attitude``: the one place jitting is set up.

Every compiled kernel in ``orbit`` and ``attitude`` is decorated with :func:`jit`,
:func:`parallel_jit` or :func:`jit_generic` from this module. ``orbit`` is the bottom layer
(``attitude`` imports it, never the reverse; an import contract in pyproject.toml enforces
it), so the shared module lives here, and its name says that it is shared.

* Kernels are compiled lazily, on first call, and cached on disk (``cache=True``); nothing is
  compiled at import time.
* The on-disk cache is keyed on a fingerprint of *all* the Python sources of both packages,
  not only of the function's own file (numba's default): the cached integrators inline kernels
  from several modules, and a change to any of them must invalidate the cached machine code.
* ``ATTITUDE_CACHE_DIR=/path`` moves the package's cache out of the source tree.
* Kernels that take another compiled function as an *argument* (the generic integrator loops)
  are :func:`jit_generic`: inlined into their callers and never cached on their own. A cached
  function compiled for a function-typed argument records that function's type, and so its
  module, in the cache index; a user's kernel there would break every later process that
  cannot import the user's module. The cached callers are the entry points of
  :mod:`attitude._core.entry_points` (built-in models, in the package's cache) and their
  per-model copies for user kernels (:mod:`attitude._user_kernels`, in :func:`user_cache_dir`).
* Setting the environment variable ``ATTITUDE_DISABLE_JIT=1`` (or numba's own
  ``NUMBA_DISABLE_JIT=1``) before import turns every kernel into plain Python: slow, but with
  readable tracebacks (tests/test_propagate.py checks a propagation in that mode).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import numba

__all__ = [
    "JIT_DISABLED",
    "jit",
    "jit_generic",
    "parallel_jit",
    "slp_vectorized",
    "sources_fingerprint",
    "user_cache_dir",
]

JIT_DISABLED: bool = os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0") or bool(
    numba.config.DISABLE_JIT
)


_PACKAGE_DIRS = tuple(
    str(Path(__file__).resolve().parent.parent / name) + os.sep for name in ("orbit", "attitude")
)


_FINGERPRINT: list[bytes] = []


def sources_fingerprint() -> bytes:
    """SHA-256 over every .py file of the ``orbit`` and ``attitude`` packages (memoised)."""
    if not _FINGERPRINT:
        h = hashlib.sha256()
        for d in _PACKAGE_DIRS:
            for path in sorted(Path(d).rglob("*.py")):
                h.update(str(path.relative_to(d)).encode())
                h.update(path.read_bytes())
        _FINGERPRINT.append(h.digest())
    return _FINGERPRINT[0]


def user_cache_dir() -> Path:
    """Where compiled user kernels go: ``$ATTITUDE_CACHE_DIR/user``, else the platform's cache.

    The platform's user cache directory: ``$XDG_CACHE_HOME/attitude`` (default
    ``~/.cache/attitude``) on Linux and other Unix systems, ``~/Library/Caches/attitude`` on
    macOS, ``%LOCALAPPDATA%\\attitude\\Cache`` on Windows.
    """
    root = os.environ.get("ATTITUDE_CACHE_DIR")
    if root:
        return Path(root).expanduser().resolve() / "user"
    home = Path.home()
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or home / "AppData" / "Local")
        return base / "attitude" / "Cache"
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "attitude"
    return Path(os.environ.get("XDG_CACHE_HOME") or home / ".cache") / "attitude"


def _install_cache_locators() -> None:
    from numba.core import caching

    def cls(name):  # numba < 0.61 spells these with a leading underscore
        return getattr(caching, name, None) or getattr(caching, "_" + name)

    def stamp() -> bytes:
        return sources_fingerprint()

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


def jit_generic(func=None, /, **options):
    """:func:`jit` for kernels that take compiled functions as arguments: inlined, never cached.

    Such a kernel is compiled only as part of a cached entry point that passes it module-level
    kernels (see the module docstring), so nothing specialised for a user's function is ever
    written to the package's cache.
    """
    options.setdefault("inline", "always")
    options["cache"] = False
    return jit(func, **options)


def parallel_jit(func=None, /, **options):
    """Like :func:`jit` with ``parallel=True`` (for ``prange`` loops over independent members)."""
    options.setdefault("parallel", True)
    return jit(func, **options)


def slp_vectorized(dispatcher):
    """Compile a :func:`jit` kernel with LLVM's SLP vectoriser on (numba turns it off unless
    ``NUMBA_SLP_VECTORIZE=1``); a decorator placed above ``@jit``.

    For structure-of-arrays kernels written on tuples of lanes (``attitude._core.lanes``): the
    vectoriser turns each tuple operation into one SIMD instruction. It changes no result (it
    packs identical IEEE operations; it only reassociates under fastmath flags such kernels do
    not use). Only this kernel's own compilation is affected: callers that inline it keep its
    vector code, and other kernels compile as before (SLP can slow scalar code down).
    """
    if JIT_DISABLED:
        return dispatcher
    from numba.core import config

    compile_ = dispatcher.compile

    def compile(sig):
        old = config.SLP_VECTORIZE
        config.SLP_VECTORIZE = 1
        try:
            return compile_(sig)
        finally:
            config.SLP_VECTORIZE = old

    dispatcher.compile = compile
    return dispatcher
