"""orbit.NumericalOrbit against heyoka's Taylor integrator: one day under EGM2008 20×20 with a
uniformly turning Earth (tests/data/heyoka_numerical_orbit.npz, written by
tools/heyoka_numerical_orbit_reference.py; heyoka is not needed here).

The reference: heyoka 7.13.2, ``taylor_adaptive`` at tol 1e-15 (order 19, high accuracy), the
same equations written in heyoka's own expressions (its own EGM2008 coefficients and recursion)
with θ = θ0 + ω t; against a tol 1e-13 run it moves by 3.0e-5 m at most over the day, so at
1e-15 its error is far below the bound here.

The bound: DOP853 at rtol 1e-13, atol 1e-12 (positions and velocities both held by rtol) ends
the day 7.3e-5 m from the same integrator at rtol = atol = 1e-15 (its own error at this
tolerance; at 1e-15 its round-off floor is a few µm), so 1e-4 m (1.5e-11 of the radius), and
n·1e-4 m ≈ 1.1e-7 m/s for the velocities (n the mean motion). Measured: 6.6e-5 m, 7.3e-8 m/s.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import orbit
import orbit.frames

DATA = Path(__file__).parent / "data" / "heyoka_numerical_orbit.npz"
POSITION_BOUND = 1e-4  # m
VELOCITY_BOUND = 1.1e-7  # m/s


@pytest.fixture(scope="module")
def ref():
    with np.load(DATA) as d:
        return {k: d[k] for k in d.files}


def _orbit(ref, monkeypatch, rtol, atol=1e-12, max_step=None):
    # θ0 as heyoka's run had it: a newer IERS table may move UT1 at the epoch by a fraction of
    # a millisecond, which would move the field, not test the integrator.
    theta0 = float(ref["theta0"])
    monkeypatch.setattr(
        orbit.frames, "_earth_rotation_angle", lambda times: np.full(times.size, theta0)
    )
    return orbit.NumericalOrbit(
        ref["r0_km"], ref["v0_km_s"], str(ref["epoch"]),
        gravity=orbit.SphericalHarmonics(int(ref["degree"]), int(ref["order"])),
        earth_rotation="uniform", rtol=rtol, atol=atol, max_step=max_step,
    )  # fmt: skip


def test_reference_is_the_projects_model(ref):
    # the same field constants, the same ERA convention (ERFA era00 of UT1) and rate
    field = orbit.SphericalHarmonics(int(ref["degree"]), int(ref["order"]))
    assert field.mu == ref["mu"] and field.radius == ref["radius"]
    assert ref["omega"] == 2.0 * math.pi * 1.00273781191135448 / 86400.0
    o = orbit.NumericalOrbit(ref["r0_km"], ref["v0_km_s"], str(ref["epoch"]),
                             gravity=field, earth_rotation="uniform")  # fmt: skip
    assert np.array_equal(o.initial_state, np.concatenate([ref["r0"], ref["v0"]]))
    # 1e-7 rad: IERS table updates (< 1 ms of UT1) pass, a wrong convention (UTC for UT1,
    # GMST for ERA) does not
    assert abs(o._forces._theta0 - float(ref["theta0"])) < 1e-7
    assert ref["check_max_dr"] < 1e-4  # heyoka's 1e-13 and 1e-15 runs


def test_one_day_egm2008_20x20_matches_heyoka(ref, monkeypatch):
    o = _orbit(ref, monkeypatch, rtol=1e-13)
    ds = o.propagate(ref["t"])
    dr = np.linalg.norm(ds.position.values - ref["r"], axis=1)
    dv = np.linalg.norm(ds.velocity.values - ref["v"], axis=1)
    assert np.max(dr) < POSITION_BOUND, np.max(dr)
    assert np.max(dv) < VELOCITY_BOUND, np.max(dv)


def test_the_reference_resolves_the_tolerance(ref, monkeypatch):
    # looser tolerances are seen (4e-3 m at rtol 1e-11 with hour-long steps allowed): the
    # comparison is not blind
    o = _orbit(ref, monkeypatch, rtol=1e-11, max_step=3600.0)
    dr = np.linalg.norm(o.propagate(ref["t"]).position.values - ref["r"], axis=1)
    assert 1e-3 < np.max(dr) < 1e-2
