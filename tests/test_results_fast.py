"""The Dataset of ``propagate`` is assembled directly (attitude.results._dataset): it must be
identical to what the public xarray constructor builds from the same pieces."""

from __future__ import annotations

import importlib.util
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import orbit
from attitude.canonical import project_state
from attitude.potentials import GravityGradient
from attitude.propagate import propagate

ROOT = Path(__file__).resolve().parents[1]


def _public(ds: xr.Dataset) -> xr.Dataset:
    return xr.Dataset(
        {k: ds[k].variable.copy() for k in ds.data_vars},
        coords={k: ds[k].variable.to_base_variable() for k in ds.coords},
        attrs=dict(ds.attrs),
    )


def test_direct_dataset_identical_to_public_constructor(tmp_path):
    q0, Q0, _ = project_state(
        np.array([0.5, -1 / math.sqrt(2), 0.0, 0.5]), np.array([0.3, -0.848528, 0.141421, -1.5])
    )
    o = orbit.KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12)
    for kw in ({}, {"potential": GravityGradient(o)}):
        ds = propagate([400.0, 500.0, 600.0], q0, Q0, np.linspace(0.0, 100.0, 5), **kw)
        ref = _public(ds)
        xr.testing.assert_identical(ds, ref)
        assert list(ds.variables) == list(ref.variables)
        assert list(ds.dims) == list(ref.dims) and dict(ds.sizes) == dict(ref.sizes)
        assert set(ds.xindexes) == set(ref.xindexes) == {"time", "component", "axis", "model"}
        # indexing, selection and a netCDF round trip behave as on a public Dataset
        assert ds.sel(time=50.0).q.shape == (4,)
        assert ds.sel(component=1).q.shape == (5,)  # numeric CF coordinate; "x" in the label
        assert str(ds.component_label.sel(component=1).values) == "x"
        path = tmp_path / "x.nc"
        ds.to_netcdf(path)
        with xr.open_dataset(path, decode_times=False) as back:
            xr.testing.assert_identical(back.load(), ds)
    # the cached index coordinates are not shared mutable state between results
    a = propagate([1.0, 2.0, 3.0], q0, Q0, [0.0, 1.0])
    a.component.attrs["note"] = "changed"
    b = propagate([1.0, 2.0, 3.0], q0, Q0, [0.0, 1.0])
    assert "note" not in b.component.attrs


_NO_DASK = """
import sys
from attitude.cli import main
for arg in sys.argv[2:]:
    scen, stop = arg.rsplit(":", 1)
    out = sys.argv[1] + "/" + scen.rsplit("/", 1)[-1] + ".nc"
    assert main(["run", scen, "-o", out, "--stop", stop, "-q"]) == 0
print(sorted(m for m in sys.modules if m.split(".")[:2] == ["dask", "array"]))
"""


def test_a_run_and_its_file_do_not_import_dask(tmp_path):
    """xarray's public Variable constructor imports ``dask.array`` (0.3 s; installed with the
    test extra) to ask whether the data is a dask array: every result variable is built
    without it (attitude.results._variable, xarray's fast path), so the README's main job, a
    run with events and one with the orbit in the state never import it, in a fresh
    process."""
    if importlib.util.find_spec("dask") is None:
        pytest.skip("dask is not installed: nothing to import")
    stops = {"paper_keplerian": 60, "lvlh_pointing_events": 60, "orbit_raising_burn": 0.01}
    scen = [f"{ROOT / 'scenarios' / n}.toml:{stop}" for n, stop in stops.items()]
    r = subprocess.run(
        [sys.executable, "-c", _NO_DASK, str(tmp_path), *scen],
        capture_output=True, text=True, timeout=600,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip().splitlines()[-1] == "[]"
