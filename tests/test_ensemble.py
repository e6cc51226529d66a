"""Ensembles (attitude.ensemble) against closed forms, single runs, and their own contracts.

Truth: uniform spin about a principal axis and the symmetric top (closed forms), a constant
body torque (closed form), the orbit module for r and f, conservation laws, and percentiles of
known sets of angles and rates. Contracts: a member's result does not depend on the chunk
size, the thread count, or whether it ran on a Dask cluster (bit for bit); memory is bounded by
one chunk when streaming; bad input fails before any work; a failing chunk names its members
and keeps the chunks already written.
"""

from __future__ import annotations

import importlib.util
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from attitude import canonical as C
from attitude import io
from attitude import quaternion as qt
from attitude._core import entry_points as _ep
from attitude.body import RigidBody
from attitude.ensemble import (
    Dispersions,
    pointing_error_percentiles,
    propagate_ensemble,
    rate_percentiles,
    run_scenario,
)
from attitude.ensemble._chunks import _compute_chunk, _Setup
from attitude.errors import AttitudeTypeError, AttitudeValueError, PropagationError
from attitude.potentials import CustomTorque, GravityGradient, HeavyTop, TorqueFree
from attitude.propagate import propagate
from attitude.scenario import ScenarioError, load, loads
from orbit import _rk

ROOT = Path(__file__).resolve().parents[1]
I_PAPER = np.array([1.25, 1.0, 0.75])


def random_unit(rng, n):
    return qt.normalize(rng.normal(size=(n, 4)))


@pytest.fixture(scope="module")
def gg_case():
    """The paper's Sect. 6.2 case with dispersed momenta (12 members, a quarter orbit)."""
    sc = load(ROOT / "scenarios/paper_keplerian.toml")
    q0, Q0, _ = C.project_state(sc.q0, sc.Q0)
    rng = np.random.default_rng(62)
    n = 12
    q = qt.multiply(q0, qt.from_rotation_vector(0.05 * rng.normal(size=(n, 3))))
    g0 = C.body_angular_momentum(q0, Q0)
    g = g0 * (1.0 + 0.1 * rng.normal(size=(n, 3)))
    Q = C.momenta_from_body_angular_momentum(q, g)
    t = np.linspace(0.0, 1500.0, 7)
    return sc, q, Q, t


def same(a: xr.Dataset, b: xr.Dataset) -> bool:
    """Every data variable and the member coordinate identical, bit for bit."""
    if set(a.data_vars) != set(b.data_vars):
        return False
    ok = np.array_equal(a["member"].values, b["member"].values)
    for v in a.data_vars:
        x, y = np.asarray(a[v].values), np.asarray(b[v].values)
        ok &= x.shape == y.shape and x.tobytes() == y.tobytes()
    return bool(ok)


# ------------------------------------------------------------------------------------------------
# physics: closed forms
# ------------------------------------------------------------------------------------------------


def test_uniform_spins_closed_form_per_member():
    """Each member spins about a principal axis: q(t) = q0∘exp(ω t / 2) exactly."""
    rng = np.random.default_rng(1)
    n = 9
    q0 = random_unit(rng, n)
    w = np.zeros((n, 3))
    axes = np.arange(n) % 3
    rates = rng.uniform(0.2, 2.0, n)
    w[np.arange(n), axes] = rates
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    # the intermediate axis is unstable: keep the span short (see test_propagate)
    t = np.linspace(0.0, 8.0, 41)
    ds = propagate_ensemble(I_PAPER, q0, Q0, t, rtol=1e-13, atol=1e-15, chunk_size=4)
    assert ds.sizes == {"member": n, "time": 41, "component": 4, "axis": 3}
    for i in range(n):
        exact = qt.multiply(q0[i], qt.from_rotation_vector(np.outer(t, w[i])))
        assert np.max(qt.angle_between(ds.q.values[i], exact)) < 1e-11
        np.testing.assert_allclose(ds.omega.values[i], np.broadcast_to(w[i], (41, 3)), atol=1e-12)
    assert ds.attrs["run_status"] == "complete"
    assert int(ds.attrs["n_steps"]) == int(ds.member_n_steps.sum())
    assert np.all(ds.member_status.values == 0)


@pytest.mark.parametrize(
    ("method", "atol"), [("dop853", 1e-15), ("taylor", 1e-13)], ids=["dop853", "taylor"]
)
def test_per_member_inertia_symmetric_tops(method, atol):
    """I1 = I2 per member, different bodies: q(t) = exp_S(Ĝ|G|t/I1)∘q0∘exp_B(e3 ν t)."""
    rng = np.random.default_rng(2)
    n = 6
    i1 = rng.uniform(1.5, 2.5, n)
    i3 = i1 * rng.uniform(0.3, 1.6, n)
    inertia = np.stack([i1, i1, i3], axis=1)
    q0 = random_unit(rng, n)
    g0 = rng.normal(size=(n, 3))
    Q0 = C.momenta_from_body_angular_momentum(q0, g0)
    t = np.linspace(0.0, 50.0, 101)
    kw = {"method": method, "rtol": 1e-13, "atol": atol, "chunk_size": 4}
    ds = propagate_ensemble(inertia, q0, Q0, t, **kw)
    np.testing.assert_array_equal(ds.inertia.values, inertia)
    for i in range(n):
        G = qt.rotate(q0[i], g0[i])
        nu = g0[i, 2] * (1 / i3[i] - 1 / i1[i])
        prec = qt.from_rotation_vector(np.outer(t, G / i1[i]))
        spin = qt.from_rotation_vector(np.outer(t, [0.0, 0.0, nu]))
        exact = qt.multiply(qt.multiply(prec, q0[i]), spin)
        assert np.max(qt.angle_between(ds.q.values[i], exact)) < 1e-10
    # a list of RigidBody is the same input
    bodies = [RigidBody(row) for row in inertia]
    ds2 = propagate_ensemble(bodies, q0, Q0, t, **kw)
    assert same(ds, ds2)


def test_heavy_tops_per_member_weights_conserve_energy_and_gz():
    rng = np.random.default_rng(3)
    n = 5
    q0 = random_unit(rng, n)
    Q0 = C.momenta_from_angular_velocity(q0, rng.normal(size=(n, 3)), I_PAPER)
    weights = rng.uniform(0.1, 1.0, n)
    pots = [HeavyTop(w, [1.0, 0.0, 0.2]) for w in weights]
    t = np.linspace(0.0, 200.0, 401)
    ds = propagate_ensemble(I_PAPER, q0, Q0, t, pots, rtol=1e-14, atol=1e-16)
    E = ds.energy.values
    scale = np.max(np.abs(ds.potential_energy.values), axis=1) + np.abs(E[:, 0])
    assert np.max(np.abs(E - E[:, :1]) / scale[:, None]) < 1e-11
    G3 = ds.G.values[:, :, 2]
    assert np.max(np.abs(G3 - G3[:, :1])) / np.max(np.abs(ds.G.values)) < 1e-11
    # the potential energy is each member's own weight: U = W (q c q̃)·s3
    for i in (0, n - 1):
        U = HeavyTop(weights[i], [1.0, 0.0, 0.2]).value(ds.q.values[i])
        np.testing.assert_allclose(ds.potential_energy.values[i], U, rtol=1e-13, atol=1e-15)
    assert "max_rel_energy_error" in ds.attrs and "max_rel_Gz_error" in ds.attrs


@pytest.mark.slow
def test_user_torque_in_the_parallel_loop_closed_form():
    """A constant body torque about b3 from a spin about b3: θ(t) = ω0 t + τ t²/(2 I3)."""
    tau3 = 0.3

    def torque(q, t):
        return (0.0, 0.0, 0.3)

    rng = np.random.default_rng(4)
    n = 6
    q0 = random_unit(rng, n)
    w0 = np.zeros((n, 3))
    w0[:, 2] = rng.uniform(-1.0, 1.0, n)
    Q0 = C.momenta_from_angular_velocity(q0, w0, I_PAPER)
    t = np.linspace(0.0, 5.0, 26)
    ds = propagate_ensemble(I_PAPER, q0, Q0, t, CustomTorque(torque), rtol=1e-13, atol=1e-15)
    for i in range(n):
        theta = w0[i, 2] * t + tau3 * t**2 / (2 * I_PAPER[2])
        exact = qt.multiply(q0[i], qt.from_rotation_vector(np.outer(theta, [0.0, 0.0, 1.0])))
        assert np.max(qt.angle_between(ds.q.values[i], exact)) < 1e-11


# ------------------------------------------------------------------------------------------------
# the same code path as propagate; reproducibility
# ------------------------------------------------------------------------------------------------


def test_members_are_single_runs(gg_case):
    """Each member is the compiled single-run loop from its own projected state, bit for bit,
    and agrees with attitude.propagate."""
    sc, q, Q, t = gg_case
    ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, method="dop853", chunk_size=5)
    params = sc.potential.bind(sc.body)._params(sc.body.inertia)
    for i in range(q.shape[0]):
        y0 = np.concatenate([ds.q.values[i, 0], ds.Q.values[i, 0]])  # t[0] is an output
        work, tstate, counters = _rk.new_state(8)
        y = np.empty((t.shape[0], 8))
        status, k = _ep.dop853_canonical(
            params, y0, t[0], t, y, work, tstate, counters, 1e-10, 1e-12, t[-1], np.inf, 10**8
        )
        assert status == 0 and k == t.shape[0]
        assert y.tobytes() == np.concatenate([ds.q.values[i], ds.Q.values[i]], 1).tobytes()
        assert int(counters[0]) == int(ds.member_n_steps[i])
    for i in (0, 7):
        single = propagate(sc.body, q[i], Q[i], t, sc.potential, method="dop853")
        np.testing.assert_allclose(ds.q.values[i], single.q.values, rtol=0, atol=1e-13)
        np.testing.assert_allclose(
            ds.energy.values[i], single.energy.values, rtol=1e-12, atol=1e-16
        )
    # the orbit variables come from the orbit module
    orbit = sc.potential.orbit
    np.testing.assert_array_equal(ds.r.values, orbit.radius(t))
    np.testing.assert_array_equal(ds.f.values, orbit.true_anomaly(t))


def test_result_independent_of_chunks_threads_and_driver(gg_case):
    sc, q, Q, t = gg_case
    ref = propagate_ensemble(sc.body, q, Q, t, sc.potential, method="dop853",
                             chunk_size=q.shape[0], threads=1)  # fmt: skip
    for kw in ({"chunk_size": 1}, {"chunk_size": 5, "threads": 2}, {"threads": 2}):
        ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, method="dop853", **kw)
        assert same(ref, ds), kw
    # the serial driver (what Dask workers run)
    setup = _Setup(t, 1e-10, 1e-12, np.inf, 10**8)
    params = np.tile(sc.potential.bind(sc.body)._params(sc.body.inertia), (q.shape[0], 1))
    y0 = np.concatenate([ref.q.values[:, 0], ref.Q.values[:, 0]], axis=1)
    out = _compute_chunk(setup, params, y0, parallel=False)
    assert out["y"][:, :, :4].tobytes() == ref.q.values.tobytes()
    assert out["diag"][:, :, 9].tobytes() == ref.energy.values.tobytes()
    # a member alone gives the same bits as inside the ensemble
    one = propagate_ensemble(sc.body, q[5:6], Q[5:6], t, sc.potential, method="dop853")
    assert one.q.values.tobytes() == ref.q.values[5:6].tobytes()


def test_per_member_orbits(gg_case):
    from orbit.keplerorbit import KeplerOrbit

    sc, q, Q, t = gg_case
    n = 4
    orbits = [
        KeplerOrbit(7000.0 + 300 * i, 0.05 * i, 0.3 + 0.1 * i, 0.2, 0.1 * i, f0=0.2 * i)
        for i in range(n)
    ]
    pots = [GravityGradient(o) for o in orbits]
    ds = propagate_ensemble(sc.body, q[:n], Q[:n], t, pots, chunk_size=3)
    assert ds.r.dims == ("member", "time") and ds.p.dims == ("member", "time", "component")
    for i in range(n):
        np.testing.assert_array_equal(ds.r.values[i], orbits[i].radius(t))
        np.testing.assert_array_equal(ds.f.values[i], orbits[i].true_anomaly(t))
        single = propagate(sc.body, q[i], Q[i], t, pots[i])
        np.testing.assert_allclose(ds.q.values[i], single.q.values, rtol=0, atol=1e-13)
    # a different orbit gives a different motion (the rows really carry the orbits)
    assert np.max(np.abs(ds.q.values[0, -1] - ds.q.values[1, -1])) > 1e-3


# ------------------------------------------------------------------------------------------------
# streaming, memory, failure
# ------------------------------------------------------------------------------------------------


def test_streamed_file_equals_in_memory(gg_case, tmp_path):
    sc, q, Q, t = gg_case
    mem = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=5)
    path = tmp_path / "ens.nc"
    lazy = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=5, path=path)
    try:
        assert same(mem, lazy)
        assert lazy.attrs["run_status"] == "complete"
        assert int(lazy.attrs["n_steps"]) == int(mem.attrs["n_steps"])
    finally:
        lazy.close()
    back = io.read(path)
    assert same(mem, back)
    assert back.q.attrs["units"] == "1" and back.omega.attrs["units"] == "rad s^-1"
    assert not list(tmp_path.glob(".*.tmp"))


def _streamed_peak(n, tmp_path):
    rng = np.random.default_rng(5)
    q0 = random_unit(rng, n)
    Q0 = C.momenta_from_angular_velocity(q0, rng.normal(size=(n, 3)), I_PAPER)
    t = np.linspace(0.0, 5.0, 400)
    pot = HeavyTop(0.5, [1.0, 0.0, 0.0])
    path = tmp_path / f"m{n}.nc"
    tracemalloc.start()
    try:
        ds = propagate_ensemble(I_PAPER, q0, Q0, t, pot, chunk_size=40, path=path)
        ds.close()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak, path.stat().st_size


def test_streaming_memory_is_one_chunk(tmp_path):
    """Peak traced memory with 8x the members stays that of a chunk (40 members x 400 samples
    x 21 values x 8 bytes = 2.7 MB), while the result is 8x larger."""
    _streamed_peak(40, tmp_path)  # warm-up (compilation, imports)
    small, size_small = _streamed_peak(200, tmp_path)
    large, size_large = _streamed_peak(1600, tmp_path)
    chunk_bytes = 40 * 400 * 21 * 8
    result_large = 1600 * 400 * 21 * 8
    assert size_large > 4 * size_small
    assert large < small + chunk_bytes  # not growing with N
    assert large < result_large / 4


def test_failing_member_is_named_and_done_chunks_are_kept(tmp_path):
    n = 12
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    w = np.zeros((n, 3))
    w[:, 2] = 0.1
    w[7, 2] = 30.0  # needs far more steps than the others
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    t = np.linspace(0.0, 10.0, 3)
    path = tmp_path / "fail.nc"
    with pytest.raises(PropagationError, match=r"member\(s\) 7 failed") as exc:
        propagate_ensemble(I_PAPER, q0, Q0, t, max_steps=100, chunk_size=5, path=path)
    assert "maximum number of steps" in str(exc.value)
    assert "all 12 are in" in str(exc.value)
    back = io.read(path)
    # every member is kept (issue 12): the failed one marked, the later chunks computed
    np.testing.assert_array_equal(back.member.values, np.arange(n))
    assert back.member_status.values[7] != 0 and np.count_nonzero(back.member_status.values) == 1
    assert back.attrs["run_status"].startswith("failed: member(s) 7")
    exc.value.partial.close()
    # in memory: .partial holds every member
    with pytest.raises(PropagationError) as exc:
        propagate_ensemble(I_PAPER, q0, Q0, t, max_steps=100, chunk_size=5)
    assert exc.value.partial.sizes["member"] == n
    # a failure in the only chunk still writes the other members
    with pytest.raises(PropagationError):
        propagate_ensemble(I_PAPER, q0, Q0, t, max_steps=100, path=tmp_path / "one.nc")
    assert io.read(tmp_path / "one.nc").sizes["member"] == n
    assert not list(tmp_path.glob(".*.tmp"))


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------


def test_bad_input_before_any_work(tmp_path):
    rng = np.random.default_rng(6)
    q = random_unit(rng, 5)
    Q = C.momenta_from_angular_velocity(q, rng.normal(size=(5, 3)), I_PAPER)
    t = np.linspace(0.0, 1.0, 3)
    cases = [
        ((I_PAPER, q, Q[:4], t), {}, AttitudeValueError, "q0 has 5 members.*Q0 has 4"),
        ((I_PAPER, q[:0], Q[:0], t), {}, AttitudeValueError, "empty.*N = 0"),
        ((I_PAPER, q[0], Q[0], t), {}, AttitudeValueError, "ensemble size N is unknown"),
        ((I_PAPER, q[:, :3], Q, t), {}, AttitudeValueError, r"q0: expected shape \(\.\.\., 4\)"),
        ((np.ones((4, 3)), q, Q, t), {}, AttitudeValueError, "body: 4 rows of inertia for 5"),
        (([1.0, 1.0, 3.0], q, Q, t), {}, AttitudeValueError, "triangle"),
        ((np.tile([1.0, 1.0, 3.0], (5, 1)), q, Q, t), {}, AttitudeValueError, "member 0"),
        ((I_PAPER, q * 1.1, Q, t), {}, AttitudeValueError, "q0: member 0: .*is not 1"),
        ((I_PAPER, q, Q, t, [TorqueFree()] * 4), {}, AttitudeValueError, "4 potentials for 5"),
        (
            (I_PAPER, q, Q, t, [TorqueFree()] * 4 + [HeavyTop(1.0, [1, 0, 0])]),
            {},
            AttitudeValueError,
            "same kind",
        ),
        ((I_PAPER, q, Q, t), {"method": "nosquish"}, AttitudeValueError, "'dop853' or 'taylor'"),
        ((I_PAPER, q, Q, t), {"chunk_size": 0}, AttitudeValueError, "chunk_size"),
        ((I_PAPER, q, Q, t), {"rtol": -1.0}, AttitudeValueError, "rtol"),
        ((I_PAPER, q, Q, t), {"client": object()}, AttitudeTypeError, "client"),
    ]
    bad_q = q.copy()
    bad_q[3] *= 1.01
    cases.append(((I_PAPER, bad_q, Q, t), {}, AttitudeValueError, "member 3"))
    for args, kw, exc, match in cases:
        if "client" in kw:
            import distributed  # noqa: F401 - test extra
        with pytest.raises(exc, match=match):
            propagate_ensemble(*args, path=tmp_path / "x.nc", **kw)
        assert not (tmp_path / "x.nc").exists()
    assert not list(tmp_path.iterdir())


def test_unanswered_scheduler_fails_fast_and_writes_nothing(tmp_path, monkeypatch):
    """An address nobody answers: Dask's own connection timeout is the user's
    ``scheduler_timeout`` (recorded on the way in, so "fast" is Dask's contract, not a clock
    reading here), its failure becomes one clear error, and nothing is written."""
    import socket

    import distributed

    calls = []

    class RecordingClient(distributed.Client):
        def __init__(self, *args, **kwargs):
            calls.append(kwargs.get("timeout"))
            try:
                super().__init__(*args, **kwargs)
            except BaseException as exc:
                calls.append(type(exc))
                raise

    monkeypatch.setattr(distributed, "Client", RecordingClient)
    with socket.socket() as s:  # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    Q = np.zeros((3, 4))
    with pytest.raises(AttitudeValueError, match=r"no Dask scheduler answered.*within 1 s"):
        propagate_ensemble(
            I_PAPER,
            q,
            Q,
            [0.0, 1.0],
            client=f"tcp://127.0.0.1:{port}",
            scheduler_timeout=1.0,
            path=tmp_path / "x.nc",
        )
    # one connection attempt, bounded by the given timeout, that Dask itself gave up
    assert calls[0] == 1.0 and len(calls) == 2 and issubclass(calls[1], Exception), calls
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------------------------------
# Dask
# ------------------------------------------------------------------------------------------------


def test_dask_local_cluster_equals_local_run_bit_for_bit(gg_case, tmp_path):
    import distributed  # noqa: F401 - test extra
    from distributed import Client, LocalCluster

    sc, q, Q, t = gg_case
    local = tmp_path / "local.nc"
    propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=5, path=local).close()
    # compile/cache the workers' serial driver here, so the workers load it from disk
    setup = _Setup(t, 1e-10, 1e-12, np.inf, 10**8)
    params = np.tile(sc.potential.bind(sc.body)._params(sc.body.inertia), (1, 1))
    _compute_chunk(setup, params, np.concatenate([q[0], Q[0]])[None], parallel=False)
    remote = tmp_path / "dask.nc"
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
        Client(cluster) as client,
    ):
        ds = propagate_ensemble(
            sc.body, q, Q, t, sc.potential, chunk_size=5, client=client, path=remote
        )
        try:
            assert ds.q.chunks is not None  # assembled lazily with dask
            assert ds.attrs["execution"] == "dask"
        finally:
            ds.close()
        # without a path: in memory, same bits
        mem = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=4, client=client)
        # lazy: a dask graph of chunk tasks, written by to_netcdf on the cluster
        lazy_path = tmp_path / "lazy.nc"
        propagate_ensemble(
            sc.body, q, Q, t, sc.potential, chunk_size=6, client=client, lazy=True, path=lazy_path
        ).close()
    a, b = io.read(local), io.read(remote)
    assert same(a, b)
    assert same(a, mem)
    assert same(a, io.read(lazy_path))


def test_lazy_result_is_a_dask_graph_with_the_same_bits(gg_case, tmp_path):
    import dask  # noqa: F401 - test extra

    sc, q, Q, t = gg_case
    ref = propagate_ensemble(sc.body, q, Q, t, sc.potential)
    lazy = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=5, lazy=True)
    assert lazy.q.chunks[0] == (5, 5, 2)  # nothing computed yet: one task per chunk
    assert same(ref, lazy.compute())
    # a failing member raises when computed, and lazy writing keeps nothing
    n = 6
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    w = np.zeros((n, 3))
    w[:, 2] = 0.1
    w[4, 2] = 30.0
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    path = tmp_path / "lazy.nc"
    with pytest.raises(PropagationError, match=r"member\(s\) 4 failed"):
        propagate_ensemble(
            I_PAPER, q0, Q0, [0.0, 10.0], max_steps=100, chunk_size=3, lazy=True, path=path
        )
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------------------------------------
# statistics
# ------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def spun_about_b3():
    """Members q_i(t) = qa∘exp((α_i + ω t) b3 / 2): attitude errors |α_i| from the nominal."""
    rng = np.random.default_rng(7)
    qa = random_unit(rng, 1)[0]
    alpha = np.concatenate([[0.0], rng.uniform(0.01, 0.5, 10)])
    alpha = np.concatenate([alpha, -alpha[1:]])  # symmetric: the mean attitude is the nominal
    n = alpha.size
    q0 = qt.multiply(qa, qt.from_rotation_vector(np.outer(alpha, [0.0, 0.0, 1.0])))
    w = np.zeros((n, 3))
    w[:, 2] = 0.7
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    t = np.linspace(0.0, 20.0, 11)
    ds = propagate_ensemble(I_PAPER, q0, Q0, t, rtol=1e-13, atol=1e-15)
    nominal = propagate(I_PAPER, qa, Q0[0], t, rtol=1e-13, atol=1e-15)
    return ds, nominal, np.abs(alpha)


def test_pointing_error_percentiles_against_known_angles(spun_about_b3):
    ds, nominal, err = spun_about_b3
    p = [0, 5, 50, 90, 100]
    want = np.percentile(err, p)
    for ref in ("mean", 0, nominal, nominal.q.values):
        got = pointing_error_percentiles(ds, reference=ref, percentiles=p)
        assert got.dims == ("percentile", "time")
        np.testing.assert_allclose(got.values, np.broadcast_to(want[:, None], got.shape), atol=1e-9)
    deg = pointing_error_percentiles(ds, 0, p, degrees=True)
    np.testing.assert_allclose(deg.values[:, 3], np.degrees(want), atol=1e-7)
    assert deg.attrs["units"] == "deg"
    # a boresight along the spin axis b3 does not move; one along b1 moves by |α|
    b3 = pointing_error_percentiles(ds, 0, p, axis=[0.0, 0.0, 2.0])
    assert np.max(b3.values) < 1e-9
    b1 = pointing_error_percentiles(ds, 0, p, axis=[1.0, 0.0, 0.0])
    np.testing.assert_allclose(b1.values, np.broadcast_to(want[:, None], b1.shape), atol=1e-9)


def test_rate_percentiles_against_known_rates():
    rng = np.random.default_rng(8)
    n = 15
    q0 = random_unit(rng, n)
    rates = rng.uniform(0.1, 2.0, n)
    w = np.zeros((n, 3))
    w[:, 0] = rates  # the major axis: stable
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    t = np.linspace(0.0, 10.0, 6)
    ds = propagate_ensemble(I_PAPER, q0, Q0, t, rtol=1e-13, atol=1e-15)
    p = (10, 50, 95)
    got = rate_percentiles(ds, p)
    np.testing.assert_allclose(
        got.values, np.percentile(rates, p)[:, None] * np.ones(6), rtol=1e-11
    )
    assert got.attrs["units"] == ds.omega.attrs["units"]
    comp = rate_percentiles(ds, p, norm=False)
    assert comp.dims == ("percentile", "time", "axis")
    np.testing.assert_allclose(comp.values[:, :, 0], got.values, rtol=1e-11)
    np.testing.assert_allclose(comp.values[:, :, 1:], 0.0, atol=1e-11)


def test_statistics_default_percentiles(spun_about_b3):
    """Called without ``percentiles``, the three statistics give the 5th, 50th and 95th
    percentiles (the documented default), each np.percentile over the members."""
    from attitude.ensemble import event_time_percentiles

    want_p = [5.0, 50.0, 95.0]
    ds, _, err = spun_about_b3
    got = pointing_error_percentiles(ds)  # no reference_q stored: from the mean attitude
    np.testing.assert_array_equal(got["percentile"].values, want_p)
    want = np.percentile(err, want_p)
    np.testing.assert_allclose(got.values, np.broadcast_to(want[:, None], got.shape), atol=1e-9)

    rng = np.random.default_rng(9)
    n = 9
    rates = rng.uniform(0.1, 2.0, n)
    w = np.zeros((n, 3))
    w[:, 0] = rates  # about the major axis: |ω| constant
    q0 = random_unit(rng, n)
    spins = propagate_ensemble(
        I_PAPER, q0, C.momenta_from_angular_velocity(q0, w, I_PAPER), [0.0, 1.0], rtol=1e-13
    )
    got = rate_percentiles(spins)
    np.testing.assert_array_equal(got["percentile"].values, want_p)
    np.testing.assert_allclose(
        got.values, np.percentile(rates, want_p)[:, None] * [1, 1], rtol=1e-11
    )

    first = rng.uniform(0.0, 100.0, (n, 2))
    first[[1, 4], 1] = np.nan  # two members without the second event
    events = xr.Dataset(
        {
            "event_first_time": (("member", "detector"), first, {"units": "s"}),
            "event_count": (("member", "detector"), np.isfinite(first).astype(np.int64)),
        },
        coords={"member": np.arange(n), "detector": [0, 1]},
    )
    got = event_time_percentiles(events)
    np.testing.assert_array_equal(got["percentile"].values, want_p)
    np.testing.assert_array_equal(
        got["first_time"].values[:, 0], np.percentile(first[:, 0], want_p)
    )
    np.testing.assert_array_equal(
        got["first_time"].values[:, 1], np.nanpercentile(first[:, 1], want_p)
    )


def test_statistics_on_a_lazy_dask_file(spun_about_b3, tmp_path):
    import dask  # noqa: F401 - test extra

    ds, _, err = spun_about_b3
    path = tmp_path / "s.nc"
    q0 = ds.q.values[:, 0]
    Q0 = ds.Q.values[:, 0]
    lazy = propagate_ensemble(I_PAPER, q0, Q0, ds.time.values, path=path, rtol=1e-13, atol=1e-15)
    try:
        lazy = lazy.chunk({"member": 5})
        got = pointing_error_percentiles(lazy, "mean", (50,))
        np.testing.assert_allclose(got.values[0], np.percentile(err, 50), atol=1e-9)
    finally:
        lazy.close()


def test_statistics_bad_input(spun_about_b3):
    ds, nominal, _ = spun_about_b3
    with pytest.raises(AttitudeValueError, match="percentiles"):
        pointing_error_percentiles(ds, percentiles=[50, 120])
    with pytest.raises(AttitudeValueError, match="reference"):
        pointing_error_percentiles(ds, reference="median")
    with pytest.raises(AttitudeValueError, match=r"output times"):
        pointing_error_percentiles(ds, reference=nominal.isel(time=slice(0, 5)))
    with pytest.raises(AttitudeValueError, match="ensemble result"):
        rate_percentiles(nominal)
    with pytest.raises(AttitudeTypeError):
        rate_percentiles(ds.q)


# ------------------------------------------------------------------------------------------------
# dispersions and scenarios
# ------------------------------------------------------------------------------------------------


def test_shipped_ensemble_scenario():
    sc = load(ROOT / "scenarios/ensemble_paper_keplerian.toml")
    d = sc.ensemble
    assert d.size == 1000 and d.seed == 2006
    assert d.attitude_error == pytest.approx(np.radians(1.0), rel=1e-15)
    assert d.rate_error == pytest.approx(np.radians(2e-3), rel=1e-15)
    assert d.inertia_error == 0.02


def test_dispersion_draws_do_not_depend_on_size_or_chunks():
    d = Dispersions(size=10**6, seed=11, attitude_error=0.1, rate_error=0.01, inertia_error=0.05)
    q0 = qt.normalize(np.array([0.5, -0.5, 0.1, 0.7]))
    Q0 = C.momenta_from_angular_velocity(q0, [0.1, 0.2, -0.3], I_PAPER)
    full = d.sample(q0, Q0, I_PAPER, 0, 100)
    part = d.sample(q0, Q0, I_PAPER, 37, 60)
    for a, b in zip(full, part, strict=True):
        assert a[37:60].tobytes() == b.tobytes()
    other = Dispersions(size=100, seed=12, attitude_error=0.1)
    assert not np.array_equal(other.sample(q0, Q0, I_PAPER, 0, 5)[0], full[0][:5])


@pytest.mark.parametrize("dist", ["normal", "uniform"])
def test_dispersion_statistics(dist):
    """Sampled errors recovered through the quaternion and canonical modules have the asked
    distribution (moments within sampling error of 40000 members)."""
    n = 40000
    s_att, s_rate, s_in = 0.02, 0.003, 0.04
    d = Dispersions(
        size=n,
        seed=3,
        attitude_error=s_att,
        attitude_distribution=dist,
        rate_error=s_rate,
        rate_distribution=dist,
        inertia_error=s_in,
        inertia_distribution=dist,
    )
    q0 = qt.normalize(np.array([0.3, 0.1, -0.8, 0.5]))
    w0 = np.array([0.05, -0.02, 0.1])
    Q0 = C.momenta_from_angular_velocity(q0, w0, I_PAPER)
    q, Q, inertia = d.sample(q0, Q0, I_PAPER, 0, n)
    dtheta = qt.to_rotation_vector(qt.multiply(qt.conjugate(q0), q))
    eps = inertia / I_PAPER - 1.0
    dw = np.stack([C.angular_velocity(q[i], Q[i], inertia[i]) for i in range(0, n, 8)]) - w0
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.sum(q * Q, axis=1), 0.0, atol=1e-15)
    if dist == "normal":
        sd = (s_att, s_rate, s_in * 0.98658)  # truncated at 3σ: σ sqrt(1 − 6φ(3)/(2Φ(3) − 1))
        assert np.max(np.abs(eps)) <= 3 * s_in * (1 + 1e-12)
        assert np.max(np.abs(eps)) > 2.5 * s_in
    else:
        sd = (s_att / np.sqrt(3), s_rate / np.sqrt(3), s_in / np.sqrt(3))
        assert np.max(np.abs(dtheta)) <= s_att and np.max(np.abs(eps)) <= s_in
    for x, s, m in ((dtheta, sd[0], n), (dw, sd[1], n // 8), (eps, sd[2], n)):
        np.testing.assert_allclose(np.mean(x, axis=0), 0.0, atol=4 * s / np.sqrt(m))
        np.testing.assert_allclose(np.std(x, axis=0), s, rtol=4 * 0.71 / np.sqrt(m) + 1e-3)


_SMALL = """
[body]
inertia = [1.25, 1.0, 0.75]
[initial_state]
form = "body_rates"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.3, 0.1, 0.8]
[time]
stop = 5.0
count = 6
[ensemble]
size = 23
seed = 4
chunk = 6
attitude_error = 2.0
attitude_error_unit = "deg"
rate_error = 0.01
inertia_error = 0.05
"""


def test_run_scenario_streams_the_sampled_members(tmp_path):
    sc = loads(_SMALL)
    info = run_scenario(sc, tmp_path / "e.nc")
    back = io.read(info["path"])
    assert back.sizes["member"] == 23 and info["run_status"] == "complete"
    q, Q, inertia = sc.ensemble.sample(sc.q0, sc.Q0, I_PAPER, 0, 23)
    np.testing.assert_array_equal(back.inertia.values, inertia)
    np.testing.assert_allclose(back.q.values[:, 0], q, rtol=0, atol=3e-16)
    np.testing.assert_allclose(back.Q.values[:, 0], Q, rtol=0, atol=1e-15)
    assert back.attrs["ensemble_seed"] == 4 and back.attrs["scenario"] == "scenario"
    # each sampled member is a plain propagation of its own state and body
    i = 17
    single = propagate(inertia[i], back.q.values[i, 0], back.Q.values[i, 0], sc.t)
    np.testing.assert_allclose(back.q.values[i], single.q.values, atol=1e-13)


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        ("size = 23\n", "ensemble.size"),
        ("size = 23", "ensemble.size"),
        ('attitude_error_unit = "deg"\n', "ensemble.attitude_error"),
        ("inertia_error = 0.05", "ensemble.inertia_error"),
        ("seed = 4", "ensemble.seed"),
        ("chunk = 6", "ensemble.chunk"),
    ],
)
def test_ensemble_table_errors_name_the_key(edit, key):
    replacements = {
        "size = 23\n": "",
        "size = 23": "size = 0",
        'attitude_error_unit = "deg"\n': "",
        "inertia_error = 0.05": "inertia_error = 0.4",
        "seed = 4": "seed = -1",
        "chunk = 6": "chunk = 2.5",
    }
    text = _SMALL.replace(edit, replacements[edit])
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        loads(text)
    with pytest.raises(ScenarioError, match=r"ensemble\.attitude_distribution"):
        loads(_SMALL + 'attitude_distribution = "gaussian"\n')
    with pytest.raises(ScenarioError, match=r"ensemble\.siez"):
        loads(_SMALL + "siez = 3\n")


def test_cli_runs_an_ensemble_and_reports_chunks(tmp_path, capsys, monkeypatch):
    from attitude import ensemble
    from attitude.cli import main

    scen = tmp_path / "small.toml"
    scen.write_text(_SMALL)
    out = tmp_path / "o.nc"
    assert main(["run", str(scen), "-o", str(out), "--progress", "always"]) == 0
    cap = capsys.readouterr()
    assert cap.err.count("ensemble chunk") == 4  # 23 members in chunks of 6
    assert "23/23 members done" in cap.err
    assert "23 members (seed 4)" in cap.out
    assert "max | |q| - 1 |" in cap.out and "max |H - H0|/|H0| (conserved)" in cap.out
    assert io.read(out).sizes["member"] == 23
    assert main(["run", str(scen), "-o", str(tmp_path / "q.nc"), "-q"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "propagate_ensemble" in info
    # what it is: its members, what it stored, its seed, the members that failed (none)
    assert "\nensemble    23 members, output samples, seed 4, 0 failed\n" in info
    # --scheduler needs an [ensemble] table
    plain = tmp_path / "plain.toml"
    plain.write_text(_SMALL.split("[ensemble]")[0])
    assert main(["run", str(plain), "-o", str(tmp_path / "p.nc"), "--scheduler", "x"]) == 2
    assert "[ensemble]" in capsys.readouterr().err
    if importlib.util.find_spec("distributed") is not None:
        monkeypatch.setattr(ensemble._dask, "SCHEDULER_TIMEOUT", 1.0)
        bad = tmp_path / "b.nc"
        code = main(["run", str(scen), "-o", str(bad), "--scheduler", "tcp://127.0.0.1:9"])
        assert code == 2
        assert "no Dask scheduler answered at 'tcp://127.0.0.1:9'" in capsys.readouterr().err
        assert not bad.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "o.nc",
        "plain.toml",
        "q.nc",
        "small.toml",
    ]


def test_shipped_ensemble_scenario_runs_from_the_cli(tmp_path, capsys):
    """scenarios/ensemble_paper_keplerian.toml through `attitude run` (a short span)."""
    from attitude.cli import main

    out = tmp_path / "e.nc"
    path = ROOT / "scenarios/ensemble_paper_keplerian.toml"
    assert main(["run", str(path), "-o", str(out), "--stop", "291.425"]) == 0
    assert "1000 members (seed 2006)" in capsys.readouterr().out
    back = io.read(out)
    assert back.sizes == {"member": 1000, "time": 6, "component": 4, "axis": 3, "detector": 3}
    assert back.attrs["run_status"] == "complete"
    # the scenario gives the paper's kg km²; results are in SI (kg m²) since issue 16
    np.testing.assert_allclose(back.attrs["inertia"], [4e8, 5e8, 6e8], rtol=1e-15)
    # the dispersed inertia: 2 % per axis, truncated at 3 sigma
    eps = back.inertia.values / [4e8, 5e8, 6e8] - 1
    assert 0.015 < np.std(eps) < 0.025 and np.max(np.abs(eps)) <= 0.06
    np.testing.assert_allclose(back.norm_error.values, 0.0, atol=1e-10)  # DOP853, rtol 1e-10
    assert np.all(back.r.values > 5599.0)  # the orbit's periapsis is a (1 - e) = 5600 km


def test_projection_warning_and_no_warning_for_exact_states():
    rng = np.random.default_rng(9)
    q = random_unit(rng, 4)
    Q = C.momenta_from_angular_velocity(q, rng.normal(size=(4, 3)), I_PAPER)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        propagate_ensemble(I_PAPER, q, Q, [0.0, 1.0])
    with pytest.warns(UserWarning, match="projected"):
        propagate_ensemble(I_PAPER, q * (1 + 1e-9), Q, [0.0, 1.0])


def test_runs_with_jit_disabled():
    """The kernels are valid Python: the same members with ATTITUDE_DISABLE_JIT=1."""
    import json
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np\n"
        "from attitude.ensemble import propagate_ensemble\n"
        "q = np.tile([1.0, 0, 0, 0], (3, 1))\n"
        "Q = np.array([[0, 0.2, 0.1, 0.3], [0, 0.1, 0.1, 0.3], [0, 0.3, -0.1, 0.3]])\n"
        "ds = propagate_ensemble([1.25, 1.0, 0.75], q, Q, [0.0, 1.0, 2.0], chunk_size=2)\n"
        "import json; print(json.dumps(ds.q.values.tolist()))\n"
    )
    env = {**os.environ, "ATTITUDE_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr
    plain = np.array(json.loads(out.stdout))
    q = np.tile([1.0, 0, 0, 0], (3, 1))
    Q = np.array([[0, 0.2, 0.1, 0.3], [0, 0.1, 0.1, 0.3], [0, 0.3, -0.1, 0.3]])
    ds = propagate_ensemble(I_PAPER, q, Q, [0.0, 1.0, 2.0])
    np.testing.assert_allclose(plain, ds.q.values, rtol=0, atol=1e-14)
