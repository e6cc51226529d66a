"""The Orekit reference orbits (tests/data/orekit_numerical_orbit.npz) against the package's
force models and frames, integrated by scipy (no Orekit needed).

Truth: Orekit 13.1.9's ``NumericalPropagator`` (tools/orekit_numerical_orbit_reference.py;
tests/data/README.md): EGM2008 20 × 20 (case A), with the Sun and the Moon (B), 70 × 70 (C), one
day from 2026-03-20 at 60 s, with Orekit's frames made astropy's (7.4e-12 rad) and the
package's Sun and Moon positions. Here ``solve_ivp`` (DOP853) propagates the same initial
states with ``orbit.SphericalHarmonics``, ``orbit.frames.gcrs_to_itrs_matrix`` and
``orbit.ThirdBody`` (tools/orekit_numerical_orbit_crosscheck.py): one orbit by default (Orekit
within 3e-7 m), the whole day with ``-m slow`` (within 1.3e-5 m). The numerical orbit of the
package is checked against the same file in its own tests.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data" / "orekit_numerical_orbit.npz"


@pytest.fixture(scope="module")
def ref():
    with np.load(DATA) as d:
        return {k: d[k] for k in d.files}


@pytest.fixture(scope="module")
def crosscheck():
    path = ROOT / "tools" / "orekit_numerical_orbit_crosscheck.py"
    spec = importlib.util.spec_from_file_location("orekit_numerical_orbit_crosscheck", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_reference_file(ref):
    """What the generator recorded: its frames agree with astropy's, its runs converged."""
    assert str(ref["epoch"]) == "2026-03-20T00:00:00 UTC"
    assert ref["frame_angle_linear_simple"] < 1e-11
    assert ref["tt_minus_utc_orekit"] == pytest.approx(ref["tt_minus_utc_astropy"], abs=1e-9)
    assert ref["mu"] == 3.986004415e14
    for case, degree, bodies in (("A", 20, []), ("B", 20, ["sun", "moon"]), ("C", 70, [])):
        assert ref[f"{case}_t"].shape == (1441,) and ref[f"{case}_r"].shape == (1441, 3)
        assert ref[f"{case}_degree"] == degree and list(ref[f"{case}_bodies"]) == bodies
        assert ref[f"{case}_convergence_r"] < 1e-4  # m
        np.testing.assert_array_equal(ref[f"{case}_r"][0], ref[f"{case}_r0"])


@pytest.mark.parametrize("case", ["A", "B", "C"])
def test_one_orbit(ref, crosscheck, case):
    t, r, v, _ = crosscheck.propagate(ref, case, t_end=5760.0)
    k = t.size
    assert k == 97
    assert np.max(np.linalg.norm(r - ref[f"{case}_r"][:k], axis=1)) < 2e-6  # m; 3e-7 measured
    assert np.max(np.linalg.norm(v - ref[f"{case}_v"][:k], axis=1)) < 2e-9  # m/s


@pytest.mark.slow
@pytest.mark.parametrize("case", ["A", "B", "C"])
def test_one_day(ref, crosscheck, case):
    t, r, v, _ = crosscheck.propagate(ref, case)
    assert t.size == 1441
    assert np.max(np.linalg.norm(r - ref[f"{case}_r"], axis=1)) < 1e-4  # m; 1.3e-5 measured
    assert np.max(np.linalg.norm(v - ref[f"{case}_v"], axis=1)) < 1e-7  # m/s
