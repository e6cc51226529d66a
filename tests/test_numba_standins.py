"""The stand-ins for numba's inliner copy, SSA reconstruction and flags comparison
(orbit/_numba_standins.py, docs/cold_start.md) give the same LLVM IR as numba's own passes, and they
are in place only while one of the package's kernels compiles.

Truth: numba itself, in a second process with the stand-ins left out
(``ATTITUDE_NUMBA_STANDINS=0``), or without ``attitude`` imported at all. Two of the package's
kernels are compiled afresh (never from a cache) in both processes: the gyrostat's Taylor
recurrences (hundreds of variables assigned more than once: the SSA pass) and the MEKF's
propagation (functions inlined at the IR level: the inliner). Their LLVM IR must be the same
text, and the first process must really have used the stand-ins (else the comparison would be
numba against numba). A user's own numba function, which reassigns variables, inlines a callee
and compiles with non-default flags, must compile to the same LLVM IR whether or not
``attitude`` was imported and had compiled its kernels first.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(
    os.environ.get("ATTITUDE_DISABLE_JIT", "0") not in ("", "0"), reason="kernels not compiled"
)

_PACKAGE = textwrap.dedent(
    """
    import hashlib, json, re, sys
    import numba
    import orbit._shared_jit  # registers the listener (unless switched off)
    from orbit import _numba_standins as sj
    from attitude._core import mekf, taylor_gyrostat as tg
    from numba.core import types
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
    out["standins"] = sj.STANDINS.used
    print(json.dumps(out))
    """
)

# A user's module. Three of numba's process-wide counters, advanced by any earlier compilation
# (the package's or anyone's), show in the IR: the function version in mangled names, the
# version in the names of an inlined function's variables, and the numbers of the blocks its
# inliner adds. They are renamed (blocks in order of appearance) and comments dropped (their
# padding follows the names); everything else must be the same text.
_USER = textwrap.dedent(
    """
    import copy, hashlib, json, re, sys
    import numba
    import numpy as np
    if sys.argv[1] == "attitude":
        import attitude
        from orbit import _numba_standins as sj
        from attitude._core import mekf
        from numba.core import types
        arr = types.float64[::1]
        numba.njit((arr, arr, arr, types.float64), cache=False)(mekf.mekf_propagate.py_func)
        assert sj.STANDINS.used >= 1 or not sj.NUMBA_STANDINS
    from numba.core import ssa, targetconfig
    from numba.core import inline_closurecall as ic

    @numba.njit(inline="always")
    def helper(x, k):
        s = 0.0
        for i in range(k):
            s = s + x * i
            if s > 10.0:
                s = s - 10.0
        return s

    @numba.njit(fastmath=True, error_model="numpy")
    def user(a, n):
        acc = 0.0
        t = 1.0
        for j in range(a.shape[0]):
            t = t * 0.5 + a[j]
            if t > 2.0:
                t = helper(t, n)
            acc = acc + t
        t = acc / n
        return t, acc

    user(np.arange(5.0), 3)
    ir = user.inspect_llvm(user.signatures[0])
    ir = re.sub(r"0x[0-9a-f]+|inttoptr \\(i64 \\d+", "ADDR", ir)
    ir = re.sub(r"B\\d+v\\d+", "Bv", ir)
    ir = re.sub(r"_v\\d+_", "_v_", re.sub(r"\\s*;.*", "", ir))
    labels = {}
    ir = re.sub(r"\\bB(\\d+)\\b", lambda m: "L%d" % labels.setdefault(m[1], len(labels)), ir)
    print(json.dumps({
        "ir": hashlib.sha256(ir.encode()).hexdigest(),
        "numbas_own": [
            ssa._run_ssa.__module__ == "numba.core.ssa",
            ic.copy is copy,
            targetconfig.TargetConfig.__hash__.__module__ == "numba.core.targetconfig",
        ],
    }))
    """
)


def _run(code: str, tmp, *args: str, **env_extra: str) -> dict:
    # empty caches of its own (numba's and the package's): processes compile the same
    # functions in the same order, so the version numbers in the mangled names agree (a
    # shared package cache let the second process load what the first compiled: v3 for v4)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp), ATTITUDE_CACHE_DIR=str(tmp / "package"),
               **env_extra)  # fmt: skip
    env.pop("ATTITUDE_DISABLE_JIT", None)
    r = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_standins_give_numbas_own_llvm_ir(tmp_path):
    ours = _run(_PACKAGE, tmp_path / "a", ATTITUDE_NUMBA_STANDINS="1")
    numbas = _run(_PACKAGE, tmp_path / "b", ATTITUDE_NUMBA_STANDINS="0")
    assert numbas.pop("standins") == 0
    assert ours.pop("standins") == 2  # both kernels compiled with them (numba 0.68 is pinned)
    assert ours == numbas


def test_user_numba_code_compiles_as_without_attitude(tmp_path):
    alone = _run(_USER, tmp_path / "a", "alone")
    beside = _run(_USER, tmp_path / "b", "attitude")
    assert alone["numbas_own"] == [True, True, True]
    assert beside["numbas_own"] == [True, True, True]  # put back after the package's compile
    assert beside["ir"] == alone["ir"]
