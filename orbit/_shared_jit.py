"""The numba configuration shared by ``orbit`` and ``attitude``: the one place jitting is set up.

Every compiled kernel in ``orbit`` and ``attitude`` is decorated with :func:`jit` or
:func:`jit_generic` from this module (no numba ``parallel``: ensembles run members on Python
threads, the GIL released). ``orbit`` is the bottom layer
(``attitude`` imports it, never the reverse; an import contract in pyproject.toml enforces
it), so the shared module lives here, and its name says that it is shared.

* Kernels are compiled lazily, on first call, and cached on disk (``cache=True``); nothing is
  compiled at import time.
* The on-disk cache is keyed per module on the sources of the module and of every package
  module it imports (:func:`source_stamp`), not only on the function's own file (numba's
  default): the cached integrators inline kernels and read constants from the modules they
  import, and a change to any of them must invalidate the cached machine code; an edit of a
  module no kernel imports (the CLI) recompiles nothing.
* While one of the package's kernels compiles, three faster stand-ins for numba's passes are
  in place (:mod:`orbit._numba_standins`: the same IR); numba's own are put back when it ends, so
  anyone else's numba code compiles as it would without the package.
* ``ATTITUDE_CACHE_DIR=/path`` moves the package's cache out of the source tree.
* A kernel is loaded or compiled under a lock file beside its cache index, whether called from
  Python or compiled as another kernel's callee: processes that start together on an empty
  cache (or a run and its compile helper, :mod:`attitude._compiling`) compile it once, the
  others wait and load it.
* Kernels that take another compiled function as an *argument* (the generic integrator loops)
  are :func:`jit_generic`: inlined into their callers and never cached on their own. A cached
  function compiled for a function-typed argument records that function's type, and so its
  module, in the cache index; a user's kernel there would break every later process that
  cannot import the user's module. The cached callers are the entry points of
  :mod:`attitude._core.entry_points` (built-in models, in the package's cache) and their
  per-model copies for user kernels (:mod:`attitude._user_kernels`, in :func:`user_cache_dir`).
* :func:`specialise` makes an in-memory copy of a module whose compiled functions see other
  objects under some of their global names (e.g. the entry points of one built-in model with
  ``torque`` bound to that model's kernel alone): each copy compiles only the code it reaches,
  and is cached under its own name (the function's name plus a tag).
* :func:`interpreted` gives a module's kernels as plain Python (for a few scalar evaluations
  from Python, e.g. when an orbit is built, where compiling would cost more than it saves).
* Setting the environment variable ``ATTITUDE_DISABLE_JIT=1`` (or numba's own
  ``NUMBA_DISABLE_JIT=1``) before import turns every kernel into plain Python: slow, but with
  readable tracebacks (tests/test_propagate.py checks a propagation in that mode).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import re
import sys
import time
import types
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no lock between processes
    fcntl = None

import numba
from numba.core import sigutils
from numba.core import types as nbtypes
from numba.core.registry import CPUDispatcher

from . import _numba_standins

__all__ = [
    "JIT_DISABLED",
    "Kernel",
    "from_source",
    "interpreted",
    "jit",
    "jit_generic",
    "rebind",
    "slp_vectorized",
    "sources_fingerprint",
    "specialise",
    "user_cache_dir",
    "will_compile",
]

JIT_DISABLED: bool = os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0") or bool(
    numba.config.DISABLE_JIT
)


_ROOT = Path(__file__).resolve().parent.parent
_PACKAGE_DIRS = tuple(str(_ROOT / name) + os.sep for name in ("orbit", "attitude"))


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


@functools.cache
def _module_file(name: str) -> Path | None:
    """The source file of the package module ``name`` (``attitude._core.quat``), or None."""
    if name.split(".", 1)[0] not in ("orbit", "attitude"):
        return None
    base = _ROOT.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


@functools.cache
def _source(name: str) -> bytes:
    """The source of the package module ``name`` (read once per process, as the keys are)."""
    return _module_file(name).read_bytes()


# Import statements at any indentation: ``from <dots><module> import <names>`` (the names in
# parentheses over several lines, comments inside) and ``import <modules>``. A regular
# expression rather than Python's parser: `import attitude` reads every kernel module's imports
# (the kernel cache's keys) and parsing them took 0.7 s of it; tests/test_shared_jit.py checks
# that both find the same modules in every module of the packages.
_FROM = re.compile(
    rb"^[ \t]*from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\((?:[^)#]|#[^\n]*)*\)|[^\n;]*)", re.M
)
_IMPORT = re.compile(rb"^[ \t]*import[ \t]+([^\n;]*)", re.M)
_COMMENT = re.compile(rb"#[^\n]*")


@functools.cache
def _imports(name: str) -> frozenset[str]:
    """The package modules that module ``name``'s source imports by name (``import`` and
    ``from ... import`` statements, relative ones resolved; a name that is a submodule counts
    as that submodule, not its package)."""
    path = _module_file(name)
    if path is None:
        return frozenset()
    base = name if path.name == "__init__.py" else name.rpartition(".")[0]
    src = _source(name)
    out = set()
    for m in _IMPORT.finditer(src):
        for item in _COMMENT.sub(b"", m.group(1)).split(b","):
            words = item.split()
            if words:
                out.add(words[0].decode())
    for m in _FROM.finditer(src):
        level = len(m.group(1))
        parts = base.split(".")[: len(base.split(".")) - level + 1] if level else []
        mod = ".".join(parts + ([m.group(2).decode()] if m.group(2) else []))
        for item in _COMMENT.sub(b"", m.group(3)).strip(b"() \t\n").split(b","):
            words = item.split()
            if words:
                sub = f"{mod}.{words[0].decode()}"
                out.add(sub if _module_file(sub) is not None else mod)
    return frozenset(m for m in out if _module_file(m) is not None)


@functools.cache
def source_stamp(*roots: str) -> bytes:
    """SHA-256 over the sources of the package modules ``roots`` and every package module they
    import, directly or not: what a kernel of those modules can read when it compiles.

    The kernel cache is keyed on it, per module: editing a module recompiles the kernels of
    the modules that import it (their compiled code may inline its kernels or read its
    constants), and nothing else (editing the CLI recompiles nothing).
    """
    seen: set[str] = set()
    stack = [r.partition("[")[0] for r in roots]  # (a specialise() copy: "module[tag]")
    while stack:
        m = stack.pop()
        if m not in seen and _module_file(m) is not None:
            seen.add(m)
            stack.extend(_imports(m))
    h = hashlib.sha256()
    for m in sorted(seen):
        h.update(m.encode())
        h.update(_source(m))
    return h.digest()


def _stamp_of(py_func, py_file: str) -> bytes:
    rel = Path(os.path.abspath(py_file)).relative_to(_ROOT).with_suffix("")
    name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
    return source_stamp(name, *getattr(py_func, "_attitude_stamp_roots", ()))


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


def data_cache_dir() -> Path:
    """Where parsed data files go (the IERS table): ``$ATTITUDE_CACHE_DIR/data``, else ``data``
    in the platform's cache (:func:`user_cache_dir`)."""
    root = os.environ.get("ATTITUDE_CACHE_DIR")
    if root:
        return Path(root).expanduser().resolve() / "data"
    return user_cache_dir() / "data"


def _install_cache_locators() -> None:
    from numba.core import caching

    def cls(name):  # numba < 0.61 spells these with a leading underscore
        return getattr(caching, name, None) or getattr(caching, "_" + name)

    def ours(py_file: str) -> bool:
        return os.path.abspath(py_file).startswith(_PACKAGE_DIRS)

    def stamped(locator, py_func, py_file):
        if locator is not None:
            locator._attitude_stamp = _stamp_of(py_func, py_file)
        return locator

    class _Stamped:
        def get_source_stamp(self):
            return self._attitude_stamp

    class _InTree(_Stamped, cls("InTreeCacheLocator")):
        @classmethod
        def from_function(cls, py_func, py_file):
            if not ours(py_file):
                return None
            return stamped(super().from_function(py_func, py_file), py_func, py_file)

    class _UserWide(_Stamped, cls("UserWideCacheLocator")):
        @classmethod
        def from_function(cls, py_func, py_file):
            if not ours(py_file):
                return None
            return stamped(super().from_function(py_func, py_file), py_func, py_file)

    class _EnvDir(_Stamped, cls("UserProvidedCacheLocator")):
        # ATTITUDE_CACHE_DIR=/some/dir puts the cache there (benchmarks use it for cold starts).
        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            root = os.path.abspath(os.environ["ATTITUDE_CACHE_DIR"])
            self._cache_path = os.path.join(root, self.get_suitable_cache_subpath(py_file))

        @classmethod
        def from_function(cls, py_func, py_file):
            if not os.environ.get("ATTITUDE_CACHE_DIR") or not ours(py_file):
                return None
            return stamped(cls(py_func, py_file), py_func, py_file)

    class _Redirect:
        # A copy of a package kernel bound to a user module's functions (rebind): cached as if
        # it were defined in the user module's file, never in the package's cache.
        @classmethod
        def from_function(cls, py_func, py_file):
            source = getattr(py_func, "_attitude_cache_source", None)
            if source is None:
                return None
            for c in classes:
                if getattr(c, "__module__", "") != __name__:
                    locator = c.from_function(py_func, source)
                    if locator is not None:
                        return locator
            return None

    classes = cls("CacheImpl")._locator_classes
    if not any(getattr(c, "__module__", "") == __name__ for c in classes):
        classes[0:0] = [_Redirect, _EnvDir, _InTree, _UserWide]


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


if not JIT_DISABLED and _numba_standins.NUMBA_STANDINS:
    try:
        _numba_standins.install(_PACKAGE_DIRS)
    except (ImportError, AttributeError):  # pragma: no cover - numba internals moved
        pass


def jit(func=None, /, **options):
    """Compile ``func`` with numba in nopython mode, cached, or return it unchanged.

    Usable bare (``@jit``) or with extra numba options (``@jit(inline="always")``).
    """
    # No C-callable (cfunc) wrapper: nothing takes a kernel's address; compiling one per
    # function cost a few percent of a fresh install's first run.
    opts = {
        "cache": True,
        "nopython": True,
        "fastmath": False,
        "error_model": "numpy",
        "no_cfunc_wrapper": True,
    }
    opts.update(options)

    def wrap(f):
        if JIT_DISABLED:
            return f
        disp = numba.jit(**opts)(f)
        if opts.get("inline", "never") == "never":  # (an inlined one never compiles on its own)
            disp.__class__ = Kernel
        disp._attitude_jit_options = opts  # what specialise() compiles a copy with
        return disp

    return wrap if func is None else wrap(func)


class Kernel(CPUDispatcher):
    """numba's dispatcher, for calls from Python; compiled code calls :attr:`dispatcher`, the same
    function compiled without the CPython wrapper.

    numba compiles a CPython wrapper (boxing and unboxing every argument) with every function,
    although most kernels are only ever called from other kernels; leaving it out of those saves
    a tenth of a fresh install's first run. This object is numba's ordinary dispatcher for calls
    from Python (numba's fast call path, its ``stats``, ``signatures``, ...), but numba types it
    as :attr:`dispatcher` in compiled code (``_numba_type_``): a copy compiled without the
    wrapper, created on first use and cached under the name ``<name>__kernel`` (numba's cache
    index does not tell the two compilations apart).
    """

    @property
    def dispatcher(self):
        """The dispatcher compiled code calls (no CPython wrapper)."""
        d = self.__dict__.get("_kernel_dispatcher")
        if d is None:
            f = self.py_func
            g = _copy(f, f.__globals__, "kernel")  # its own cache files
            opts = getattr(self, "_attitude_jit_options", {"nopython": True})
            d = numba.jit(**{**opts, "no_cpython_wrapper": True})(g)
            d.__class__ = _KernelCopy
            self._kernel_dispatcher = d
        return d

    @property
    def _numba_type_(self):
        return nbtypes.Dispatcher(self.dispatcher)

    def _compile_for_args(self, *args, **kws):
        # A call from Python that finds no compiled overload: numba loads it from the disk cache
        # or compiles it. Processes that start together on an empty cache (a pool's workers,
        # test workers, two runs at once) would each compile the same driver; the lock makes
        # the others wait for the first and load what it saved.
        with _compile_lock(self):
            return super()._compile_for_args(*args, **kws)


class _KernelCopy(CPUDispatcher):
    """:attr:`Kernel.dispatcher`: numba's dispatcher, whose compilation (as the callee of
    another kernel) waits for a process compiling the same kernel and loads what it saved,
    instead of compiling it a second time (the lock of :func:`_compile_lock`)."""

    def compile(self, sig):
        args, _ = sigutils.normalize_signature(sig)
        if tuple(args) in self.overloads:  # (every call site's typing asks again)
            return super().compile(sig)
        with _compile_lock(self):
            return super().compile(sig)


#: Seconds a process waits for another one compiling the same kernel before it compiles too.
COMPILE_LOCK_TIMEOUT = 900.0


@contextlib.contextmanager
def _compile_lock(dispatcher):
    """An exclusive lock on ``<cache index>.lock`` beside ``dispatcher``'s cache index, held
    while it is loaded or compiled (POSIX ``flock``; elsewhere, or without a disk cache, none).
    A process holds the locks of the kernels it is compiling, a chain of callers and callees:
    the call graph has no cycle, so two processes cannot wait for each other."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    fd = path = None
    if fcntl is not None and cache_file is not None:
        try:
            path = cache_file._index_path + ".lock"
            if path not in _HELD:  # (numba calls back in for literal arguments)
                os.makedirs(cache_file._cache_path, exist_ok=True)
                fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except (OSError, AttributeError):  # a read-only cache: numba does without one too
            fd = None
    if fd is not None:
        deadline = time.monotonic() + COMPILE_LOCK_TIMEOUT
        pause = 0.002  # (most waits are for a small kernel: a few ms)
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:  # a stuck process: compile regardless
                    os.close(fd)
                    fd = None
                    break
                time.sleep(pause)
                pause = min(0.1, 2.0 * pause)
            except OSError:  # a file system without locks
                os.close(fd)
                fd = None
                break
    if fd is not None:
        _HELD.add(path)
    try:
        yield
    finally:
        if fd is not None:
            _HELD.discard(path)
            os.close(fd)  # (releases the lock)


_HELD: set[str] = set()  # the locks this process holds (another thread of it does not wait)


def will_compile(dispatcher) -> bool:
    """Whether a call of ``dispatcher`` from Python would compile it (not load it).

    False when it was compiled (or loaded) in this process, or when its on-disk cache index
    holds an entry for this machine under its module's current source stamp (numba's index
    reader returns nothing for a stale stamp); True otherwise, and for a dispatcher
    without a disk cache that has not been compiled yet. It does not look at the argument
    types: the package's entry points are compiled for one signature each.
    """
    if JIT_DISABLED or not isinstance(dispatcher, CPUDispatcher):
        return False
    if dispatcher.signatures:
        return False
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    if cache_file is None:  # numba's NullCache: compiled in every process
        return True
    try:
        index = cache_file._load_index()
        magic = dispatcher.targetctx.codegen().magic_tuple()
    except Exception:  # pragma: no cover - an unreadable index, or numba's internals moved
        return True
    return not any(isinstance(key, tuple) and key[1:2] == (magic,) for key in index)


def from_source(
    source: str, namespace: dict, module: str, file: str, suffix: str = "", **options
) -> dict:
    """The functions that ``source`` defines, executed in ``namespace``, compiled with :func:`jit`
    and ``options``: kernels written once as a pattern and generated for several cases (lane
    widths, the registered laws, element-wise loops).

    They belong to ``module`` and their source location is ``file`` (numba keys their cache on
    it, :func:`source_stamp`); ``suffix`` is appended to their qualified names (their own cache
    files, where one file generates the same names for several cases).
    """
    before = set(namespace)
    exec(compile(source, file, "exec"), namespace)
    out = {}
    for name, f in list(namespace.items()):
        if name in before or not isinstance(f, types.FunctionType):
            continue
        f.__module__ = module
        f.__qualname__ = f"{name}{suffix}"
        out[name] = jit(f, **options)
    return out


def jit_generic(func=None, /, **options):
    """:func:`jit` for kernels that take compiled functions as arguments: inlined, never cached.

    Such a kernel is compiled only as part of a cached entry point that passes it module-level
    kernels (see the module docstring), so nothing specialised for a user's function is ever
    written to the package's cache.
    """
    options.setdefault("inline", "always")
    options["cache"] = False
    return jit(func, **options)


def slp_vectorized(dispatcher):
    """Compile a :func:`jit` kernel with LLVM's SLP vectoriser on (numba turns it off unless
    ``NUMBA_SLP_VECTORIZE=1``); a decorator placed above ``@jit``.

    For structure-of-arrays kernels written on tuples of lanes (``attitude._core.lanes``): the
    vectoriser turns each tuple operation into one SIMD instruction. It changes no result (it
    packs identical IEEE operations; it only reassociates under fastmath flags such kernels do
    not use). Only this kernel's own compilation is affected: callers that inline it keep its
    vector code, and other kernels compile as before (SLP can slow scalar code down). For a
    :class:`Kernel`, the copy that compiled code calls (:attr:`Kernel.dispatcher`) is compiled
    the same way (without it the batch integrator lost its SIMD code: 1.8x slower).
    """
    if JIT_DISABLED:
        return dispatcher
    from numba.core import config

    def vectorising(d):
        compile_ = d.compile

        def compile(sig):
            old = config.SLP_VECTORIZE
            config.SLP_VECTORIZE = 1
            try:
                return compile_(sig)
            finally:
                config.SLP_VECTORIZE = old

        d.compile = compile

    vectorising(dispatcher)
    if isinstance(dispatcher, Kernel):
        vectorising(dispatcher.dispatcher)
    dispatcher._attitude_slp = True  # specialise() vectorises its copies too
    return dispatcher


def specialise(module, tag: str, names=None, **bindings):
    """An in-memory copy of ``module`` whose functions see ``bindings`` among their globals.

    Every function defined in ``module`` with :func:`jit` (only those in ``names`` if given) is
    copied with the same options; the copies share one namespace, the module's globals updated
    with ``bindings`` and with the copies themselves, so calls between them stay within the
    copy. numba resolves a global when it compiles, so a copy compiles the code its bindings
    reach and nothing else (e.g. ``torque`` bound to one model's kernel instead of the switch
    over every kind).

    Each copy is cached on disk like the original, under the original's name with
    ``__<tag>`` appended: ``tag`` must name the bindings uniquely (the same tag with other
    bindings would load the other copy's machine code). Bind module-level objects of the
    package only, never a user's function (user models get their own modules in
    :func:`user_cache_dir`).

    Returns a module object (``types.ModuleType``) whose attributes are the copy's namespace.
    """
    name = f"{module.__name__}[{tag}]"
    roots = (sys._getframe(1).f_globals.get("__name__", ""),)  # who chose the bindings
    copy = types.ModuleType(name, module.__doc__)
    ns = copy.__dict__
    ns.update({k: v for k, v in vars(module).items() if k not in ("__name__", "__doc__")})
    ns.update(bindings)
    ns["__kernel_tag__"] = tag
    rebound = []
    for key, obj in vars(module).items():
        if key in bindings or (names is not None and key not in names):
            continue
        if hasattr(obj, "_attitude_rebind"):  # a rebind() of the module: redone in the copy
            if all(n in ns for n in obj._attitude_rebind[2].values()):
                rebound.append((key, obj._attitude_rebind))
            continue  # (else another module's, imported: shared as it is)
        f = getattr(obj, "py_func", obj) if not JIT_DISABLED else obj
        if not isinstance(f, types.FunctionType) or f.__module__ != module.__name__:
            continue
        if not JIT_DISABLED and not hasattr(obj, "_attitude_jit_options"):
            continue  # a plain Python helper of the module: shared as it is
        g = _copy(f, ns, tag, roots)  # numba names the cache files after its qualname
        ns[key] = g if JIT_DISABLED else jit(g, **obj._attitude_jit_options)
        if getattr(obj, "_attitude_slp", False):
            ns[key] = slp_vectorized(ns[key])
    for key, (template, rtag, rnames, cache, options) in rebound:
        ns[key] = rebind(template, ns, rtag, cache=cache, options=options, _roots=roots, **rnames)
    return copy


def _copy(f, namespace: dict, tag: str, roots: tuple = ()) -> types.FunctionType:
    """``f`` with the globals ``namespace``, named ``<qualname>__<tag>`` (numba names its cache
    files after it); its cache is also keyed on the sources of the modules ``roots`` (where the
    bindings come from) and of what they import."""
    g = types.FunctionType(f.__code__, namespace, f.__name__, f.__defaults__, f.__closure__)
    g.__kwdefaults__ = f.__kwdefaults__
    g.__doc__ = f.__doc__
    g.__module__ = f.__module__
    g.__qualname__ = f"{f.__qualname__}__{tag}"
    g._attitude_stamp_roots = (*getattr(f, "_attitude_stamp_roots", ()), *roots)
    return g


def rebind(
    template,
    namespace: dict,
    tag: str,
    *,
    cache: bool | None = None,
    options: dict | None = None,
    _roots: tuple = (),
    **names: str,
):
    """A copy of the kernel ``template`` (of another module) with some of its globals bound to
    the objects a module has under the given names.

    ``dop853_canonical = rebind(dop853_run, globals(), "canonical", RHS="canonical_rhs")`` in a
    module of entry points: the DOP853 driver of :mod:`orbit._rk` compiled with that
    module's ``canonical_rhs`` as its right-hand side ``RHS``. The right-hand side is a global of
    the copy, not an argument: a compiled function that takes a compiled function as an argument
    cannot be cached on its own, so it must be inlined into a cached caller, and numba's
    inliner deep-copies the whole inlined loop (a second per cold start for the DOP853 driver).

    The copy is cached under the template's name with ``__<tag>`` appended (and the tag of a
    :func:`specialise` copy of the module, which redoes the rebind with its own objects); for a
    module outside the package (a user model, :mod:`attitude._user_kernels`) also that module's
    name, and the cache goes with that module's file, never into the package's cache.
    ``cache=False`` compiles it for this process only; ``options`` are jit options of the
    copy that replace the template's (e.g. ``{"_nrt": False}``: no reference counting).
    """
    f = getattr(template, "py_func", template)
    tags = [tag, namespace.get("__kernel_tag__")]
    file = str(namespace.get("__file__") or "")
    outside = not os.path.abspath(file).startswith(_PACKAGE_DIRS)
    if outside:  # a user module: its own name and cache
        tags.append(str(namespace["__name__"]))
        if not os.path.isfile(file):
            cache = False
    glob = dict(f.__globals__)
    glob.update({g: namespace[n] for g, n in names.items()})
    g = _copy(f, glob, "__".join(filter(None, tags)), (*_roots, str(namespace["__name__"])))
    if outside and cache is not False:
        g._attitude_cache_source = os.path.abspath(file)
    if JIT_DISABLED:
        k = g
    else:
        opts = dict(template._attitude_jit_options)
        opts.update(options or {})
        if cache is not None:
            opts["cache"] = cache
        k = jit(g, **opts)
    k._attitude_rebind = (template, tag, names, cache, options)
    return k


def inline_copy(template, namespace: dict, **names: str):
    """A :func:`rebind` copy of ``template`` (tag ``inline``) that numba's IR inliner inlines
    into its callers (``inline="always"``), with some of its globals bound to other inline
    copies by name: the tick and the Taylor step inlined whole into the single-run drivers."""
    return rebind(template, namespace, "inline", options={"inline": "always"}, **names)


_INTERPRETED: dict[str, types.ModuleType] = {}


def interpreted(module) -> types.ModuleType:
    """``module``'s kernels as plain Python functions calling each other: nothing compiles.

    For a few scalar evaluations from Python (an orbit's mean anomaly at epoch when it is built,
    a reference frame at the initial time): the same code and IEEE arithmetic as the compiled
    kernels (numba does not contract or reassociate without ``fastmath``), so the same results,
    without compiling a kernel and everything it calls before a run can start. Kernels and
    modules of the package that ``module`` uses are followed into their interpreted copies.
    Python raises where compiled code returns inf or NaN (a division by zero, a math domain
    error): call it with validated input, and fall back to the compiled kernel if it raises.
    """
    name = module.__name__
    if name in _INTERPRETED:
        return _INTERPRETED[name]
    copy = types.ModuleType(f"{name}[interpreted]", module.__doc__)
    _INTERPRETED[name] = copy  # before following imports (modules may import each other)
    ns = copy.__dict__
    ns.update({k: v for k, v in vars(module).items() if k not in ("__name__", "__doc__")})
    for key, obj in vars(module).items():
        if isinstance(obj, types.ModuleType):
            if obj.__name__ in sys.modules and _in_package(obj):
                ns[key] = interpreted(obj)
            continue
        f = getattr(obj, "py_func", obj)
        if not isinstance(f, types.FunctionType):
            continue
        if f.__module__ == name:
            g = types.FunctionType(f.__code__, ns, f.__name__, f.__defaults__, f.__closure__)
            g.__kwdefaults__ = f.__kwdefaults__
            ns[key] = g
        elif f is not obj:  # a kernel imported from another module of the package
            home = sys.modules.get(f.__module__)
            if home is not None and _in_package(home) and getattr(home, f.__name__, None) is obj:
                ns[key] = getattr(interpreted(home), f.__name__)
    return copy


def _in_package(module) -> bool:
    return os.path.abspath(getattr(module, "__file__", None) or "").startswith(_PACKAGE_DIRS)
