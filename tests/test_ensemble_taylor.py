"""propagate_ensemble(method="taylor"): the Taylor method on SIMD batches of members.

Truth: single runs of the same method (bit for bit: a member in a batch lane computes exactly
what it computes alone), closed forms (symmetric tops), conservation laws (H, |q|, q·Q, the
inertial momentum) against the dop853 ensemble at equal tolerance. Contracts as for dop853
ensembles: results independent of chunks, threads and driver; failures name the members and
keep the chunks done; bad input (events, potentials the method cannot expand) fails before any
work with the parameter named. The batch kernel really is SIMD code (packed FMAs).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from attitude import canonical as C
from attitude import quaternion as qt
from attitude._core import entry_points as _ep
from attitude.body import RigidBody
from attitude.ensemble import propagate_ensemble, rerun_member, run_scenario
from attitude.ensemble._chunks import _compute_chunk, _Setup
from attitude.errors import AttitudeValueError, PropagationError
from attitude.events import RateExceeds
from attitude.potentials import CustomTorque, GravityGradient, HeavyTop, TorqueFree
from attitude.propagate import METHODS, Problem, propagate
from attitude.scenario import load, loads
from orbit import _rk

ROOT = Path(__file__).resolve().parents[1]
I_PAPER = np.array([1.25, 1.0, 0.75])
RTOL = 1e-12


def random_unit(rng, n):
    return qt.normalize(rng.normal(size=(n, 4)))


@pytest.fixture(scope="module")
def gg_case():
    """Sect. 6.2 (gravity gradient, e = 0.2), 13 members (not a multiple of the 4 lanes) of
    mixed difficulty: rates up to 30× the nominal one, so lanes finish at different times and
    take new members while the others run on."""
    sc = load(ROOT / "scenarios/paper_keplerian.toml")
    q0, Q0, _ = C.project_state(sc.q0, sc.Q0)
    rng = np.random.default_rng(17)
    n = 13
    q = qt.multiply(q0, qt.from_rotation_vector(0.05 * rng.normal(size=(n, 3))))
    g0 = C.body_angular_momentum(q0, Q0)
    scale = np.where(np.arange(n) % 5 == 2, 30.0, 1.0)[:, None]
    g = g0 * scale * (1.0 + 0.1 * rng.normal(size=(n, 3)))
    Q = C.momenta_from_body_angular_momentum(q, g)
    t = np.linspace(0.0, 1500.0, 7)
    return sc, q, Q, t


def single_taylor(body, potential, y0, t, rtol=RTOL, atol=RTOL):
    """The runner of propagate(method="taylor") on the exact initial state ``y0`` (no
    projection) -> (states (m, 8), diagnostics (m, 13), steps)."""
    pot = potential.bind(body)
    params = pot._params(body.inertia)
    problem = Problem(body, pot, params, y0, t, pot._entry_points())
    r = METHODS["taylor"](problem, rtol=rtol, atol=atol)
    assert r.status == 0
    diag = np.empty((t.shape[0], 13))
    _ep.diagnostics(t, r.y, params, diag)
    return r.y, diag, r.stats["n_steps"]


def assert_members_are_single_runs(ds, bodies, pots, t, rtol=RTOL):
    for i in range(ds.sizes["member"]):
        y0 = np.concatenate([ds.q.values[i, 0], ds.Q.values[i, 0]])  # t[0] is an output
        y, diag, steps = single_taylor(bodies[i], pots[i], y0, t, rtol, rtol)
        assert y[:, :4].tobytes() == ds.q.values[i].tobytes(), i
        assert y[:, 4:].tobytes() == ds.Q.values[i].tobytes(), i
        for name, cols in (("omega", slice(0, 3)), ("G", slice(6, 9)), ("energy", 9),
                           ("norm_error", 10), ("qQ", 11), ("potential_energy", 12)):  # fmt: skip
            assert diag[:, cols].tobytes() == ds[name].values[i].tobytes(), (i, name)
        assert steps == int(ds.member_n_steps[i])


# ------------------------------------------------------------------------------------------------
# a member of a batch is its single run, bit for bit
# ------------------------------------------------------------------------------------------------


def test_members_are_single_taylor_runs_bit_for_bit(gg_case):
    sc, q, Q, t = gg_case
    ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, method="taylor", rtol=RTOL,
                            atol=RTOL, chunk_size=6)  # fmt: skip
    n = q.shape[0]
    assert ds.attrs["method"] == "taylor" and ds.attrs["run_status"] == "complete"
    assert int(ds.attrs["taylor_order"]) == 15 and int(ds.attrs["n_rhs"]) == 0
    steps = ds.member_n_steps.values
    assert steps[2] > 5 * steps[0]  # the fast members take many more steps
    assert_members_are_single_runs(ds, [sc.body] * n, [sc.potential] * n, t)
    # propagate(method="taylor") itself, from the states as given (projected there)
    for i in (0, 2):
        one = propagate(sc.body, q[i], Q[i], t, sc.potential, "taylor", RTOL, RTOL)
        np.testing.assert_allclose(ds.q.values[i], one.q.values, rtol=0, atol=1e-13)
        np.testing.assert_allclose(ds.energy.values[i], one.energy.values, rtol=1e-12)
    # and the dop853 ensemble, to the tolerance
    ref = propagate_ensemble(sc.body, q, Q, t, sc.potential, rtol=1e-13, atol=1e-15)
    assert np.max(np.abs(ds.q.values - ref.q.values)) < 1e-10


# Both widths in the default suite, whatever the CPU: the batch integrator at the CPU's own width
# runs in every Taylor ensemble test, but the other width's lane helpers (attitude._core.lanes
# or attitude._core.lanes.module(8)) run nowhere else (~30 s of a fresh cache).
@pytest.mark.parametrize("lanes", [4, 8])
def test_members_are_single_runs_at_every_simd_width(gg_case, lanes, monkeypatch):
    """The batch width follows the CPU (attitude._core.lanes.simd_lanes); whatever it is, each
    member is its single run bit for bit. And method="auto" (the default) runs this batch."""
    from attitude._core import taylor_batch as tb

    sc, q, Q, t = gg_case
    monkeypatch.setenv("ATTITUDE_SIMD_LANES", str(lanes))
    assert tb.batch().LANES == lanes
    ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, rtol=RTOL, atol=RTOL, chunk_size=6)
    assert ds.attrs["method"] == "taylor" and ds.attrs["method_requested"] == "auto"
    n = q.shape[0]
    assert_members_are_single_runs(ds, [sc.body] * n, [sc.potential] * n, t)


def test_per_member_orbits_and_heavy_tops_bit_for_bit(gg_case):
    import orbit

    sc, q, Q, t = gg_case
    orbits = [orbit.KeplerOrbit(7000.0 + 300 * i, 0.05 * i, 0.3 + 0.1 * i, 0.2, 0.1 * i, f0=0.2 * i)
              for i in range(5)]  # fmt: skip
    pots = [GravityGradient(o) for o in orbits]
    ds = propagate_ensemble(sc.body, q[:5], Q[:5], t, pots, method="taylor", rtol=RTOL, atol=RTOL)
    assert_members_are_single_runs(ds, [sc.body] * 5, pots, t)
    assert np.max(np.abs(ds.q.values[0, -1] - ds.q.values[1, -1])) > 1e-3

    rng = np.random.default_rng(3)
    n = 6
    q0 = random_unit(rng, n)
    Q0 = C.momenta_from_angular_velocity(q0, rng.normal(size=(n, 3)), I_PAPER)
    inertia = I_PAPER * (1.0 + 0.05 * rng.normal(size=(n, 3)))
    tops = [HeavyTop(w, [1.0, 0.0, 0.2]) for w in rng.uniform(0.1, 1.0, n)]
    th = np.linspace(0.0, 50.0, 11)
    ds = propagate_ensemble(inertia, q0, Q0, th, tops, method="taylor", rtol=RTOL, atol=RTOL)
    assert_members_are_single_runs(ds, [RigidBody(row) for row in inertia], tops, th)


# ------------------------------------------------------------------------------------------------
# conservation laws (the closed form of symmetric tops: tests/test_ensemble.py, both methods)
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("pot", [TorqueFree(), HeavyTop(0.5, [1.0, 0.0, 0.2])])
def test_conserves_like_the_dop853_ensemble(pot):
    """H, |q|, q·Q (and G, resp. G3 of the heavy top) drift no more than with dop853 at the same
    tolerance (a factor 3 of slack, or round-off)."""
    rng = np.random.default_rng(5)
    n = 9
    q0 = random_unit(rng, n)
    Q0 = C.momenta_from_angular_velocity(q0, rng.normal(size=(n, 3)), I_PAPER)
    t = np.linspace(0.0, 300.0, 301)
    kw = {"rtol": 1e-12, "atol": 1e-14}
    tay = propagate_ensemble(I_PAPER, q0, Q0, t, pot, method="taylor", **kw).attrs
    dop = propagate_ensemble(I_PAPER, q0, Q0, t, pot, method="dop853", **kw).attrs
    keys = ["max_rel_energy_error", "max_abs_norm_error", "max_abs_qQ"]
    keys.append("max_rel_G_error" if isinstance(pot, TorqueFree) else "max_rel_Gz_error")
    for key in keys:
        assert tay[key] <= max(3 * dop[key], 1e-13), (key, tay[key], dop[key])
    assert tay["max_abs_qQ"] < 1e-12 and tay["max_rel_energy_error"] < 1e-11


# ------------------------------------------------------------------------------------------------
# contracts shared with the dop853 ensemble
# ------------------------------------------------------------------------------------------------


def test_independent_of_chunks_threads_and_driver(gg_case):
    sc, q, Q, t = gg_case
    kw = {"method": "taylor", "rtol": 1e-10, "atol": 1e-10}
    ref = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=q.shape[0], threads=1,
                             **kw)  # fmt: skip
    for extra in ({"chunk_size": 1}, {"chunk_size": 5, "threads": 2}, {"threads": 2}):
        ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, **extra, **kw)
        for v in ("q", "Q", "energy", "member_n_steps"):
            assert ds[v].values.tobytes() == ref[v].values.tobytes(), (extra, v)
    setup = _Setup(t, 1e-10, 1e-10, np.inf, 10**8, method="taylor")
    params = np.tile(sc.potential.bind(sc.body)._params(sc.body.inertia), (q.shape[0], 1))
    y0 = np.concatenate([ref.q.values[:, 0], ref.Q.values[:, 0]], axis=1)
    out = _compute_chunk(setup, params, y0, parallel=False)  # the serial driver (Dask workers)
    assert out["y"][:, :, :4].tobytes() == ref.q.values.tobytes()
    assert out["diag"][:, :, 9].tobytes() == ref.energy.values.tobytes()
    one = rerun_member(ref, 7, sc.potential)  # the replay re-runs with the ensemble's method
    assert one.q.values.tobytes() == ref.q.values[7].tobytes()


def test_failing_member_is_named_and_done_chunks_are_kept(tmp_path):
    n = 12
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    w = np.zeros((n, 3))
    w[:, 2] = 0.1
    w[7] = [20.0, 1.0, 30.0]  # ~400 steps where the others take 2
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    t = np.linspace(0.0, 10.0, 3)
    kw = {"method": "taylor", "rtol": 1e-10, "atol": 1e-10, "max_steps": 100, "chunk_size": 5}
    with pytest.raises(PropagationError, match=r"member\(s\) 7 failed \(1 of 12\)") as exc:
        propagate_ensemble(I_PAPER, q0, Q0, t, path=tmp_path / "fail.nc", **kw)
    assert "maximum number of steps" in str(exc.value)
    exc.value.partial.close()
    with pytest.raises(PropagationError) as exc:
        propagate_ensemble(I_PAPER, q0, Q0, t, **kw)
    # every member is kept (docs/ensemble.md): the failed one marked, NaN after its failure
    part = exc.value.partial
    st = part.member_status.values
    assert part.sizes["member"] == n and st[7] == _rk.TOO_MANY_STEPS
    assert np.all(np.delete(st, 7) == _rk.SUCCESS)
    q = part.q.values
    assert np.all(np.isfinite(np.delete(q, 7, axis=0)))
    assert np.all(np.isfinite(q[7, 0])) and np.all(np.isnan(q[7, -1]))
    assert np.all(np.isnan(part.energy.values[7, -1]))
    assert 0.0 < exc.value.time < 10.0


def test_bad_input_names_the_parameter():
    import orbit

    rng = np.random.default_rng(6)
    q = random_unit(rng, 4)
    Q = C.momenta_from_angular_velocity(q, rng.normal(size=(4, 3)), I_PAPER)
    t = np.linspace(0.0, 10.0, 3)
    o = orbit.KeplerOrbit(7000.0, 0.01, 0.5, 0.2, 0.1)
    j2 = orbit.SecularJ2Orbit(7000.0, 0.01, 0.5, 0.2, 0.1)
    cases = [
        ({"events": [RateExceeds(1.0)]}, TorqueFree(), "^events: method='taylor'"),
        ({}, CustomTorque(lambda q, t: (0.0, 0.0, 0.1)), "^method: 'taylor' expands"),
        ({}, GravityGradient(j2), "^method: 'taylor' restarts the orbit"),
        ({}, [GravityGradient(o)] * 3 + [GravityGradient(j2)], "^method: 'taylor' restarts"),
        ({"rtol": 1e-17}, TorqueFree(), "^rtol"),
    ]
    for kw, pot, match in cases:
        with pytest.raises(AttitudeValueError, match=match):
            propagate_ensemble(I_PAPER, q, Q, t, pot, method="taylor", **kw)
    # dop853 runs members with orbits of different types (parameter rows of different sizes)
    pots = [GravityGradient(o)] * 3 + [GravityGradient(j2)]
    ds = propagate_ensemble(I_PAPER, q, Q, t, pots, rtol=1e-12, atol=1e-14)
    one = propagate(I_PAPER, q[3], Q[3], t, pots[3], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ds.q.values[3], one.q.values, rtol=0, atol=1e-13)


def test_scenario_ensemble_with_method_taylor(tmp_path):
    text = (ROOT / "scenarios/ensemble_paper_keplerian.toml").read_text()
    with pytest.raises(AttitudeValueError, match=r"^events: method='taylor'"):
        run_scenario(loads(text), tmp_path / "no.nc", method="taylor")
    assert not (tmp_path / "no.nc").exists()
    text = text.split("[events.")[0].split("[output]")[0]  # no events
    text = text.replace('method = "dop853"', 'method = "taylor"').replace("size = 1000", "size = 9")
    text = text.replace("stop = 5828.5", "stop = 1000.0").replace("count = 101", "count = 11")
    info = run_scenario(loads(text), tmp_path / "e.nc")
    assert info["method"] == "taylor" and info["run_status"] == "complete"
    assert int(info["ensemble_size"]) == 9


@pytest.mark.slow  # compiles the kernel afresh (~10 s): the cache holds no assembly to inspect
def test_batch_kernel_is_simd_code():
    """The lane-wise recurrences compile to packed FMAs (4 doubles per instruction)."""
    import llvmlite.binding as llb
    import numba

    from attitude._core import taylor_batch as tb
    from orbit._shared_jit import JIT_DISABLED, slp_vectorized

    features = llb.get_host_cpu_features()
    if JIT_DISABLED or not (features.get("avx2") and features.get("fma")):
        pytest.skip("needs a CPU with AVX2 and FMA (x86-64)")
    from orbit._shared_jit import jit

    # as the package builds it (a Kernel: compiled code calls its wrapper-less copy), uncached
    fresh = slp_vectorized(jit(cache=False)(tb.taylor_coefficients_lanes.py_func))
    inner = getattr(fresh, "dispatcher", fresh)

    @numba.njit
    def caller(cf, p, kind, cst):  # a compiled caller, as the batch integrator
        fresh(cf, p, kind, cst)

    cf = np.ones((tb.WORK_ROWS, tb.COL.SIZE, tb.LANES))
    caller(cf, 10, 2, np.ones((tb.CONST.SIZE, tb.LANES)))
    fresh(cf, 10, 2, np.ones((tb.CONST.SIZE, tb.LANES)))
    import re

    for d in {id(fresh): fresh, id(inner): inner}.values():  # both copies are SIMD code
        asm = d.inspect_asm(d.signatures[0])
        packed = re.findall(r"\bvfn?m(?:add|sub)\d{3}pd\s+[^\n]*%[yz]mm", asm)
        scalar = re.findall(r"\bvfn?m(?:add|sub)\d{3}sd\b", asm)
        assert len(packed) > 50 and len(packed) > 5 * len(scalar), (len(packed), len(scalar))


def test_same_bits_with_jit_disabled():
    """The kernels are valid Python (fma exact in rational arithmetic): same members, same bits."""
    import json
    import os
    import subprocess
    import sys

    q = np.tile([1.0, 0, 0, 0], (5, 1))
    Q = np.array([[0, 0.2, 0.1, 0.3], [0, 0.1, 0.1, 0.3], [0, 0.3, -0.1, 0.3], [0, 0.2, 0.2, 0.2],
                  [0, 0.1, 0.3, 0.1]])  # fmt: skip
    args = "[1.25, 1.0, 0.75], q, Q, [0.0, 1.0, 2.0], HeavyTop(0.5, [1, 0, 0]), method='taylor'"
    code = (
        "import json, numpy as np\n"
        "from attitude.ensemble import propagate_ensemble\n"
        "from attitude.potentials import HeavyTop\n"
        f"q, Q = np.array({q.tolist()}), np.array({Q.tolist()})\n"
        f"ds = propagate_ensemble({args}, rtol=1e-6, atol=1e-6, chunk_size=2)\n"
        "print(json.dumps(ds.q.values.tolist()))\n"
    )
    env = {**os.environ, "ATTITUDE_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr
    ds = propagate_ensemble(I_PAPER, q, Q, [0.0, 1.0, 2.0], HeavyTop(0.5, [1, 0, 0]),
                            method="taylor", rtol=1e-6, atol=1e-6)  # fmt: skip
    assert np.array(json.loads(out.stdout)).tobytes() == ds.q.values.tobytes()
