"""attitude.io: netCDF4 round trip, CF attrs read with netCDF4 directly, streaming, atomicity."""

from __future__ import annotations

import tracemalloc

import netCDF4
import numpy as np
import pytest
import xarray as xr
from astropy import units as u

from attitude import io
from attitude.errors import PropagationError
from attitude.potentials import HeavyTop
from attitude.propagate import propagate

I_PAPER = [1.25, 1.0, 0.75]
Q0_PAPER = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
P0_PAPER = np.array([0.3, -0.848528, 0.141421, -1.5])


@pytest.fixture(scope="module")
def heavy():
    with pytest.warns(UserWarning, match="projected"):
        return propagate(
            I_PAPER, Q0_PAPER, P0_PAPER, np.linspace(0.0, 5.0, 501), HeavyTop(0.5, [1, 0, 0])
        )


def _bits(a):
    a = np.ascontiguousarray(a)
    return a.dtype, a.shape, a.tobytes()


def test_round_trip_bit_exact(heavy, tmp_path):
    ds = heavy.copy()
    ds.attrs.update(note="é ∘ unicode", some_int=np.int64(-7), some_list=[1.5, 2.5, -0.0])
    path = io.write(ds, tmp_path / "r.nc")
    back = io.read(path)
    xr.testing.assert_identical(ds.drop_attrs(deep=False), back.drop_attrs(deep=False))
    for name in ds.variables:
        assert _bits(ds[name].values) == _bits(back[name].values), name
        assert ds[name].attrs == back[name].attrs, name
    assert set(ds.attrs) == set(back.attrs)
    for k, v in ds.attrs.items():
        w = back.attrs[k]
        assert np.asarray(v).tolist() == np.asarray(w).tolist(), k
        if isinstance(v, (float, np.floating, int, np.integer)):
            assert np.asarray(v).dtype.kind == np.asarray(w).dtype.kind, k
    # -0.0 keeps its sign bit inside the attr array
    assert np.signbit(back.attrs["some_list"][2])


def test_file_read_with_netcdf4_directly(heavy, tmp_path):
    path = io.write(heavy, tmp_path / "h.nc")
    with netCDF4.Dataset(path) as nc:
        assert nc.data_model == "NETCDF4"
        assert nc.getncattr("Conventions") == "CF-1.11"
        for key in ("title", "history", "source", "method", "potential", "package_version"):
            assert isinstance(nc.getncattr(key), str) and nc.getncattr(key)
        np.testing.assert_array_equal(nc.getncattr("inertia"), I_PAPER)
        assert nc.getncattr("rtol") == 1e-10
        assert nc.dimensions["time"].isunlimited() and len(nc.dimensions["time"]) == 501
        for name in ("q", "Q", "omega", "g", "G", "energy", "potential_energy", "norm_error"):
            v = nc.variables[name]
            assert v.dimensions[0] == "time"
            u.Unit(v.getncattr("units"))  # astropy parses every unit string
            assert v.getncattr("long_name")
            assert v.filters()["zlib"] and v.filters()["shuffle"]
        # the data are the values of the Dataset, bit for bit
        assert _bits(nc.variables["q"][:].data) == _bits(heavy.q.values)
        # CF: numeric dimension coordinates, the letters in auxiliary label variables named
        # by the data variables' "coordinates" attr
        assert nc.variables["component"][:].tolist() == [0, 1, 2, 3]
        assert list(nc.variables["component_label"][:]) == ["w", "x", "y", "z"]
        assert nc.variables["axis"][:].tolist() == [0, 1, 2]
        assert list(nc.variables["axis_label"][:]) == ["x", "y", "z"]
        assert nc.variables["q"].coordinates == "component_label"
        assert nc.variables["omega"].coordinates == "axis_label"


_REOPEN = """
import sys, netCDF4, xarray as xr
held = xr.open_dataset(sys.argv[1]).load()
for _ in range(100):
    with netCDF4.Dataset(sys.argv[1]) as nc:
        nc.variables
    xr.open_dataset(sys.argv[1]).load().close()
print(list(held.axis_label.values))
"""


def test_a_file_held_open_can_be_opened_again(heavy, tmp_path):
    """The labels are character arrays, not HDF5 variable-length strings: with those, the HDF5
    of netCDF4's wheels crashes a process that holds a file open through xarray and opens it
    again through netCDF4 and xarray (a segmentation fault; this script, on such a file)."""
    import subprocess
    import sys

    path = io.write(heavy, tmp_path / "h.nc")
    with netCDF4.Dataset(path) as nc:
        v = nc.variables["component_label"]
        assert v.dtype == np.dtype("S1") and v.getncattr("_Encoding") == "utf-8"
        assert v.dimensions == ("component", "component_label_strlen")
    r = subprocess.run([sys.executable, "-c", _REOPEN, str(path)], capture_output=True,
                       text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, (r.returncode, r.stderr[-2000:])
    assert r.stdout.split() == ["['x',", "'y',", "'z']"]


def test_streaming_equals_in_memory(heavy, tmp_path):
    path = tmp_path / "s.nc"
    chunks = []
    with io.StreamWriter(path) as w:

        def sink(c):
            chunks.append(c.sizes["time"])
            w.append(c)

        with pytest.warns(UserWarning, match="projected"):
            last = propagate(
                I_PAPER,
                Q0_PAPER,
                P0_PAPER,
                np.linspace(0.0, 5.0, 501),
                HeavyTop(0.5, [1, 0, 0]),
                on_chunk=sink,
                chunk=37,
            )
        w.attrs = dict(last.attrs)
    assert chunks == [37] * 13 + [501 - 13 * 37]
    assert last.sizes["time"] == 1 and last.time.values[0] == 5.0
    back = io.read(path)
    for name in heavy.data_vars:  # dense output does not depend on where chunks end
        assert _bits(back[name].values) == _bits(heavy[name].values), name
    assert back.attrs["n_steps"] == heavy.attrs["n_steps"]


def test_streaming_memory_is_bounded(tmp_path):
    # 200 000 samples: in memory the states and diagnostics alone take 200e3*(8+13)*8 B = 34 MB.
    n = 200_000
    t = np.linspace(0.0, 2000.0, n)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = np.array([0.0, 0.3, 0.2, 0.1])
    propagate(I_PAPER, q0, Q0, t[:10], rtol=1e-8)  # compile outside the measurement
    tracemalloc.start()
    try:
        with io.StreamWriter(tmp_path / "big.nc") as w:
            propagate(I_PAPER, q0, Q0, t, rtol=1e-8, on_chunk=w.append, chunk=2048)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 6e6, f"peak {peak / 1e6:.1f} MB"
    with netCDF4.Dataset(tmp_path / "big.nc") as nc:
        assert len(nc.dimensions["time"]) == n
        assert nc.variables["time"][-1] == 2000.0


def test_failed_write_leaves_nothing(heavy, tmp_path):
    path = tmp_path / "x.nc"
    path.write_bytes(b"previous")
    with pytest.raises(RuntimeError), io.StreamWriter(path) as w:
        w.append(heavy.isel(time=slice(0, 100)))
        raise RuntimeError("crash midway")
    assert path.read_bytes() == b"previous"  # the old file is untouched
    assert list(tmp_path.iterdir()) == [path]  # and no temporary file is left


def test_failed_propagation_keeps_what_it_computed(tmp_path):
    from attitude import scenario

    sc = scenario.loads(
        """
        [body]
        inertia = [1.25, 1.0, 0.75]
        [initial_state]
        form = "body_rates"
        q = [1.0, 0.0, 0.0, 0.0]
        omega = [0.3, 2.0, 0.1]
        [time]
        stop = 50.0
        step = 0.01
        [integrator]
        method = "dop853"  # 200 of its steps end the run midway (taylor's longer ones finish)
        rtol = 1e-12
        max_steps = 200
        """
    )
    with pytest.raises(PropagationError, match="stopped"):
        sc.run_to_file(tmp_path / "f.nc", chunk=64)
    back = io.read(tmp_path / "f.nc")
    n = back.sizes["time"]
    assert 0 < n < 5001
    assert back.attrs["run_status"].startswith("failed:")
    assert back.attrs["n_samples"] == n
    full = scenario.loads(sc.source.replace("max_steps = 200", "")).run()
    np.testing.assert_allclose(back.q.values, full.q.values[:n], rtol=0, atol=1e-9)


def test_read_errors(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        io.read(tmp_path / "missing.nc")
    (tmp_path / "junk.nc").write_text("not netcdf")
    with pytest.raises(ValueError, match="not a netCDF4 file"):
        io.read(tmp_path / "junk.nc")


@pytest.mark.slow
def test_streaming_ten_million_samples_bounded_memory(tmp_path):
    n = 10_000_000
    t = np.linspace(0.0, 1.0e5, n)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = np.array([0.0, 0.3, 0.2, 0.1])
    propagate(I_PAPER, q0, Q0, t[:10], rtol=1e-8)
    tracemalloc.start()
    try:
        with io.StreamWriter(tmp_path / "huge.nc") as w:
            propagate(I_PAPER, q0, Q0, t, rtol=1e-8, on_chunk=w.append)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # Output samples in memory would be 10e6 * 21 * 8 B = 1.7 GB. What remains is O(len(t)) at
    # one byte per sample (the boolean checks of the input times) plus one chunk.
    assert peak < 0.25 * t.nbytes + 20e6, f"peak {peak / 1e6:.1f} MB"
    ds = io.read(tmp_path / "huge.nc", load=False)
    assert ds.sizes["time"] == n and float(ds.time[-1]) == 1.0e5
    ds.close()


def test_an_ensemble_in_memory_is_written_as_propagate_ensemble_writes_it(tmp_path):
    """io.write of an ensemble Dataset (member dimension) reads back equal to it, and equal to
    the file propagate_ensemble(path=) writes of the same members."""
    from attitude.ensemble import propagate_ensemble

    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = np.array([[0.0, 0.2, 0.1, -0.3], [0.0, -0.1, 0.3, 0.2], [0.0, 0.05, 0.0, 0.4]])
    t = np.linspace(0.0, 2.0, 5)
    body = [1.0, 2.0, 2.5]
    ds = propagate_ensemble(body, q0, Q0, t, method="dop853")
    io.write(ds, tmp_path / "mem.nc")
    propagate_ensemble(body, q0, Q0, t, method="dop853", path=tmp_path / "run.nc")
    mem, run = io.read(tmp_path / "mem.nc"), io.read(tmp_path / "run.nc")
    for v in ds.data_vars:
        np.testing.assert_array_equal(mem[v].values, ds[v].values, err_msg=v)
        np.testing.assert_array_equal(mem[v].values, run[v].values, err_msg=v)
