"""The stand-ins for numba's inliner copy, SSA reconstruction and flags comparison
(orbit/_shared_jit.py, docs/cold_start.md) give the same LLVM IR as numba's own passes.

Truth: numba itself, in a second process with the stand-ins left out
(``ATTITUDE_NUMBA_STANDINS=0``). Two of the package's kernels are compiled afresh (never from a
cache) in both processes: the gyrostat's Taylor recurrences (hundreds of variables assigned more
than once: the SSA pass) and the MEKF's propagation (functions inlined at the IR level: the
inliner). Their LLVM IR must be the same text, and the first process must really have the
stand-ins in place (else the comparison would be numba against numba).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

_PROBE = textwrap.dedent(
    """
    import hashlib, json, re, sys
    import numba
    import orbit._shared_jit as sj  # registers the stand-ins (unless switched off)
    from attitude._core import mekf, taylor_gyrostat as tg
    from numba.core import ssa, types
    arr = types.float64[::1]
    arr2 = types.float64[:, ::1]
    cases = [
        (mekf.mekf_propagate, (arr, arr, arr, types.float64)),
        (tg.gyrostat_coefficients, (arr2, types.int64, arr, arr, types.float64, arr,
                                     types.float64, types.float64, types.float64, types.int64)),
    ]
    out = {}
    for kernel, sig in cases:
        f = numba.njit(sig, cache=False, error_model="numpy")(kernel.py_func)
        ir = f.inspect_llvm(sig)
        ir = re.sub(r"0x[0-9a-f]+|inttoptr \\(i64 \\d+", "ADDR", ir)
        out[kernel.py_func.__name__] = hashlib.sha256(ir.encode()).hexdigest()
    out["standins"] = ssa._run_ssa.__module__ != "numba.core.ssa"  # (installed on a compile)
    print(json.dumps(out))
    """
)


def _probe(standins: str, tmp) -> dict:
    import json

    # empty caches of its own (numba's and the package's): both processes compile the same
    # functions in the same order, so the version numbers in the mangled names agree (a
    # shared package cache let the second process load what the first compiled: v3 for v4)
    env = dict(os.environ, ATTITUDE_NUMBA_STANDINS=standins, NUMBA_CACHE_DIR=str(tmp),
               ATTITUDE_CACHE_DIR=str(tmp / "package"))  # fmt: skip
    env.pop("ATTITUDE_DISABLE_JIT", None)
    r = subprocess.run(
        [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(
    os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0"), reason="kernels not compiled"
)
def test_standins_give_numbas_own_llvm_ir(tmp_path):
    ours = _probe("1", tmp_path / "a")
    numbas = _probe("0", tmp_path / "b")
    assert not numbas.pop("standins")
    if not ours.pop("standins"):
        # they leave themselves out on a numba whose internals differ from 0.68's (by design);
        # on the numba they were written for, not being in place is a failure
        import numba

        assert not numba.__version__.startswith("0.68."), "the stand-ins are not in place"
        pytest.skip(f"numba {numba.__version__}: the stand-ins left themselves out")
    assert ours == numbas
