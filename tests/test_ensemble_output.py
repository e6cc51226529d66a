"""Ensembles people can afford (issue 16): output choices, size estimate and limit, statistics
computed as the members finish, re-running a member alone; the CLI around them.

Truth: the run that stores every sample (every k-th and final samples are its samples, bit for
bit); ``np.percentile`` over that run's members (the statistics-only percentiles); the netCDF
file's real size and the Dataset's ``nbytes`` (the size estimate); the seed's own draws
(``Dispersions.draws``) and the closed-form dispersion formulas (the stored dispersions); the
stored trajectory (a member re-run alone); ``attitude.propagate`` of the nominal state (the
stored reference attitude); the independent CCSDS reader (an exported member).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from attitude import canonical as C
from attitude import io
from attitude import quaternion as qt
from attitude.ensemble import (
    Dispersions,
    member_initial_state,
    pointing_error_percentiles,
    propagate_ensemble,
    rate_percentiles,
    rerun_member,
    run_scenario,
)
from attitude.ensemble import _percentile_store as store_mod
from attitude.errors import AttitudeValueError, OutputSizeError, PropagationError
from attitude.propagate import propagate
from attitude.scenario import ScenarioError, load, loads

ROOT = Path(__file__).resolve().parents[1]
TRAJ = ("q", "Q", "omega", "g", "G", "energy", "potential_energy", "norm_error", "qQ")
PCT = (5.0, 50.0, 95.0, 100.0)


@pytest.fixture(scope="module")
def gg():
    """The paper's Sect. 6.2 case, 14 members with dispersed attitude and momenta, 31 times
    over a quarter orbit, and its nominal (projected) state."""
    sc = load(ROOT / "scenarios/paper_keplerian.toml")
    q0, Q0, _ = C.project_state(sc.q0, sc.Q0)
    rng = np.random.default_rng(16)
    n = 14
    q = qt.multiply(q0, qt.from_rotation_vector(0.05 * rng.normal(size=(n, 3))))
    g0 = C.body_angular_momentum(q0, Q0)
    Q = C.momenta_from_body_angular_momentum(q, g0 * (1.0 + 0.1 * rng.normal(size=(n, 3))))
    t = np.linspace(0.0, 1500.0, 31)
    full = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=5, nominal=(q0, Q0))
    return sc, q, Q, t, (q0, Q0), full


def _same(a: xr.Dataset, b: xr.Dataset, names) -> None:
    for v in names:
        x, y = np.asarray(a[v].values), np.asarray(b[v].values)
        assert x.shape == y.shape and x.tobytes() == y.tobytes(), v


def test_invariant_maxima_are_numpys_over_the_stored_members(gg):
    """The attrs max_abs_norm_error, max_abs_qQ, max_rel_qQ, max_rel_energy_variation (one
    compiled pass over each chunk) are numpy's maxima over the stored members, to the bit; and
    the kernel's torque-free and heavy-top maxima (G, G_z) are numpy's on random data with NaN
    samples and members left out."""
    from attitude._core import ensemble as ke

    full = gg[-1]
    E = full.energy.values
    G = full.G.values
    want = {
        "max_abs_norm_error": np.abs(full.norm_error.values).max(),
        "max_abs_qQ": np.abs(full.qQ.values).max(),
        "max_rel_qQ": (
            np.abs(full.qQ.values) / np.maximum(2.0 * np.linalg.norm(G, axis=-1), 1e-308)
        ).max(),
        "max_rel_energy_variation": (np.abs(E - E[:, :1]) / np.abs(E[:, :1])).max(),
    }
    for k, v in want.items():
        assert full.attrs[k] == v, k
    rng = np.random.default_rng(28)
    d = rng.normal(size=(9, 7, 13)) * np.exp(3.0 * rng.normal(size=(9, 7, 13)))
    d[2, 4:] = np.nan  # a member ended by a terminal event
    ok = np.ones(9, dtype=bool)
    ok[5] = False  # a failed member
    dd = d[ok]
    G = dd[:, :, 6:9]
    sG = np.linalg.norm(G[:, :1], axis=-1)
    for kind, ref in (
        (ke.INVARIANTS_TORQUE_FREE, np.linalg.norm(G - G[:, :1], axis=-1) / sG),
        (ke.INVARIANTS_HEAVY_TOP, np.abs(G[:, :, 2] - G[:, :1, 2]) / sG),
    ):
        mx = np.zeros(5)
        ke.invariant_maxima(d, ok, kind, mx)
        assert mx[4] == np.nanmax(ref)
        assert mx[0] == np.nanmax(np.abs(dd[:, :, 10]))
        E = dd[:, :, 9]
        assert mx[3] == np.nanmax(np.abs(E - E[:, :1]) / np.abs(E[:, :1]))


# ------------------------------------------------------------------------------------------------
# every k-th sample, final state only
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("every", [3, 4])
def test_every_kth_sample_is_the_full_runs_sample_bit_for_bit(gg, every, tmp_path):
    sc, q, Q, t, _, full = gg
    ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, every=every, chunk_size=4)
    assert ds.sizes["time"] == len(t[::every])  # 11 for k = 3 (30 % 3 == 0), 8 for k = 4
    np.testing.assert_array_equal(ds.time.values, t[::every])
    _same(ds, full.isel(time=slice(None, None, every)), (*TRAJ, "r", "f", "p"))
    # the members integrated to t[-1] alike: the same accepted steps
    np.testing.assert_array_equal(ds.member_n_steps.values, full.member_n_steps.values)
    assert ds.attrs["output_every"] == every and ds.attrs["integration_stop"] == 1500.0
    # streamed to a file: the same bits
    path = tmp_path / "every.nc"
    lazy = propagate_ensemble(sc.body, q, Q, t, sc.potential, every=every, path=path)
    try:
        _same(lazy, ds, TRAJ)
    finally:
        lazy.close()


def test_final_state_only_is_the_full_runs_last_sample(gg, tmp_path):
    sc, q, Q, t, _, full = gg
    path = tmp_path / "final.nc"
    ds = propagate_ensemble(sc.body, q, Q, t, sc.potential, output="final", path=path, threads=1)
    try:
        assert ds.sizes["time"] == 1 and float(ds.time[0]) == 1500.0
        _same(ds, full.isel(time=[-1]), (*TRAJ, "r", "f", "p"))
        np.testing.assert_array_equal(ds.member_n_steps.values, full.member_n_steps.values)
        assert ds.attrs["ensemble_output"] == "final"
    finally:
        ds.close()


def test_output_argument_errors(gg):
    sc, q, Q, t, nom, _ = gg
    cases = [
        ({"output": "all"}, "output"),
        ({"every": 0}, "every"),
        ({"output": "final", "every": 2}, "every"),
        ({"percentiles": (50,)}, "percentiles"),
        ({"output": "statistics"}, "nominal"),
        ({"output": "statistics", "nominal": nom, "percentiles": (50, 101)}, "percentiles"),
        ({"output": "statistics", "nominal": nom, "lazy": True}, "lazy"),
        ({"boresight": [0, 0, 1]}, "boresight"),
        ({"nominal": nom, "reference": [1.0, 0, 0, 0]}, "nominal, reference"),
        ({"max_output_size": "lots"}, "max_output_size"),
        ({"max_output_size": -5}, "max_output_size"),
        ({"reference": np.ones((5, 4)) / 2}, "reference"),
    ]
    for kw, name in cases:
        with pytest.raises((AttitudeValueError, TypeError), match=f"^{name}:"):
            propagate_ensemble(sc.body, q, Q, t, sc.potential, **kw)
    # per-member bodies have no one nominal run: a reference must be given instead
    bodies = np.tile(sc.body.inertia, (q.shape[0], 1))
    with pytest.raises(AttitudeValueError, match=r"^nominal:"):
        propagate_ensemble(bodies, q, Q, t, sc.potential, nominal=nom)


# ------------------------------------------------------------------------------------------------
# statistics only
# ------------------------------------------------------------------------------------------------


def test_reference_is_the_nominal_propagated_once(gg):
    sc, _, _, t, (q0, Q0), full = gg
    nominal = propagate(sc.body, q0, Q0, t, sc.potential)
    np.testing.assert_allclose(full.reference_q.values, nominal.q.values, rtol=0, atol=1e-13)
    assert full.attrs["pointing_reference"].startswith("nominal")


@pytest.mark.parametrize("on_disk", [False, True])
def test_statistics_only_equal_np_percentile_over_the_stored_members(gg, on_disk, tmp_path):
    sc, q, Q, t, nom, full = gg
    if on_disk:  # the store in a temporary file, written from a 1-member buffer, read back in
        # blocks of 3 times
        mp = pytest.MonkeyPatch()
        mp.setattr(store_mod, "STORE_MEMORY", 0)
        mp.setattr(store_mod, "BLOCK_BYTES", 3 * 16 * q.shape[0])
    try:
        path = tmp_path / "stats.nc"
        st = propagate_ensemble(
            sc.body, q, Q, t, sc.potential, output="statistics", nominal=nom, chunk_size=3,
            path=path, percentiles=(0, 5, 50, 95, 100),
        )  # fmt: skip
    finally:
        if on_disk:
            mp.undo()
    try:
        assert sorted(p.name for p in tmp_path.iterdir()) == ["stats.nc"]  # store removed
        assert "q" not in st and "omega" not in st  # no member trajectories
        assert st.sizes["member"] == 14 and st.attrs["statistics_members"] == 14
        p = [0, 5, 50, 95, 100]
        # truth: the run that stores every member, its reference, np.percentile over members
        ref = full.reference_q.values
        np.testing.assert_array_equal(st.reference_q.values, ref)
        from attitude.ensemble.statistics import _error_angles

        err = _error_angles(full.q.values, ref[None], None)  # (member, time)
        want = np.percentile(err, p, axis=0)
        np.testing.assert_array_equal(st.pointing_error_percentiles.values, want)
        # an independent formula for the angle: 2 acos |q_ref . q| (less accurate near 0)
        dot = np.abs(np.sum(full.q.values * ref[None], axis=-1))
        alt = np.percentile(2 * np.arccos(np.minimum(dot, 1.0)), p, axis=0)
        np.testing.assert_allclose(st.pointing_error_percentiles.values, alt, atol=1e-7)
        wn = np.sqrt(np.sum(full.omega.values**2, axis=-1))
        np.testing.assert_array_equal(st.omega_norm_percentiles.values, np.percentile(wn, p, 0))
        w2 = np.linalg.norm(full.omega.values, axis=-1)
        np.testing.assert_allclose(
            st.omega_norm_percentiles.values, np.percentile(w2, p, 0), rtol=1e-15
        )
        assert np.all(st.pointing_error_percentiles.values[-1] == err.max(axis=0))  # 100: max
        # per-member inputs and statistics are kept
        _same(st, full, ("inertia", "initial_q", "initial_Q", "member_n_steps", "member_status"))
        # the percentile functions read the stored statistics (and only those)
        got = pointing_error_percentiles(st, percentiles=(50, 95), degrees=True)
        np.testing.assert_allclose(got.values, np.degrees(want[[2, 3]]), rtol=1e-15)
        w = rate_percentiles(st, (100,), degrees=True)
        np.testing.assert_allclose(w.values[0], np.degrees(wn.max(axis=0)), rtol=1e-15)
        assert w.attrs["units"] == "deg s^-1"
        with pytest.raises(AttitudeValueError, match=r"^percentiles: .* 90 was not computed"):
            pointing_error_percentiles(st, percentiles=(90,))
        with pytest.raises(AttitudeValueError, match=r"^reference:"):
            pointing_error_percentiles(st, reference="mean")
        with pytest.raises(AttitudeValueError, match=r"^norm:"):
            rate_percentiles(st, norm=False)
    finally:
        st.close()


def test_statistics_in_memory_and_with_a_boresight(gg):
    sc, q, Q, t, nom, full = gg
    st = propagate_ensemble(
        sc.body, q, Q, t, sc.potential, output="statistics", nominal=nom, every=5,
        boresight=[0.0, 0.0, 2.0],
    )  # fmt: skip
    assert st.sizes["time"] == 7 and st.sizes["percentile"] == 4
    sub = full.isel(time=slice(None, None, 5))
    # the boresight error: the angle between the directions of b3 in space
    b = np.array([0.0, 0.0, 1.0])
    u = qt.rotate(sub.q.values, b)
    v = qt.rotate(sub.reference_q.values, b)[None]
    ang = np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))
    np.testing.assert_allclose(
        st.pointing_error_percentiles.values, np.percentile(ang, PCT, 0), rtol=1e-14, atol=1e-16
    )
    # a given reference (a propagate result) instead of the nominal state
    nominal = propagate(sc.body, *nom, t, sc.potential)
    st2 = propagate_ensemble(sc.body, q, Q, t, sc.potential, output="statistics", reference=nominal)
    err = qt.angle_between(full.q.values, nominal.q.values[None])
    np.testing.assert_allclose(
        st2.pointing_error_percentiles.values, np.percentile(err, PCT, 0), atol=1e-12
    )
    assert st2.attrs["pointing_reference"] == "given"


def test_rate_percentiles_in_degrees():
    rng = np.random.default_rng(5)
    n = 11
    q0 = qt.normalize(rng.normal(size=(n, 4)))
    rates = rng.uniform(0.1, 2.0, n)
    w = np.zeros((n, 3))
    w[:, 0] = rates  # about the major axis: |omega| constant
    inertia = [1.25, 1.0, 0.75]
    t = np.linspace(0.0, 5.0, 4)
    Q0 = C.momenta_from_angular_velocity(q0, w, inertia)
    ds = propagate_ensemble(inertia, q0, Q0, t, rtol=1e-13, atol=1e-15)
    got = rate_percentiles(ds, (10, 50, 90), degrees=True)
    np.testing.assert_allclose(got.values[:, 0], np.degrees(np.percentile(rates, [10, 50, 90])))
    assert got.attrs["units"] == "deg" and "per time unit" in got.attrs["comment"]
    comp = rate_percentiles(ds, (50,), norm=False, degrees=True)
    np.testing.assert_allclose(comp.values[0, :, 0], np.degrees(np.median(rates)), rtol=1e-12)
    with pytest.raises(AttitudeValueError, match=r"^degrees:"):
        rate_percentiles(ds, (50,), variable="g", degrees=True)


# ------------------------------------------------------------------------------------------------
# expected size and its limit
# ------------------------------------------------------------------------------------------------


def test_size_estimate_against_the_real_file_and_memory(tmp_path):
    """The estimate counts the data uncompressed plus the netCDF metadata: the files (zlib)
    come out at 60-100 % of it (measured 75-96 %); in memory it bounds ``nbytes`` from above
    by the metadata allowance only."""
    sc = load(ROOT / "scenarios/ensemble_paper_keplerian.toml")
    sc.ensemble.size = 300
    sc.t = np.linspace(0.0, 5828.5, 201)
    for output, every in (("samples", 1), ("samples", 10), ("final", 1), ("statistics", 1)):
        est: list[int] = []
        path = tmp_path / f"{output}{every}.nc"
        info = run_scenario(sc, path, output=output, every=every, on_estimate=est.append)
        size = os.path.getsize(path)
        assert len(est) == 1 and info["expected_output_size"] == est[0]
        assert 0.6 * est[0] <= size <= est[0], (output, every, size, est[0])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (50, 1))
    Q = C.momenta_from_angular_velocity(q, [0.1, 0.2, 0.3], [1.25, 1.0, 0.75])
    got: list[int] = []
    ds = propagate_ensemble([1.25, 1.0, 0.75], q, Q, np.linspace(0, 1, 101), on_estimate=got.append)
    from attitude.ensemble import _plan

    text = [k for k in ds.variables if ds[k].dtype.kind in "UO"]  # + a dimension each
    meta = _plan.FILE_OVERHEAD + _plan.VARIABLE_OVERHEAD * (len(ds.variables) + len(text))
    assert ds.nbytes <= got[0] <= ds.nbytes + meta + 4000  # + the attrs' text


def test_output_above_the_limit_is_refused_before_any_work(tmp_path):
    sc = loads(_SMALL)
    path = tmp_path / "e.nc"
    est: list[int] = []
    run_scenario(sc, path, on_estimate=est.append)
    path.unlink()
    with pytest.raises(OutputSizeError, match=r"^max_output_size: the output file would take") as e:
        run_scenario(sc, path, max_output_size=est[0] - 1)
    assert e.value.expected == est[0] and e.value.limit == est[0] - 1
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary file
    # the scenario key, with a unit, and 'none'
    small = loads(_SMALL + "max_output_size = 1\nmax_output_size_unit = 'kB'\n")
    assert small.ensemble.max_output_size == 1000.0
    with pytest.raises(OutputSizeError, match="1 kB"):
        run_scenario(small, path)
    info = run_scenario(small, path, max_output_size=None)
    assert info["run_status"] == "complete" and path.exists()
    assert loads(_SMALL + "max_output_size = 'none'\n").ensemble.max_output_size == np.inf
    # the default limit (1 GB) refuses the 10 000 members x 5001 samples (~8.5 GB)
    big = loads(_SMALL.replace("size = 23", "size = 10000").replace("count = 6", "count = 5001"))
    with pytest.raises(OutputSizeError) as e:
        run_scenario(big, tmp_path / "big.nc")
    assert 8e9 < e.value.expected < 9e9 and e.value.limit == 1e9
    assert not (tmp_path / "big.nc").exists()


# ------------------------------------------------------------------------------------------------
# per-member dispersions; re-running a member alone
# ------------------------------------------------------------------------------------------------

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


def test_stored_dispersions_are_the_seeds_draws(tmp_path):
    sc = loads(_SMALL)
    path = tmp_path / "e.nc"
    run_scenario(sc, path)
    ds = io.read(path)
    d = Dispersions(size=23, seed=4, attitude_error=np.radians(2.0), rate_error=0.01,
                    inertia_error=0.05)  # fmt: skip
    dtheta, domega, eps = d.draws(0, 23)  # the seed's stream, drawn again here
    _ = ds  # stored: the same numbers
    np.testing.assert_array_equal(ds.dispersion_attitude.values, dtheta)
    np.testing.assert_array_equal(ds.dispersion_rate.values, domega)
    np.testing.assert_array_equal(ds.dispersion_inertia.values, eps)
    np.testing.assert_array_equal(ds.member_draw_counter.values, 3 * np.arange(23))
    assert ds.attrs["ensemble_seed"] == 4
    # and they are what was applied: q_i = q0 o exp(dtheta/2), I_i = I (1 + eps), w_i = w0 + dw
    I0 = np.array([1.25, 1.0, 0.75])
    np.testing.assert_allclose(
        ds.initial_q.values, qt.from_rotation_vector(dtheta), rtol=0, atol=2e-16
    )
    np.testing.assert_allclose(ds.inertia.values, I0 * (1 + eps), rtol=2e-16)
    w = np.stack([C.angular_velocity(a, b, c) for a, b, c in zip(
        ds.initial_q.values, ds.initial_Q.values, ds.inertia.values, strict=True)])  # fmt: skip
    np.testing.assert_allclose(w, np.add([0.3, 0.1, 0.8], domega), rtol=1e-14)
    assert ds.dispersion_rate.attrs["units"] == "1"  # dimensionless body


@pytest.mark.parametrize("output", ["samples", "final", "statistics"])
def test_rerun_member_alone_bit_for_bit(output, tmp_path):
    """Member k of a dispersed Sect. 6.2 ensemble, integrated alone from what the file stores,
    gives its samples bit for bit (the samples-run's samples for the other outputs)."""
    sc = load(ROOT / "scenarios/ensemble_paper_keplerian.toml")
    sc.ensemble.size = 17
    sc.t = sc.t[:11]
    full_path = tmp_path / "full.nc"
    run_scenario(sc, full_path, chunk_size=4)
    full = io.read(full_path)
    path = tmp_path / f"{output}.nc"
    if output != "samples":
        run_scenario(sc, path, output=output, chunk_size=5)
    else:
        path = full_path
    pot = loads(full.attrs["scenario_toml"]).potential
    for k in (0, 9, 16):
        one = rerun_member(path, k, pot)
        ref = full.sel(member=k) if output != "final" else full.sel(member=k).isel(time=[-1])
        _same(one, ref, (*TRAJ, "r", "f", "p"))
        assert int(one.member) == k
        assert int(one.member_n_steps) == int(full.member_n_steps.sel(member=k))
    # a one-member ensemble from member_initial_state: the same bits
    body, q0, Q0 = member_initial_state(path, 9)
    np.testing.assert_array_equal(body.inertia, full.inertia.sel(member=9).values)
    # (the scenario's method, dop853, named: the default "auto" would pick taylor)
    assert full.attrs["method"] == sc.method == "dop853"
    one = propagate_ensemble(body, q0[None], Q0[None], sc.t, pot, sc.method, nominal=None)
    _same(one.isel(member=0), full.sel(member=9), TRAJ)
    # attitude.propagate projects the state its own way: the same to round-off only
    single = propagate(body, q0, Q0, sc.t, pot, sc.method)
    np.testing.assert_allclose(single.q.values, full.q.sel(member=9).values, atol=1e-13)
    with pytest.raises(AttitudeValueError, match=r"^potential: the ensemble ran with"):
        rerun_member(path, 0)
    with pytest.raises(AttitudeValueError, match=r"^k: no member 17"):
        rerun_member(path, 17, pot)


def test_rerun_member_of_a_torque_free_ensemble_needs_no_potential():
    rng = np.random.default_rng(3)
    q = qt.normalize(rng.normal(size=(6, 4)))
    Q = C.momenta_from_angular_velocity(q, rng.normal(size=(6, 3)), [1.25, 1.0, 0.75])
    ds = propagate_ensemble([1.25, 1.0, 0.75], q, Q, np.linspace(0, 3, 7), every=2)
    one = rerun_member(ds, 4)
    _same(one, ds.sel(member=4), TRAJ)


# ------------------------------------------------------------------------------------------------
# scenario keys
# ------------------------------------------------------------------------------------------------


def test_ensemble_output_keys_of_a_scenario(tmp_path):
    sc = loads(_SMALL + "output = 'statistics'\nevery = 2\npercentiles = [50, 100]\n")
    info = run_scenario(sc, tmp_path / "s.nc")
    ds = io.read(info["path"])
    assert ds.sizes["time"] == 3 and list(ds.percentile.values) == [50.0, 100.0]
    assert "q" not in ds and ds.attrs["ensemble_output"] == "statistics"
    for text, key in (
        ("output = 'everything'\n", "ensemble.output"),
        ("every = 0\n", "ensemble.every"),
        ("output = 'final'\nevery = 2\n", "ensemble.every"),
        ("percentiles = [50]\n", "ensemble.percentiles"),
        ("output = 'statistics'\npercentiles = [50, 120]\n", "ensemble.percentiles"),
        ("max_output_size = 1\n", "ensemble.max_output_size"),
        ("max_output_size = 1\nmax_output_size_unit = 'm'\n", "ensemble.max_output_size_unit"),
    ):
        with pytest.raises(ScenarioError, match=r"^" + key.replace(".", r"\.")):
            loads(_SMALL + text)


def test_angle_errors_in_the_users_unit():
    with pytest.raises(ScenarioError, match=r"^ensemble\.attitude_error: .* got -1\.0 deg$"):
        loads(_SMALL.replace("attitude_error = 2.0", "attitude_error = -1.0"))
    text = (ROOT / "scenarios/paper_keplerian.toml").read_text()
    with pytest.raises(ScenarioError, match=r"^orbit\.inc: .*\[0, 180 deg\], got 200\.0 deg"):
        loads(text.replace("inc = 30.0", "inc = 200.0"))
    hyp = text.replace("e = 0.2", "e = 1.5").replace("a = 7000.0", "a = -7000.0")
    # acos(-1/1.5) = 131.81 deg
    with pytest.raises(ScenarioError, match=r"^orbit\.f0: .* 131\.81 deg, got 170\.0 deg"):
        loads(hyp.replace("f0 = 0.0", "f0 = 170.0"))


# ------------------------------------------------------------------------------------------------
# the command line
# ------------------------------------------------------------------------------------------------


def test_cli_output_choices_size_and_limit(tmp_path, capsys):
    from attitude.cli import main

    scen = tmp_path / "small.toml"
    scen.write_text(_SMALL)
    out = tmp_path / "s.nc"
    assert main(["run", str(scen), "-o", str(out), "--ensemble-output", "statistics"]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"output      {out}: expected about ")
    assert "percentiles 5, 50, 95, 100 over members" in text
    assert "q" not in io.read(out)
    assert main(["run", str(scen), "-o", str(tmp_path / "k.nc"), "--every", "2", "-q"]) == 0
    assert io.read(tmp_path / "k.nc").sizes["time"] == 3
    # refused above the limit, naming the option; nothing written
    bad = tmp_path / "big.nc"
    assert main(["run", str(scen), "-o", str(bad), "--max-output-size", "10kB"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("attitude: error: the ensemble's output file would take about ")
    assert "above the limit of 10 kB (--max-output-size" in err and not bad.exists()
    assert main(["run", str(scen), "-o", str(bad), "--max-output-size", "ten"]) == 2
    assert "--max-output-size: 'ten' is not a size" in capsys.readouterr().err
    assert main(["run", str(scen), "-o", str(bad), "--every", "0"]) == 2
    assert main(["run", str(scen), "-o", str(bad), "--ensemble-output", "final", "--every", "2"])
    assert "attitude: error: --every:" in capsys.readouterr().err


def test_cli_warns_about_options_that_do_not_apply(tmp_path, capsys):
    from attitude.cli import main

    scen = ROOT / "scenarios/paper_torque_free.toml"
    out = str(tmp_path / "o.nc")
    assert main(["run", str(scen), "-o", out, "-q", "--dt", "0.1", "--stop", "50"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "attitude: warning: --dt applies to the fixed-step methods (nosquish, splitting), not "
        "to dop853; ignored",
        "attitude: warning: --stop 50: beyond the scenario's time span (time.stop = 20); the "
        "run ends at time.stop",
    ]
    assert io.read(out).time.values[-1] == 20.0
    args = ["run", str(scen), "-o", out, "-q", "--method", "scipy:DOP853", "--order", "4"]
    assert main([*args, "--every", "3", "--stop", "1"]) == 0
    err = capsys.readouterr().err
    assert (
        "--order applies to the fixed-step methods (nosquish, splitting), not to scipy:DOP853"
        in err
    )
    assert "--every applies to scenarios with an [ensemble] table; ignored" in err
    assert main(["run", str(scen), "-o", out, "--method", "nosquish"]) == 2
    assert "--method nosquish: a fixed-step method needs its step: give --dt" in (
        capsys.readouterr().err
    )
    # an ensemble: the fixed-step options are ignored (and said so)
    small = tmp_path / "small.toml"
    small.write_text(_SMALL)
    assert main(["run", str(small), "-o", str(tmp_path / "e.nc"), "-q", "--order", "6"]) == 0
    assert "--order does not apply to an ensemble" in capsys.readouterr().err


def test_cli_plot_draws_the_percentile_bands(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from attitude.cli import main
    from attitude.plotting import plot_ensemble

    scen = tmp_path / "small.toml"
    scen.write_text(_SMALL)
    for output in ("samples", "statistics", "final"):
        out = tmp_path / f"{output}.nc"
        assert main(["run", str(scen), "-o", str(out), "-q", "--ensemble-output", output]) == 0
        assert main(["plot", str(out), "-o", str(tmp_path / f"{output}.png")]) == 0
        assert (tmp_path / f"{output}.png").stat().st_size > 10_000
        ds = io.read(out)
        fig = plot_ensemble(ds)
        if output == "final":  # histograms over the members, percentiles as vertical lines
            wn = np.degrees(np.linalg.norm(ds.omega.values[:, -1], axis=-1))
            xs = [line.get_xdata()[0] for line in fig.axes[1].lines]
            np.testing.assert_allclose(xs, np.percentile(wn, PCT), rtol=1e-12)
            continue
        # the median line and the max line are the stored/computed percentiles, in degrees
        pe = pointing_error_percentiles(ds, percentiles=(50, 100), degrees=True)
        ax = fig.axes[0]
        np.testing.assert_allclose(ax.lines[0].get_ydata(), pe.values[0], rtol=1e-12)
        np.testing.assert_allclose(ax.lines[1].get_ydata(), pe.values[1], rtol=1e-12)
        w = rate_percentiles(ds, (50,), degrees=True)
        np.testing.assert_allclose(fig.axes[1].lines[0].get_ydata(), w.values[0], rtol=1e-12)
        assert "nominal" in ax.get_title()
    capsys.readouterr()


def test_cli_export_refuses_an_ensemble_or_exports_one_member(tmp_path, capsys):
    from attitude import aem
    from attitude.cli import main

    scen = tmp_path / "small.toml"
    scen.write_text(_SMALL)
    out = tmp_path / "e.nc"
    stats = tmp_path / "s.nc"
    assert main(["run", str(scen), "-o", str(out), "-q"]) == 0
    assert main(["run", str(scen), "-o", str(stats), "-q", "--ensemble-output", "statistics"]) == 0
    base = ["export", "--epoch", "2024-01-01T00:00:00", "--time-unit-seconds", "1"]
    aem_path = tmp_path / "m.aem"
    assert main([*base, str(out), "--ccsds-aem", str(aem_path)]) == 2
    err = capsys.readouterr().err
    assert "is an ensemble of 23 members; a CCSDS AEM holds one attitude history: choose a " in err
    assert "--member K (0..22)" in err and not aem_path.exists()
    assert main([*base, str(stats), "--ccsds-aem", str(aem_path)]) == 2
    assert "holds the statistics of an ensemble of 23 members" in capsys.readouterr().err
    assert main([*base, str(out), "--ccsds-aem", str(aem_path), "--member", "23"]) == 2
    assert "--member 23: no such member" in capsys.readouterr().err
    assert main([*base, str(out), "--ccsds-aem", str(aem_path), "--member", "7"]) == 0
    back = aem.read(aem_path)
    want = io.read(out).q.sel(member=7).values
    np.testing.assert_allclose(back.q.values * np.sign(back.q.values[:, :1]), want * np.sign(
        want[:, :1]), rtol=0, atol=1e-15)  # fmt: skip
    capsys.readouterr()


@pytest.mark.filterwarnings("ignore:this run needs about:RuntimeWarning")  # on purpose
def test_streaming_failure_message_names_no_internals(tmp_path, capsys):
    from attitude.cli import main

    text = (ROOT / "scenarios/paper_torque_free.toml").read_text()
    scen = tmp_path / "f.toml"
    scen.write_text(text.replace("[integrator]", "[integrator]\nmax_steps = 5"))
    out = tmp_path / "f.nc"
    assert main(["run", str(scen), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("attitude: failed: propagation stopped at t = ")
    assert err.rstrip().endswith(f"the samples computed are in {out} (run_status failed)")
    assert "on_chunk" not in err and "partial" not in err
    with pytest.raises(PropagationError) as e:
        propagate([1.25, 1.0, 0.75], [1.0, 0, 0, 0], [0, 0.2, 0.1, 0.3], np.linspace(0, 99, 100),
                  max_steps=3, on_chunk=lambda ds: None)  # fmt: skip
    assert "on_chunk" not in str(e.value)


def test_lazy_graph_stores_the_same_kth_and_final_samples(gg):
    pytest.importorskip("dask")
    sc, q, Q, t, _, full = gg
    for kw, sel in (({"every": 4}, slice(None, None, 4)), ({"output": "final"}, [-1])):
        lazy = propagate_ensemble(sc.body, q, Q, t, sc.potential, chunk_size=6, lazy=True, **kw)
        assert lazy.q.chunks is not None  # a dask graph
        _same(lazy.compute(), full.isel(time=sel), TRAJ)


def test_docs_first_example_runs(tmp_path, monkeypatch):
    """The first example of docs/ensemble.md (fewer members), statistics-only part included."""
    import re

    text = (ROOT / "docs/ensemble.md").read_text()
    code = re.findall(r"```python\n(.*?)```", text, flags=re.S)[0]
    assert 'output="statistics"' in code
    monkeypatch.chdir(tmp_path)
    space: dict = {}
    exec(compile(code.replace("n = 10_000", "n = 300"), "ensemble.md", "exec"), space)
    st = io.read(tmp_path / "mc_stats.nc")
    full = io.read(tmp_path / "mc.nc")
    assert st.sizes["member"] == full.sizes["member"] == 300
    assert space["p"].dims == ("percentile", "time") and space["p"].attrs["units"] == "deg"
    np.testing.assert_array_equal(
        space["w"].values, rate_percentiles(full, (5, 50, 95), degrees=True).values
    )


def test_member_state_errors_show_plain_numbers():
    q = np.array([[1.1, 0.0, 0.0, 0.0]])
    with pytest.raises(AttitudeValueError) as e:
        propagate_ensemble([1.25, 1.0, 0.75], q, [0.0, 0.1, 0.1, 0.1], [0.0, 1.0])
    assert str(e.value).startswith("q0: member 0: |q0| = 1.1 is not 1")
    assert "np." not in str(e.value)


def test_singular_euler_angles_reported_in_the_files_unit():
    text = """
[body]
inertia = [1.25, 1.0, 0.75]
[initial_state]
form = "euler_canonical"
angles = [10.0, 180.0, 20.0]
angles_unit = "deg"
momenta = [0.1, 0.2, 0.3]
[time]
stop = 5.0
count = 6
"""
    with pytest.raises(
        ScenarioError, match=r"^initial_state\.angles: .* ϑ = 180\.0 deg is 0 or 180"
    ):
        loads(text)


def test_output_choices_on_a_dask_cluster_equal_the_local_run(gg, tmp_path):
    """Chunks run as Dask tasks (serial driver on the workers): the same stored bits and the
    same statistics as the local parallel loop."""
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    sc, q, Q, t, nom, full = gg
    local = propagate_ensemble(
        sc.body, q, Q, t, sc.potential, output="statistics", nominal=nom, every=2
    )
    with (
        LocalCluster(n_workers=1, threads_per_worker=2, processes=False) as cluster,
        Client(cluster) as client,
    ):
        path = tmp_path / "d.nc"
        remote = propagate_ensemble(
            sc.body, q, Q, t, sc.potential, output="statistics", nominal=nom, every=2,
            client=client, chunk_size=4, path=path,
        )  # fmt: skip
        try:
            _same(remote, local, ("pointing_error_percentiles", "omega_norm_percentiles"))
        finally:
            remote.close()
        fin = propagate_ensemble(
            sc.body, q, Q, t, sc.potential, output="final", client=client, chunk_size=5
        )
        _same(fin, full.isel(time=[-1]), TRAJ)
