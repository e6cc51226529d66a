"""User kernels compile into a cache of their own (attitude._user_kernels), across processes.

The package's on-disk cache must only ever hold the package's kernels: a user's torque compiled
into it used to break every later process that could not import the user's module
(``ModuleNotFoundError: No module named 'mymodel'``). These tests run user models in fresh
processes with a private ``ATTITUDE_CACHE_DIR`` and check, through numba's own cache statistics,
that an unchanged user file is loaded from the cache instead of compiled again.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import attitude
from attitude import _user_kernels
from orbit._shared_jit import JIT_DISABLED

pytestmark = pytest.mark.skipif(JIT_DISABLED, reason="caching needs numba's JIT")

ROOT = Path(__file__).resolve().parent.parent

RUN = textwrap.dedent(
    """
    import json, sys, time
    import numpy as np
    sys.path.insert(0, sys.argv[1])
    import attitude
    from {module} import tau

    body = attitude.RigidBody([1.25, 1.0, 0.75])
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.1, 0.7, 0.3], body)
    pot = attitude.CustomTorque(tau)
    t0 = time.perf_counter()
    ds = attitude.propagate(body, q0, Q0, np.linspace(0.0, 10.0, 11), potential=pot)
    wall = time.perf_counter() - t0
    ep = pot._entry_points()
    stats = ep.dop853_canonical.stats
    print(json.dumps({{
        "omega": ds.omega.values[-1].tolist(),
        "module": ep.__name__,
        "file": ep.__file__,
        "hits": sum(stats.cache_hits.values()),
        "misses": sum(stats.cache_misses.values()),
        "wall": wall,
    }}))
    """
)


def _run(script_dir: Path, user_dir: Path, module: str, cache: Path) -> dict:
    script = script_dir / "run_user_model.py"
    script.write_text(RUN.format(module=module))
    env = {**os.environ, "ATTITUDE_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, str(script), str(user_dir)],
        cwd=script_dir,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def _constant_torque_omega(c: float) -> np.ndarray:
    """ω at t = 10 under a constant body torque (0, 0, c), by an independent in-process run."""
    body = attitude.RigidBody([1.25, 1.0, 0.75])
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.1, 0.7, 0.3], body)
    ref = attitude.propagate(
        body,
        q0,
        Q0,
        np.linspace(0.0, 10.0, 11),
        potential=attitude.CustomTorque(_TORQUES[c]),
        formulation="euler_equations",
        rtol=1e-12,
        atol=1e-14,
    )
    return ref.omega.values[-1]


def _tau_a(q, t):
    return (0.0, 0.0, 0.01)


def _tau_b(q, t):
    return (0.02, 0.0, 0.0)


_TORQUES = {0.01: _tau_a, 0.02: _tau_b}


def _index_entries(cache_root: Path) -> list[tuple[Path, object]]:
    """Every numba cache index below ``cache_root`` (skipping the user cache), unpickled."""
    out = []
    for nbi in sorted(cache_root.rglob("*.nbi")):
        if "user" in nbi.relative_to(cache_root).parts[:1]:
            continue
        with open(nbi, "rb") as fh:
            pickle.load(fh)  # numba's format version
            _stamp, overloads = pickle.loads(fh.read())  # raises if a module is missing
        out.append((nbi, overloads))
    return out


@pytest.mark.slow  # four processes, each compiling a user model's kernels (~70 s)
def test_user_kernels_stay_out_of_the_package_cache_across_processes(tmp_path):
    cache = tmp_path / "cache"
    a, b, scripts = tmp_path / "A", tmp_path / "B", tmp_path / "scripts"
    for d in (a, b, scripts):
        d.mkdir()
    (a / "mymodel.py").write_text("def tau(q, t):\n    return (0.0, 0.0, 0.01)\n")
    (b / "othermodel.py").write_text("def tau(q, t):\n    return (0.02, 0.0, 0.0)\n")

    first = _run(scripts, a, "mymodel", cache)
    assert first["misses"] >= 1 and first["hits"] == 0  # compiled in this process
    assert Path(first["file"]).parent == cache / "user" / "kernels"

    # the user's module disappears; a different model from another directory must still run
    (a / "mymodel.py").unlink()
    second = _run(scripts, b, "othermodel", cache)
    assert second["misses"] >= 1 and second["module"] != first["module"]

    # the same unchanged file in a fresh process: loaded from the cache, not compiled
    third = _run(scripts, b, "othermodel", cache)
    assert third["hits"] >= 1 and third["misses"] == 0
    assert third["module"] == second["module"]
    print(f"\nuser model: first process {second['wall']:.2f} s, cached {third['wall']:.2f} s")

    # physics unchanged by the caching: against an independent formulation in this process
    np.testing.assert_allclose(first["omega"], _constant_torque_omega(0.01), atol=1e-8)
    np.testing.assert_allclose(third["omega"], _constant_torque_omega(0.02), atol=1e-8)

    # a changed source is a new module (compiled again), not a stale cached kernel
    (b / "othermodel.py").write_text("def tau(q, t):\n    return (0.02, 0.0, 0.0)  # edited\n")
    fourth = _run(scripts, b, "othermodel", cache)
    assert fourth["module"] != third["module"] and fourth["misses"] >= 1

    # nothing of the users' in the package's part of the cache, and every index loads
    for nbi, _overloads in _index_entries(cache):
        text = nbi.read_bytes()
        assert b"mymodel" not in text and b"othermodel" not in text, nbi
        assert b"attitude_user_" not in text and "attitude_user_" not in nbi.name, nbi
    # the user model's copy of the DOP853 driver (orbit._shared_jit.rebind) is cached with it
    user = [p.name for p in (cache / "user").rglob("*.nbi")]
    assert any(n.startswith("rk.dop853_run__canonical__attitude_user_") for n in user), user


def test_model_key_follows_the_source_and_the_values_it_reads(tmp_path):
    def key(kind, *fns):
        return _user_kernels.model_key(tuple((kind, f, None) for f in fns))

    k1 = key("torque", _tau_a)
    assert k1 == key("torque", _tau_a)
    assert k1 != key("torque", _tau_b)  # another function
    assert k1 != key("torque_rates", _tau_a)  # another kind
    assert k1 != key("torque", _tau_a, _tau_b)  # another term
    assert k1 != _user_kernels.model_key((("torque", _tau_a, _tau_b),))  # with a potential

    def make(k):
        def tau(q, t):
            return (0.0, 0.0, k)

        return tau

    # closures: numba freezes the cell values into the code, so they are part of the key
    assert key("torque", make(1.0)) != key("torque", make(2.0))
    # no source file: no key (compiled per process)
    ns: dict = {}
    exec("def tau(q, t):\n    return (0.0, 0.0, 1.0)\n", ns)
    assert key("torque", ns["tau"]) is None


def test_user_modules_compile_the_built_in_part_of_their_model_alone():
    """A user module binds the kernels of its model's built-in part (none for user terms only,
    the model's own for a step or events on one built-in model, the switch over every kind for
    a sum), named in its key. With user terms only the switch adds exact zeros (no torque, no
    potential): the bound module's torque and potential are the user's, bit for bit."""
    from attitude._core import potentials as kp

    ct = attitude.CustomTorque(_tau_a, potential=_U_a)
    tag, bound = _user_kernels.builtin_part(ct)
    assert tag == _user_kernels.USER_ONLY
    assert bound["builtin_torque"] is kp.torque_free_torque
    top = attitude.HeavyTop(0.5, [0.1, 0.0, 0.2])
    tag, bound = _user_kernels.builtin_part(top)
    spec = top._entry_points()
    assert tag == "heavy_top" == spec.__kernel_tag__
    assert bound["builtin_torque"] is spec.torque and bound["orbit_sample"] is spec.orbit_sample
    assert _user_kernels.builtin_part(top + ct) is None  # a sum: the switch
    terms = ct._user_terms()
    assert _user_kernels.model_key(terms) != _user_kernels.model_key(terms, builtin="x")
    generic, alone = _user_kernels.entry_points(terms), ct._entry_points()  # (nothing compiled)
    assert alone is _user_kernels.entry_points(terms, potential=ct) and alone is not generic
    assert alone.builtin_torque is kp.torque_free_torque
    assert generic.builtin_torque is kp.builtin_torque
    rng = np.random.default_rng(5)
    q = attitude.quaternion.normalize(rng.normal(size=(7, 4)))
    w, t = rng.normal(size=(7, 3)), rng.uniform(0.0, 10.0, 7)
    tau, u = np.empty((7, 3)), np.empty(7)
    alone.evaluate(q, w, t, ct._params(np.ones(3)), tau, u)
    assert np.array_equal(tau, np.broadcast_to([0.0, 0.0, 0.01], (7, 3)))
    assert np.array_equal(u, [_U_a(qk, tk) for qk, tk in zip(q, t, strict=True)])


def _U_a(q, t):
    return 0.5 * q[3] * q[3] + t


def test_interactive_function_compiles_per_process_and_says_so_once():
    ns: dict = {}
    exec("def tau_prompt(q, t):\n    return (0.0, 0.0, 0.001)\n", ns)
    body = attitude.RigidBody([1.25, 1.0, 0.75])
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.1, 0.7, 0.3], body)
    pot = attitude.CustomTorque(ns["tau_prompt"])
    with pytest.warns(_user_kernels.UncachedKernelWarning, match="tau_prompt"):
        ds = attitude.propagate(body, q0, Q0, [0.0, 1.0], potential=pot)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        attitude.propagate(body, q0, Q0, [0.0, 1.0], potential=attitude.CustomTorque(pot._tau))
    # the torque acts: G3 grows at the torque's space-z component rate (about 1e-3 here)
    assert ds.G.values[-1, 2] != ds.G.values[0, 2]


def test_package_cache_indexes_load_and_hold_no_function_typed_signatures():
    """Every index of the package's own cache loads in this process and names plain types only.

    This file sorts late, so it also sees what the suite before it compiled.
    """
    from numba.core import types

    roots = [ROOT / "attitude", ROOT / "orbit"]
    if os.environ.get("ATTITUDE_CACHE_DIR"):
        roots.append(Path(os.environ["ATTITUDE_CACHE_DIR"]))
    n = 0
    for root in roots:
        for nbi, overloads in _index_entries(root):
            for key in overloads:
                sig = key[0]
                for ty in sig:
                    assert not isinstance(ty, (types.Dispatcher, types.FunctionType)), (nbi, sig)
                n += 1
    assert n > 0  # the suite compiled and cached package kernels


MAIN_JOB = textwrap.dedent(
    """
    import json, sys
    from numba.core import event
    compiled = []
    class Listener(event.Listener):
        def on_start(self, ev):
            pass
        def on_end(self, ev):
            f = getattr(ev.data.get("dispatcher"), "py_func", None)
            compiled.append(getattr(f, "__qualname__", "?"))
    event.register("numba:compile", Listener())
    from attitude.cli import main
    main(["run", sys.argv[1], "-o", sys.argv[2], "-q"])
    print(json.dumps(compiled))
    """
)


def test_main_job_compiles_nothing_in_a_second_process(tmp_path):
    """The README's main job in a fresh install: what its first run compiles is all cached.

    Fresh, empty numba caches (``NUMBA_CACHE_DIR``, ``ATTITUDE_CACHE_DIR``): the first
    ``attitude run scenarios/paper_keplerian.toml`` compiles (the kernels of the gravity
    gradient alone on an elliptic Kepler orbit, attitude._core.models; its diagnostics pass
    compiled by its helper process meanwhile); a second process loads every one of them from
    the cache (numba's compile events: none) and writes the same file.
    """
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
        "ATTITUDE_CACHE_DIR": str(tmp_path / "attitude"),
        "PYTHONPATH": str(ROOT),
        "PYTHONWARNINGS": "ignore",
        "ATTITUDE_COMPILE_HELPER": "1",  # (as in a user's shell: off in the suite's workers)
    }
    script = tmp_path / "main_job.py"
    script.write_text(MAIN_JOB)
    scenario = str(ROOT / "scenarios" / "paper_keplerian.toml")

    def run(out: Path) -> list[str]:
        res = subprocess.run(
            [sys.executable, str(script), scenario, str(out)],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900,
        )  # fmt: skip
        assert res.returncode == 0, res.stderr
        return json.loads(res.stdout.strip().splitlines()[-1])

    first = run(tmp_path / "first.nc")
    assert any(name.startswith("dop853_run__canonical") for name in first), first
    # the diagnostics pass: compiled by the run's helper meanwhile (attitude/_compiling.py)
    assert not any(name.startswith("samples__") for name in first), first
    second = run(tmp_path / "second.nc")
    assert second == []  # every kernel the job needs came from the cache
    import xarray as xr

    with xr.open_dataset(tmp_path / "first.nc") as a, xr.open_dataset(tmp_path / "second.nc") as b:
        for name in a.variables:
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


BAD_MODULE = """
import numpy as np


def tau(q, omega, t):
    scale = q[0] * 2.0
    x = "a" + scale
    return np.array([0.0, 0.0, x])


def U(q, t):
    return q.not_an_attribute


def g(t, q, omega):
    return undefined_name
"""


def test_typing_errors_in_user_functions_show_the_offending_line(tmp_path):
    """numba's 'Failed in nopython mode pipeline' is not the message: the reason, the
    construct and the user's file and line are (then numba's whole message)."""
    import importlib.util

    from attitude import events
    from attitude.errors import AttitudeTypeError
    from attitude.potentials import CustomPotential, CustomTorque

    path = tmp_path / "bad_model.py"
    path.write_text(BAD_MODULE)
    spec = importlib.util.spec_from_file_location("bad_model", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    with pytest.raises(AttitudeTypeError) as err:
        CustomTorque(mod.tau)
    first = str(err.value).splitlines()[0]
    assert "numba could not compile it: No implementation of function add for add(" in first
    assert f"at {path} line 7: " in first and first.endswith('x = "a" + scale')
    assert "numba's message:\nFailed in nopython mode pipeline" in str(err.value)
    with pytest.raises(AttitudeTypeError) as err:
        CustomPotential(mod.U)
    first = str(err.value).splitlines()[0]
    assert "Unknown attribute 'not_an_attribute'" in first and "line 12: " in first
    with pytest.raises(AttitudeTypeError) as err:
        events.Custom(mod.g)
    assert "NameError: name 'undefined_name' is not defined" in str(err.value).splitlines()[0]
