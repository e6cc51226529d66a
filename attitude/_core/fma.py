"""Fused multiply–add as an explicit operation: ``fma(a, b, c)`` = a·b + c rounded once.

The Taylor recurrences (:mod:`attitude._core.taylor`, and their lane-wise mirror in
:mod:`attitude._core.taylor_batch`) write their multiply–adds as ``fma`` calls instead of
letting LLVM contract ``a * b + c`` where it sees fit (``fastmath={"contract"}``): contraction
is decided per compiled context (scalar or SIMD code, after inlining), so the same expression
could round differently in a single run and in an ensemble batch. An explicit fma is one
IEEE-754 operation everywhere (the ``llvm.fma`` intrinsic: the FMA instruction of the CPU,
scalar or vector), so a member integrated in a SIMD batch reproduces its single run bit for
bit, and the rounding no longer depends on the compiler's choices.

With the JIT disabled (``ATTITUDE_DISABLE_JIT=1``) ``fma`` is an exact Python implementation
(rational arithmetic, one rounding; slow, for debugging only).
"""

from __future__ import annotations

from fractions import Fraction

from orbit._shared_jit import JIT_DISABLED

__all__ = ["fma"]


def _fma_exact(a: float, b: float, c: float) -> float:
    """a·b + c with one rounding, in Python (the JIT-disabled ``fma``)."""
    a, b, c = float(a), float(b), float(c)
    prod = a * b
    if not (abs(prod) < float("inf") and abs(c) < float("inf")):
        return prod + c  # inf and NaN propagate as in IEEE arithmetic
    return float(Fraction(a) * Fraction(b) + Fraction(c))


if JIT_DISABLED:
    fma = _fma_exact
else:
    from llvmlite import ir
    from numba.core import cgutils, types
    from numba.extending import intrinsic

    @intrinsic
    def _llvm_fma(typingctx, a, b, c):
        """``llvm.fma.f64``: the hardware fused multiply-add (vectorised by the SLP pass)."""
        if not all(isinstance(x, types.Float) for x in (a, b, c)):
            return None
        sig = types.float64(types.float64, types.float64, types.float64)

        def codegen(context, builder, signature, args):
            args = [context.cast(builder, v, t, types.float64)
                    for v, t in zip(args, signature.args, strict=True)]  # fmt: skip
            d = ir.DoubleType()
            fnty = ir.FunctionType(d, [d, d, d])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64")
            return builder.call(fn, args)

        return sig, codegen

    # the intrinsic itself, not a jitted wrapper inlined by numba's IR inliner: each inlined
    # call was a deep copy and a retyping at compile time (hundreds of them per driver)
    fma = _llvm_fma
