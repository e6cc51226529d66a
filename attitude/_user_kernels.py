"""User models compiled into a cache of their own.

A user model (:class:`~attitude.potentials.CustomPotential`,
:class:`~attitude.potentials.CustomTorque`) runs through the same compiled entry points as the
built-in models: this module writes a copy of :mod:`attitude._core.entry_points` whose
``model`` block binds ``torque`` and ``potential`` to the user's functions, imports it, and
hands it out. The copy lives in the user cache directory (:func:`orbit._shared_jit.user_cache_dir`:
``$ATTITUDE_CACHE_DIR/user``, else e.g. ``~/.cache/attitude``) and numba caches its entry
points next to it, so

* the package's own cache only ever holds the package's kernels (nothing a user writes is
  compiled into it, and no user's session can break another's);
* a model defined in a file compiles once per change of that file, not once per process: the
  module is named after a hash of the user's source (the whole file of every user function,
  plus the values of the numbers and arrays it reads from globals or closures, which numba
  freezes into the machine code) and of the package's sources;
* a function with no source file (typed at a prompt) gets a module compiled for this process
  only, with one warning saying so.

The user's functions are injected as module globals (``USER_TORQUE``, ``USER_POTENTIAL``,
``USER_EVENT``: event functions g(t, q, omega) of ``attitude.events.Custom``) before anything
compiles; a cached entry point loaded from disk does not need them again.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import types
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from orbit._shared_jit import JIT_DISABLED, sources_fingerprint, user_cache_dir

from ._core import entry_points as _builtin_entry_points

__all__ = [
    "USER_ONLY",
    "builtin_part",
    "check_step",
    "compile_failure",
    "entry_points",
    "model_key",
]


def compile_failure(exc: BaseException) -> str:
    """Why calling (and so compiling) a user's function failed, with the offending line.

    numba's typing errors start with "Failed in nopython mode pipeline (step: ...)"; the
    reason, the construct and the user's file and line come after it. The result is one line
    (the reason, the construct, ``at FILE line N: <source>``), then numba's whole message.
    """
    import re

    text = str(exc)
    lines = text.splitlines()
    if not lines:
        return type(exc).__name__
    if not lines[0].startswith("Failed in "):
        return f"{type(exc).__name__}: {lines[0]}"
    body = [ln.strip() for ln in lines[1:]]
    reason = next((ln for ln in body if ln), "")
    if reason.endswith("found for signature:"):
        sig = next((ln[3:].strip() for ln in body if ln.startswith(">>>")), "")
        reason = reason.replace(" found for signature:", "") + (f" for {sig}" if sig else "")
        reason = re.sub(r"Function\(<built-in function (\w+)>\)", r"\1", reason)
    where = ""
    m = re.search(r"During: .* at (.+) \((\d+)\)", text)
    path, line = (m.group(1), m.group(2)) if m else (None, None)
    block = re.search(r'File "([^"]+)", line (\d+):\n((?:.*\n)*?)\s*\^', text)
    if block:
        path = path or block.group(1)
        line = line or block.group(2)
        src = [x for x in block.group(3).splitlines() if x.strip()]
        if src:
            where = f" at {path} line {line}: {src[-1].strip()}"
    elif path:
        where = f" at {path} line {line}"
    return f"numba could not compile it: {reason}{where}\n\nnumba's message:\n{text}"


#: Lines of numba's message kept in the error of a step function that does not compile.
STEP_MESSAGE_LINES = 20


def check_step(step: Any) -> None:
    """Compile your flight-software ``step(t, m)`` for the arguments the loop gives it (t a
    float64, m the 1-D float64 array of measurements) and check that it returns a 1-D array of
    real numbers: else an :class:`~attitude.errors.AttitudeTypeError` naming the function,
    with numba's message (its first lines), before any work (it was numba's ``TypingError``
    out of the run's first compiled call). The loop then calls this compiled version."""
    if JIT_DISABLED:
        return
    from numba import types
    from numba.core.registry import cpu_target

    from .errors import AttitudeTypeError

    name = getattr(step, "__name__", type(step).__name__)
    where = (
        f"control: your compiled step function {name}(t, m) (t a float, m the 1-D float64 "
        "array of measurements, docs/flight_software.md)"
    )
    sig = (types.float64, types.Array(types.float64, 1, "C"))
    try:  # as the loop's typing does: compiles it, or picks a signature given to njit
        found = cpu_target.typing_context.resolve_function_type(types.Dispatcher(step), sig, {})
    except Exception as exc:
        lines = compile_failure(exc).splitlines()
        text = "\n".join(lines[:STEP_MESSAGE_LINES])
        more = len(lines) - STEP_MESSAGE_LINES
        text += f"\n... ({more} more lines)" if more > 0 else ""
        raise AttitudeTypeError(f"{where} cannot be compiled: {text}") from None
    if found is None:
        raise AttitudeTypeError(
            f"{where}: none of its signatures {step.nopython_signatures} accepts "
            f"(float64, {sig[1]}); give njit no signature, or one that does"
        )
    ret = found.return_type
    if not (
        isinstance(ret, types.Array)
        and ret.ndim == 1
        and isinstance(ret.dtype, (types.Float, types.Integer))
    ):
        raise AttitudeTypeError(
            f"{where} returns {ret}; it must return a 1-D array of real numbers (the commands, "
            "e.g. np.array([...]) or -(k * sigma))"
        )


_BEGIN = "# --- model: begin (replaced in user modules) ---"
_END = "# --- model: end ---"

#: How each kind of user term builds its torque from the injected functions (``{k}``: the
#: term's number): CustomTorque gives tau(q, t) or tau(q, omega, t), with or without U(q, t),
#: and with an orbit tau(q, t, env) or tau(q, omega, t, env) (``{env}``: the number of the term
#: among those reading the environment, whose blocks attitude._core.potentials.user_env_base
#: finds); CustomPotential gives U(q, t) and its torque by complex-step differentiation.
TORQUE_EXPR = {
    "torque": "user_torque(USER_TORQUE_{k}, q, w, t)",
    "torque_rates": "user_torque_rates(USER_TORQUE_{k}, q, w, t)",
    "torque_env": "user_torque_env(USER_TORQUE_{k}, q, w, t, params, {env})",
    "torque_rates_env": "user_torque_rates_env(USER_TORQUE_{k}, q, w, t, params, {env})",
    "potential": "complex_step_torque(USER_POTENTIAL_{k}, q, w, t)",
}

#: The kinds of user terms that read the environment (a block of their own in ``params``).
ENV_KINDS = ("torque_env", "torque_rates_env")


def _torque_exprs(terms: tuple) -> list[str]:
    """The torque expression of each term, environment blocks numbered in order."""
    out, e = [], 0
    for k, (kind, _, _) in enumerate(terms):
        out.append(TORQUE_EXPR[kind].format(k=k, env=e))
        e += kind in ENV_KINDS
    return out


#: A user term: (kind, torque function or None, potential function or None).
UserTerm = tuple[str, Any, Any]


def _event_block(events: tuple) -> list[str]:
    """The ``event`` global: the user's g(t, q, omega) functions, then the built-in events."""
    if not events:
        return ["", "event = builtin_event"]
    lines = [
        "",
        "",
        "from attitude._core.events import KIND_USER, event_base, user_event  # noqa: E402",
        "",
    ]
    lines += [f"USER_EVENT_{k} = None" for k in range(len(events))]
    lines += [
        "",
        "",
        "@jit",
        "def event(j, t, q, w, evd):",
        "    b = event_base(j, evd)",
        "    if int(evd[b]) == KIND_USER:",
        "        k = int(evd[b + 3])",
    ]
    for k in range(len(events)):
        lines += [
            f"        if k == {k}:",
            f"            return user_event(USER_EVENT_{k}, t, q, w)",
        ]
    lines += [
        "        return builtin_event(j, t, q, w, evd)",
        "    return builtin_event(j, t, q, w, evd)",
    ]
    return lines


def _step_block() -> list[str]:
    """The flight software's command source with the user's compiled ``step(t, m)``."""
    return [
        "",
        "",
        "from attitude._core.fsw_step import step_boundary_with  # noqa: E402",
        "",
        "USER_STEP = None",
        "",
        "",
        "@jit",
        "def fsw_boundary(P, y, t, t_end, ctl):",
        "    return step_boundary_with(USER_STEP, P, y, t, t_end, ctl)",
        "",
        "",
        "fsw_boundary_inline = fsw_boundary  # (the single-run drivers bind this name)",
    ]


def _model_block(terms: tuple[UserTerm, ...], events: tuple = (), step: bool = False) -> str:
    """The ``model`` block of a user module: the built-in part (``params``) plus the terms, the
    user's event functions and the user's compiled flight-software step."""
    n = len(terms)
    exprs = _torque_exprs(terms)
    lines = [
        "REFCOUNT = True  # a user's kernels may allocate (numba's reference counting on)",
        "from attitude._core.potentials import ZERO3, complex_step_torque  # noqa: F401",
        "from attitude._core.potentials import user_torque, user_torque_rates  # noqa: F401",
    ]
    if any(kind in ENV_KINDS for kind, _, _ in terms):
        lines += [
            "from attitude._core.potentials import user_torque_env  # noqa: F401",
            "from attitude._core.potentials import user_torque_rates_env  # noqa: F401",
        ]
    lines += ["", "# the user's functions, injected before anything compiles"]
    for k in range(n):
        lines += [f"USER_TORQUE_{k} = None", f"USER_POTENTIAL_{k} = None"]
    parts = [f"    b{k} = {exprs[k]}" for k in range(n)]
    sums = [" + ".join([f"a[{i}]"] + [f"b{k}[{i}]" for k in range(n)]) for i in range(3)]
    lines += [
        "",
        "",
        "@jit",
        "def torque(q, w, t, params):",
        "    a = builtin_torque(q, w, t, params)",
        *parts,
        f"    return ({sums[0]}, {sums[1]}, {sums[2]})",
        "",
        "",
        "@jit",
        "def potential(q, t, params):",
        "    return builtin_potential(q, t, params)"
        + "".join(f" + USER_POTENTIAL_{k}(q, t)" for k, (_, _, U) in enumerate(terms) if U),
        "",
        "",
        "@jit",
        "def term_torque(j, q, w, t, params):",
        "    nb = builtin_n_terms(params)",
        "    if j < nb:",
        "        return builtin_term_torque(j, q, w, t, params)",
    ]
    for k in range(n):
        lines += [f"    if j == nb + {k}:", f"        return {exprs[k]}"]
    lines += [
        "    return ZERO3",
        "",
        "",
        "@jit",
        "def n_terms(params):",
        f"    return builtin_n_terms(params) + {n}",
    ]
    lines += _event_block(events)
    if step:
        lines += _step_block()
    return "\n".join(lines) + "\n"


_LOADED: dict[tuple, tuple[types.ModuleType, tuple]] = {}
_WARNED: set[str] = set()


class UncachedKernelWarning(UserWarning):
    """A user function has no source file, so its compiled kernels last for this process only."""


def _template() -> str:
    return Path(_builtin_entry_points.__file__).read_text(encoding="utf-8")


def _module_source(
    terms: tuple[UserTerm, ...],
    cached: bool,
    events: tuple = (),
    step: bool = False,
    builtin: str | None = None,
) -> str:
    text = _template()
    i = text.index(_BEGIN)
    j = text.index(_END) + len(_END)
    model = _model_block(terms, events, step)
    if builtin is not None:
        model += (
            f"\n# The built-in part of the model: {builtin} (its kernels are injected with the "
            "user's,\n# as builtin_torque, builtin_potential, builtin_term_torque"
            + (", orbit_sample" if builtin != USER_ONLY else "")
            + ").\n"
        )
    if not cached:
        model = (
            "import functools\n\njit = functools.partial(jit, cache=False)\n"
            "rebind = functools.partial(rebind, cache=False)\n\n" + model
        )
    kinds = ", ".join(
        [*(kind for kind, _, _ in terms), *(["events"] if events else []), *(["step"] * step)]
    )
    head = f'"""Compiled entry points of a user model ({kinds}), generated by attitude."""'
    k = text.index("from __future__")
    return head + "\n\n" + text[k:i] + model + text[j:]


# --------------------------------------------------------------------------------------------
# fingerprints of user functions
# --------------------------------------------------------------------------------------------


def _python_function(fn: Any) -> Any:
    return getattr(fn, "py_func", fn)


def _value_bytes(v: Any) -> bytes | None:
    """Bytes of a value numba would freeze into machine code, or None if it is not such."""
    if isinstance(v, (bool, int, float, complex, str, bytes, type(None))):
        return repr((type(v).__name__, v)).encode()
    if isinstance(v, np.ndarray):
        return repr((v.dtype.str, v.shape)).encode() + np.ascontiguousarray(v).tobytes()
    if isinstance(v, np.generic):
        return repr((v.dtype.str, v.item())).encode()
    if isinstance(v, tuple):
        parts = [_value_bytes(x) for x in v]
        return None if any(p is None for p in parts) else b"(" + b",".join(parts) + b")"
    return None


def _function_fingerprint(fn: Any, h: Any, seen: set[int]) -> bool:
    """Fold ``fn`` (its file, name, and the values it reads) into ``h``; False if impossible."""
    f = _python_function(fn)
    if id(f) in seen:
        return True
    seen.add(id(f))
    if not isinstance(f, types.FunctionType):
        return False
    try:
        path = inspect.getsourcefile(f)
    except TypeError:
        return False
    if not path or not os.path.isfile(path):
        return False
    h.update(os.path.abspath(path).encode())
    h.update(Path(path).read_bytes())
    h.update(f.__qualname__.encode())
    values: list[tuple[str, Any]] = []
    if f.__closure__:
        values += list(
            zip(f.__code__.co_freevars, (c.cell_contents for c in f.__closure__), strict=True)
        )
    values += [(n, f.__globals__[n]) for n in f.__code__.co_names if n in f.__globals__]
    for name, v in values:
        if isinstance(v, types.ModuleType):
            continue
        b = _value_bytes(v)
        if b is not None:
            h.update(name.encode() + b)
        elif callable(v) and isinstance(_python_function(v), types.FunctionType):
            if not _function_fingerprint(v, h, seen):
                return False
        # other objects (classes, numba types) do not change the compiled code by value
    return True


def model_key(
    terms: tuple[UserTerm, ...], events: tuple = (), step: Any = None, builtin: str | None = None
) -> str | None:
    """Hash naming the compiled module of a model, or None when a function has no source file
    (``builtin``: the tag of the model's built-in part, :func:`builtin_part`, if specialised)."""
    h = hashlib.sha256()
    h.update(sources_fingerprint())
    h.update(f"{sys.version_info[:2]}".encode())
    if builtin is not None:
        h.update(f"builtin:{builtin}".encode())
    seen: set[int] = set()
    steps = (("step", step),) if step is not None else ()
    for kind, *functions in (*terms, *(("event", g) for g in events), *steps):
        h.update(kind.encode())
        for fn in functions:
            h.update(b"-" if fn is None else b"+")
            if fn is not None and not _function_fingerprint(fn, h, seen):
                return None
    return h.hexdigest()[:24]


# --------------------------------------------------------------------------------------------
# modules
# --------------------------------------------------------------------------------------------


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        with _suppress():
            os.unlink(tmp)
        raise


class _suppress:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return exc[0] is not None and issubclass(exc[0], OSError)


def _load(name: str, source: str, path: Path | None) -> types.ModuleType:
    if path is not None:
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod  # numba finds the module of cached functions by name
        spec.loader.exec_module(mod)
        return mod
    mod = types.ModuleType(name)
    mod.__file__ = f"<{name}>"
    sys.modules[name] = mod
    exec(compile(source, mod.__file__, "exec"), mod.__dict__)
    return mod


#: The tag of a model with no built-in part (user terms only: ``KIND_USER`` parameters).
USER_ONLY = "user_only"


def builtin_part(potential: Any) -> tuple[str, dict[str, Any]] | None:
    """The kernels a user module binds for the built-in part of ``potential``: (tag, {global
    name: kernel}), or None to keep the switch over every built-in kind (a sum of models).

    A user module compiled with that switch compiles, into every entry point it runs, the code
    of every built-in model and orbit type (the heavy top, the gravity gradient, the environment
    models, ...) whatever the model: most of a user model's first compile. With no built-in
    part (user terms only) the built-in torque is none; with one built-in model alone (a
    compiled step or event functions on a built-in model) it is that model's own kernels, as
    the package's entry points of that model alone compile them (:mod:`attitude._core.models`,
    ``specialise``). The kernels return what the switch returns for such parameters, so the
    results are the same, bit for bit.
    """
    from ._core import potentials as _kp

    if potential is None:
        return None
    kind = getattr(potential, "_kind", None)
    if kind is None:  # user terms only: the switch gives no torque, no potential, no term
        return USER_ONLY, {
            "builtin_torque": _kp.torque_free_torque,
            "builtin_potential": _kp.torque_free_potential,
            "builtin_term_torque": _kp.model_term_torque,  # (never called: no built-in term)
        }
    if kind == _kp.KIND_SUM:
        return None
    spec = potential._entry_points()  # the package's entry points of this model alone
    tag = getattr(spec, "__kernel_tag__", None)
    if tag is None:  # (no specialisation of this model: the switch)
        return None
    return tag, {
        "builtin_torque": spec.torque,
        "builtin_potential": spec.potential,
        "builtin_term_torque": spec.term_torque,
        "orbit_sample": spec.orbit_sample,
    }


def entry_points(
    terms: tuple[UserTerm, ...], events: tuple = (), step: Any = None, potential: Any = None
) -> types.ModuleType:
    """The compiled entry points of a model with user terms (a module like ``_core.entry_points``).

    Parameters
    ----------
    terms : tuple of (kind, torque, potential)
        The user terms, in order: ``kind`` one of :data:`TORQUE_EXPR`; ``torque`` and
        ``potential`` the user's compiled functions (or None). The built-in terms of the model
        are data in ``params`` as usual.
    events : tuple of functions
        The user's event functions g(t, q, omega) (``attitude.events.Custom``), numbered in
        order (``KIND_USER`` blocks of the event data name them by number).
    step : numba function, optional
        The user's compiled flight-software ``step(t, m) -> commands``
        (:func:`attitude._core.fsw_step.step_boundary_with`).
    potential : attitude.potentials.Potential, optional
        The model these terms, events or step run with: its built-in part is compiled into the
        module (:func:`builtin_part`); without it, the switch over every built-in kind.

    Returns
    -------
    module
        With the functions of :mod:`attitude._core.entry_points`; memoised per process.
    """
    if step is not None:
        check_step(step)
    part = builtin_part(potential)
    builtin, bindings = (None, {}) if part is None else part
    memo = (
        *((kind, id(tau), id(U)) for kind, tau, U in terms),
        *(("event", id(g), 0) for g in events),
        *((("step", id(step), 0),) if step is not None else ()),
        *((("builtin", builtin, 0),) if builtin is not None else ()),
    )
    if memo in _LOADED:
        return _LOADED[memo][0]
    if JIT_DISABLED:  # plain Python: the template's functions are ordinary functions
        key, cached = "nojit" + hashlib.sha256(repr(memo).encode()).hexdigest()[:16], False
    else:
        key = model_key(terms, events, step, builtin)
        cached = key is not None
        if key is None:
            key = "p" + hashlib.sha256(repr((memo, os.getpid())).encode()).hexdigest()[:23]
            fns = [f for _, *fs in terms for f in fs if f is not None] + list(events)
            fns += [step] if step is not None else []
            names = [_python_function(f).__name__ for f in fns]
            label = ", ".join(names)
            if label not in _WARNED:
                _WARNED.add(label)
                warnings.warn(
                    f"attitude: {label} has no source file (defined interactively), so its "
                    "compiled kernels are kept for this process only; put it in a .py file to "
                    "compile it once and reuse it across processes",
                    UncachedKernelWarning,
                    stacklevel=4,
                )
    name = f"attitude_user_{key}"
    has_step = step is not None
    source = _module_source(terms, cached, events, has_step, builtin)
    path = None
    if cached:
        path = user_cache_dir() / "kernels" / f"{name}.py"
        try:
            if not (path.is_file() and path.read_text(encoding="utf-8") == source):
                _write_atomic(path, source)
        except OSError as exc:  # read-only or full disk: compile for this process only
            warnings.warn(
                f"attitude: cannot write compiled user kernels to {path.parent} ({exc}); they "
                "are kept for this process only (set ATTITUDE_CACHE_DIR to a writable folder)",
                UncachedKernelWarning,
                stacklevel=3,
            )
            source = _module_source(terms, False, events, has_step, builtin)
            name, path = name + "_p", None
    mod = sys.modules.get(name) or _load(name, source, path)
    for global_name, kernel in bindings.items():
        setattr(mod, global_name, kernel)
    for k, (_, tau, U) in enumerate(terms):
        setattr(mod, f"USER_TORQUE_{k}", tau)
        setattr(mod, f"USER_POTENTIAL_{k}", U)
    for k, g in enumerate(events):
        setattr(mod, f"USER_EVENT_{k}", g)
    if has_step:
        mod.USER_STEP = step
    _LOADED[memo] = (mod, (terms, events, step))  # keep the functions alive: ids are not reused
    return mod
