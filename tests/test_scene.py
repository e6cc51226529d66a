"""What the 3D view draws (attitude.plotting._scene): the frames a long run is decimated to,
the box of an inertia, and what a run without an orbit gets."""

from __future__ import annotations

import numpy as np
import pytest

import attitude
from attitude.errors import AttitudeValueError
from attitude.plotting._scene import MAX_FRAMES, box_from_inertia, frame_indices, scene


def test_every_sample_is_a_frame_up_to_the_limit():
    assert np.array_equal(frame_indices(5, 10), np.arange(5))
    assert np.array_equal(frame_indices(10, 10), np.arange(10))


def test_decimation_keeps_the_extremes_the_kept_samples_and_the_last():
    rng = np.random.default_rng(1)
    n = 864_001
    y = rng.normal(size=n)
    spike = 123_457
    y[spike] = 50.0  # a one-sample extreme
    dip = 700_001
    y[dip] = -50.0
    z = np.sin(np.arange(n) / 5000.0)
    z[400_000:400_010] = np.nan  # NaN ignored
    keep = [3, 555_555, 864_000, -5, n + 3]  # out-of-range indices ignored
    idx = frame_indices(n, 2000, extremes=[y, z], keep=keep)
    assert idx[0] == 0 and idx[-1] == n - 1
    assert np.all(np.diff(idx) > 0)
    assert {spike, dip, 3, 555_555} <= set(idx.tolist())
    assert 0.9 * 2000 < idx.size <= 2000 + len(keep)  # the budget is used
    # the extremes of every tenth of the run are among the frames (seeded data)
    for part in np.array_split(np.arange(n), 10):
        assert part[np.argmax(y[part])] in idx and part[np.argmin(y[part])] in idx
        assert part[np.nanargmax(z[part])] in idx


def test_box_of_an_inertia():
    a, b, c = box_from_inertia([900.0, 800.0, 600.0])
    i = np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(i / i[0], np.array([900.0, 800.0, 600.0]) / 900.0, rtol=1e-12)
    assert max(a, b, c) == 1.0
    # a rod (I1 + I2 = I3 exactly: no thickness): the missing side gets 5 % of the largest
    assert box_from_inertia([1.0, 1.0, 2.0])[2] == 0.05


def test_a_run_without_an_orbit_or_epoch():
    body = attitude.RigidBody([1.0, 2.0, 2.5])
    ds = attitude.propagate(body, [1.0, 0, 0, 0], [0, 0.2, 0.1, 0.3], np.linspace(0, 5, 11))
    s = scene(ds)
    assert s.position is None and s.sun is None and s.lvlh_q is None
    assert s.no_orbit and "no orbit" in s.no_orbit
    assert s.box is not None and not s.facets
    assert s.time_unit == "1" and s.n_samples == 11 and s.index.size == 11
    assert [x["name"] for x in s.series] == ["|ω|"]
    np.testing.assert_array_equal(s.q, ds.q.values)


def test_bad_arguments():
    body = attitude.RigidBody([1.0, 2.0, 2.5])
    ds = attitude.propagate(body, [1.0, 0, 0, 0], [0, 0.2, 0.1, 0.3], np.linspace(0, 5, 11))
    with pytest.raises(AttitudeValueError, match="max_frames"):
        scene(ds, max_frames=1)
    with pytest.raises(AttitudeValueError, match="not an ensemble"):
        scene(ds, member=0)
    with pytest.raises(AttitudeValueError, match="not an attitude result"):
        scene(ds.drop_vars("q"))
    assert MAX_FRAMES == 20_000
