"""orbit/_shared_jit.py: the package's numba layer.

The kernel cache is keyed per module on the sources of the module and of every package module
it imports (``source_stamp``): in a copy of the source tree, a kernel compiled once is loaded,
not compiled, after an edit of a module it does not import (the CLI, or a module that
imports *it*), and compiled again after an edit of a module it does import. Truth: numba's own
cache index (``will_compile`` reads it) and its compile events in fresh processes. The
stand-ins for numba's passes have their own test file (test_numba_standins.py).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from compile_events import LISTEN

import orbit._shared_jit as sj

pytestmark = pytest.mark.skipif(sj.JIT_DISABLED, reason="kernels not compiled")

_ROOT = Path(sj.__file__).resolve().parent.parent

# orbit._kernels imports orbit._kepler_equation, not the reverse: mean_anomaly (of the first)
# is keyed on both sources, reduce_angle (of the second) on its own.
_PROBE = LISTEN + textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from orbit._shared_jit import will_compile
    from orbit import _kepler_equation as ke, _kernels as k
    out = {"ke": will_compile(ke.reduce_angle), "k": will_compile(k.mean_anomaly)}
    ke.reduce_angle(7.0)
    k.mean_anomaly(np.array([7e6, 0.1, 0.5, 0.2, 0.3, 0.4, 1.0, 0.0, 1e-3, 0.0]), 10.0)
    out["compiled"] = sorted(set(compiled))
    print(json.dumps(out))
    """
)


def _probe(tree: Path, cache: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), ATTITUDE_CACHE_DIR=str(cache))
    r = subprocess.run(
        [sys.executable, "-c", _PROBE], cwd=tree, env=env, capture_output=True, text=True,
        timeout=600,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def _touch(path: Path) -> None:
    path.write_text(path.read_text() + "\n# edited\n")


def test_source_stamp_follows_imports():
    stamp = sj.source_stamp("orbit._kernels")
    assert stamp == sj.source_stamp("orbit._kernels[some_tag]")  # a specialise() copy
    assert stamp != sj.source_stamp("orbit._kepler_equation")
    assert sj._imports("orbit._kernels") >= {"orbit._kepler_equation", "orbit._shared_jit"}
    assert "attitude.cli" not in sj._imports("attitude._core.entry_points")


def test_import_scan_finds_what_pythons_parser_finds():
    # The cache keys read each module's imports with a regular expression; Python's own parser
    # (every Import and ImportFrom node, relative ones resolved) finds the same package modules
    # in every module of both packages.
    import ast

    names = []
    for pkg in ("orbit", "attitude"):
        for path in sorted((_ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(_ROOT).with_suffix("")
            names.append(".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts))
    assert len(names) > 150
    for name in names:
        path = sj._module_file(name)
        base = name if path.name == "__init__.py" else name.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_bytes())):
            if isinstance(node, ast.Import):
                found.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                up = base.split(".")[: len(base.split(".")) - node.level + 1] if node.level else []
                mod = ".".join(up + ([node.module] if node.module else []))
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    found.add(sub if sj._module_file(sub) is not None else mod)
        expected = {m for m in found if sj._module_file(m) is not None}
        assert sj._imports(name) == expected, name


def test_editing_a_module_recompiles_only_its_importers(tmp_path):
    tree = tmp_path / "src"
    for pkg in ("orbit", "attitude"):
        shutil.copytree(_ROOT / pkg, tree / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    cache = tmp_path / "cache"
    first = _probe(tree, cache)
    assert first["ke"] and first["k"]
    assert {"reduce_angle", "mean_anomaly"} <= set(first["compiled"])

    _touch(tree / "attitude" / "cli" / "_run.py")
    again = _probe(tree, cache)
    assert not again["ke"] and not again["k"]
    assert again["compiled"] == []

    _touch(tree / "orbit" / "_kernels.py")  # imports _kepler_equation, not the reverse
    edited = _probe(tree, cache)
    assert not edited["ke"] and edited["k"]
    assert "reduce_angle" not in edited["compiled"] and "mean_anomaly" in edited["compiled"]

    _touch(tree / "orbit" / "_kepler_equation.py")  # imported by _kernels: both again
    both = _probe(tree, cache)
    assert both["ke"] and both["k"]


# A process that compiles reduce_angle under its lock, told when to start (stdin), and one that
# needs it meanwhile: the second waits and loads what the first saved. Called from Python (the
# kernel itself), or compiled as the callee of another kernel (its copy without the CPython
# wrapper, what compiled code calls).
_LOCKER = LISTEN + textwrap.dedent(
    """
    import sys
    from numba.core import types
    from orbit import _kepler_equation as ke
    from orbit._shared_jit import _compile_lock
    kernel = ke.reduce_angle if sys.argv[1] == "python" else ke.reduce_angle.dispatcher
    with _compile_lock(kernel):
        print("locked", flush=True)
        sys.stdin.readline()
        kernel.compile((types.float64,))  # this process holds the lock: no wait for itself
    print(sorted(set(compiled)), flush=True)
    """
)
_WAITER = LISTEN + textwrap.dedent(
    """
    import sys
    from orbit import _kepler_equation as ke
    print("ready", flush=True)
    if sys.argv[1] == "python":
        ke.reduce_angle(7.0)
    else:
        ke._kepler_E_reduced(7.0, 0.1)  # calls reduce_angle
    print(sorted(set(compiled)), flush=True)
    """
)


@pytest.mark.parametrize("how", ["python", "callee"])
def test_a_kernel_compiling_in_another_process_is_waited_for_and_loaded(tmp_path, how):
    env = dict(os.environ, PYTHONPATH=str(_ROOT), ATTITUDE_CACHE_DIR=str(tmp_path / "cache"))
    kw = dict(env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    locker = subprocess.Popen([sys.executable, "-c", _LOCKER, how], **kw)
    waiter = None
    try:
        assert locker.stdout.readline().strip() == "locked"
        waiter = subprocess.Popen([sys.executable, "-c", _WAITER, how], **kw)
        assert waiter.stdout.readline().strip() == "ready"
        time.sleep(1.5)  # the waiter is blocked on the lock (without it: compiling already)
        assert waiter.poll() is None
        out, _ = locker.communicate("go\n", timeout=300)
        assert "reduce_angle" in out
        wout, _ = waiter.communicate(timeout=300)
        assert "reduce_angle" not in wout  # loaded, not compiled
        assert (wout.strip() == "[]") == (how == "python")  # (the caller: its own compiled)
    finally:
        for p in (locker, waiter):
            if p is not None and p.poll() is None:
                p.kill()
