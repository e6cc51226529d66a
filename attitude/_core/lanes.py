"""Lanes: LANES independent float64 values carried together, for structure-of-arrays kernels.

A batch kernel (:mod:`attitude._core.taylor_batch`) integrates LANES members at once: every
quantity is a tuple of LANES floats, one per member, and arrays keep the lane as their last,
contiguous axis (``cf[k, column, lane]``). Each helper below applies ONE floating-point
operation lane by lane (multiply–adds as explicit fused operations, :mod:`attitude._core.fma`),
so a lane computes exactly the operations, in exactly the order, of the scalar kernel it
mirrors. LLVM's SLP vectoriser (on for the kernels that use these helpers:
:func:`orbit._shared_jit.slp_vectorized`) turns each helper into one SIMD instruction
(LANES = 4 doubles: one AVX2 register) and keeps the tuples of a loop's accumulators in
registers. Lanes never mix: no helper reduces across lanes.

The helpers are written once, for any width: :func:`helpers` generates each one's source for
``width`` lanes (the statements a hand-written version would have, so the same IR), compiled as
inline kernels of this file. This module holds the width-4 helpers; :func:`module` gives the
same at 8 doubles (one AVX-512 register), which :func:`attitude._core.taylor_batch.batch` binds
its integrator to; :func:`simd_lanes` says which width this CPU takes (chosen at run time,
never at import).
"""

from __future__ import annotations

import os
import sys
import types

from orbit._shared_jit import from_source

from .fma import fma as _fma

#: Members per batch (one 256-bit SIMD register of float64).
LANES = 4


#: Lane widths the batch integrators take (4: this module; 8: ``module(8)``).
WIDTHS = (4, 8)

_HOST: list[int] = []


def simd_lanes() -> int:
    """Doubles per SIMD register of this CPU, as the batch integrator's lane count: 8 with
    AVX-512 (``avx512f``), else 4 (AVX2, or the width LLVM splits for older CPUs).

    ``ATTITUDE_SIMD_LANES=4`` or ``8`` overrides it (read at every call: tests compare the
    widths). A width changes speed only, never a result.
    """
    env = os.environ.get("ATTITUDE_SIMD_LANES", "").strip()
    if env:
        if int(env) not in WIDTHS:
            raise ValueError(f"ATTITUDE_SIMD_LANES={env!r}: must be one of {WIDTHS}")
        return int(env)
    if not _HOST:
        try:
            import llvmlite.binding as llb

            avx512 = bool(llb.get_host_cpu_features().get("avx512f"))
        except Exception:  # pragma: no cover - no feature list (another architecture)
            avx512 = False
        _HOST.append(8 if avx512 else 4)
    return _HOST[0]


#: The helpers: (arguments, what lane i of the result is, docstring). ``store`` writes instead.
_ELEMENTWISE = {
    "load": ("a, k, c", "a[k, c, {i}]", "``a[k, c, :]`` as a lane tuple."),
    "load_row": ("a, c", "a[c, {i}]", "``a[c, :]`` (per-lane constants) as a lane tuple."),
    "add": ("a, b", "a[{i}] + b[{i}]", "a + b, lane by lane."),
    "sub": ("a, b", "a[{i}] - b[{i}]", "a − b, lane by lane."),
    "mul": ("a, b", "a[{i}] * b[{i}]", "a·b, lane by lane."),
    "div": ("a, b", "a[{i}] / b[{i}]", "a / b, lane by lane."),
    "smul": ("s, a", "s * a[{i}]",
             "The scalar ``s`` times every lane (a product commutes exactly: also ``a * s``)."),
    "fma": ("a, b, c", "_fma(a[{i}], b[{i}], c[{i}])",
            "a·b + c rounded once, lane by lane (:func:`attitude._core.fma.fma`)."),
    "neg": ("a", "-a[{i}]", "−a, lane by lane."),
}  # fmt: skip


def helpers(width: int) -> dict:
    """The lane helpers for ``width`` lanes: ``ZERO``, ``LANES`` and the inline kernels
    ``load``, ``store``, ``load_row``, ``add``, ``sub``, ``mul``, ``div``, ``smul``, ``fma``,
    ``neg``."""
    src = []
    for name, (args, lane, doc) in _ELEMENTWISE.items():
        items = ", ".join(lane.format(i=i) for i in range(width))
        src.append(f'def {name}({args}):\n    """{doc}"""\n    return ({items},)\n')
    writes = "".join(f"    a[k, c, {i}] = v[{i}]\n" for i in range(width))
    src.append(f'def store(a, k, c, v):\n    """``a[k, c, :] = v``."""\n{writes}')
    suffix = "" if width == LANES else f"__lanes{width}"  # (its own cache files)
    out = from_source("\n".join(src), {"_fma": _fma}, __name__, __file__, suffix, inline="always")
    out.update(LANES=width, ZERO=(0.0,) * width)
    return out


_MODULES: dict[int, types.ModuleType] = {}


def module(width: int) -> types.ModuleType:
    """The helpers for ``width`` lanes as a module object (this module for 4)."""
    if width == LANES:
        return sys.modules[__name__]
    if width not in _MODULES:
        m = types.ModuleType(f"{__name__}{width}", f"Lanes of {width} doubles (see {__name__}).")
        m.__dict__.update(helpers(width))
        _MODULES[width] = m
    return _MODULES[width]


_H = helpers(LANES)
ZERO = _H["ZERO"]
load, store, load_row = _H["load"], _H["store"], _H["load_row"]
add, sub, mul, div, smul, fma, neg = (
    _H[n] for n in ("add", "sub", "mul", "div", "smul", "fma", "neg")
)
