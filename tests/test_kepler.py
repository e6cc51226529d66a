"""Kepler's equation and anomaly conversions against a 50-digit mpmath reference.

The reference roots are computed independently of the solver: Newton's method in mpmath
(90 working digits) started from an upper bound of the root, where the Kepler function is
increasing and convex, so the iteration decreases monotonically to the root.
"""

from __future__ import annotations

import math
import os
from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest

from orbit import _kernels as K
from orbit._shared_jit import JIT_DISABLED
from orbit.errors import OrbitTypeError, OrbitValueError
from orbit.kepler import (
    eccentric_from_true,
    hyperbolic_from_true,
    mean_from_eccentric,
    mean_from_hyperbolic,
    mean_from_true,
    mean_from_true_hyperbolic,
    solve_kepler,
    solve_kepler_hyperbolic,
    true_from_eccentric,
    true_from_hyperbolic,
    true_from_mean,
    true_from_mean_hyperbolic,
)

mp.mp.dps = 50
SEED = int(os.environ.get("KEPLER_TEST_SEED", "20240607"))


# ---------------------------------------------------------------------------------------------
# Independent arbitrary-precision references.
def _newton_from_right(g, dg, x):
    for _ in range(3000):
        d = g(x) / dg(x)
        x = x - d
        if abs(d) <= mp.mpf(10) ** -70 * abs(x):
            return x
    raise RuntimeError("reference did not converge")


def exact_E(M, e):
    """Root of E − e sin E = M (M, e exact binary floats), 50+ digits."""
    with mp.workdps(90):
        M = mp.mpf(M)
        e = mp.mpf(e)
        k = mp.floor(M / (2 * mp.pi) + mp.mpf(1) / 2)
        Mr = M - 2 * mp.pi * k
        s = 1 if Mr >= 0 else -1
        Mr = abs(Mr)
        if Mr == 0:
            return +(2 * mp.pi * k)
        hi = mp.pi  # upper bounds: E − e sin E >= (1 − e) E and >= e E³/6 (1 − π²/20)
        if e < 1:
            hi = min(hi, Mr / (1 - e))
        if e > 0:
            hi = min(hi, mp.cbrt(6 * Mr / (e * (1 - mp.pi**2 / 20))))
        E = _newton_from_right(lambda x: x - e * mp.sin(x) - Mr, lambda x: 1 - e * mp.cos(x), hi)
        return +(s * E + 2 * mp.pi * k)


def exact_H(M, e):
    """Root of e sinh H − H = M, 50+ digits."""
    with mp.workdps(90):
        M = mp.mpf(M)
        e = mp.mpf(e)
        s = 1 if M >= 0 else -1
        M = abs(M)
        if M == 0:
            return mp.mpf(0)
        hi = min(mp.asinh(M / (e - 1)), mp.cbrt(6 * M / e))  # both bound the root from above
        H = _newton_from_right(lambda x: e * mp.sinh(x) - x - M, lambda x: e * mp.cosh(x) - 1, hi)
        return +(s * H)


def ulp(x):
    return np.spacing(np.abs(np.float64(x)))


def _grid_elliptic():
    rng = np.random.default_rng(SEED)
    es = np.concatenate(
        [
            [0.0, 1e-300, 1e-12, 1e-3, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.99, 0.999, 0.9999],
            1.0 - np.geomspace(1e-5, 1e-9, 9),
        ]
    )
    Ms = np.concatenate(
        [
            np.linspace(0.0, math.pi, 41),
            np.geomspace(1e-300, 1e-3, 24),
            math.pi - np.geomspace(1e-12, 1e-2, 6),
            [math.pi, np.nextafter(math.pi, 0.0), 2.0, 2.1, 1.9],
        ]
    )
    Ms = np.concatenate([Ms, -Ms[1::3]])
    MM, EE = np.meshgrid(Ms, es)
    # Plus random points concentrated on the hard corner (e -> 1, M -> 0) and on E ~ 2.
    n = 1500
    Mr = np.concatenate([10 ** rng.uniform(-15, math.log10(math.pi), n), rng.uniform(1.0, 2.6, n)])
    er = 1.0 - 10 ** rng.uniform(-9, 0, 2 * n)
    return np.concatenate([MM.ravel(), Mr]), np.concatenate([EE.ravel(), er])


def test_solve_kepler_against_mpmath_dense_grid():
    M, e = _grid_elliptic()
    E = solve_kepler(M, e)
    worst_err = worst_res = worst_ulp = 0.0
    for Mi, ei, Ei in zip(M.tolist(), e.tolist(), E.tolist(), strict=True):
        Ex = exact_E(Mi, ei)
        err = abs(mp.mpf(Ei) - Ex)
        # Honest residual: the returned float E evaluated exactly (50 digits).
        res = abs(mp.mpf(Ei) - mp.mpf(ei) * mp.sin(mp.mpf(Ei)) - mp.mpf(Mi))
        worst_err = max(worst_err, float(err))
        worst_res = max(worst_res, float(res / (4e-16 * max(1.0, abs(Mi)))))
        if abs(Ei) > 1e-290:  # normal range: the relative error is meaningful
            worst_ulp = max(worst_ulp, float(err / ulp(Ei)))
    # Measured 2.52e-16 to 2.54e-16 rad over nine seeds (README: "within 2.5e-16 rad"): the
    # grid's largest |E| is π, where one ulp is 4.4e-16.
    assert worst_err <= 4e-16
    assert worst_res <= 1.0  # measured 0.73-0.82
    # ~correctly rounded: measured 1.12-1.32 ulp over nine seeds (documented "about 1.3 ulp")
    assert worst_ulp <= 1.5


def test_kepler_residual_is_exact_but_for_the_sine():
    """The solver's residual E − e sin E − (M + M_lo) is evaluated in double-double: on [1, π]
    the only rounding left is the one of sin E, on [0, 1) the one of the series E − sin E. So
    with those two floats taken as they are, the residual must equal the exact one to the
    rounding of the double-double sum (a few 2^-106 M), at the root (total cancellation) and
    at a starter-sized distance from it. Dropping any low-order part of the error-free sums
    and products (or M_lo) makes the difference ~2^-53 M."""
    rng = np.random.default_rng(SEED + 7)
    n = 1500
    M = np.concatenate([10 ** rng.uniform(-12, math.log10(math.pi), n), rng.uniform(0.5, 3.1, n)])
    e = np.concatenate([1 - 10 ** rng.uniform(-9, 0, n), rng.uniform(0, 1, n)])
    root = solve_kepler(M, e)
    M_lo = rng.uniform(-0.5, 0.5, M.size) * ulp(M)  # the low part of a reduced M
    worst = {"below 1": 0.0, "above 1": 0.0}
    for rel in (0.0, 1e-4):  # at the root, and where Markley's starter lands (rel. error 3e-4)
        E = np.minimum(root * (1 + rel * rng.uniform(-1, 1, M.size)), math.pi)
        for Ei, Mi, li, ei in zip(E.tolist(), M.tolist(), M_lo.tolist(), e.tolist(), strict=True):
            _residual_error(Ei, Mi, li, ei, worst)
    # measured 2.8 (E < 1) and 1.7 (E >= 1) units of 2^-106 M beyond the rounding of f0;
    # a dropped low-order part or M_lo: ~2^52 units
    assert max(worst.values()) <= 16.0, worst


# The cancellation-free series of the kernels (the "_kepler" ones are truncated variants for
# the elliptic residual, where they exist).
SERIES = [
    (name, ref, xmax)
    for name, ref, xmax in [
        ("_x_minus_sin", lambda x: x - mp.sin(x), 1.0),
        ("_one_minus_cos", lambda x: 1 - mp.cos(x), 1.0),
        ("_x_minus_sin_kepler", lambda x: x - mp.sin(x), 1.0),
        ("_one_minus_cos_kepler", lambda x: 1 - mp.cos(x), 1.0),
        ("_sinh_minus_x", lambda x: mp.sinh(x) - x, 2.5),
        ("_cosh_minus_one", lambda x: mp.cosh(x) - 1, 2.5),
    ]
    if hasattr(K, name)
]


@pytest.mark.parametrize("name,ref,xmax", SERIES, ids=[s[0] for s in SERIES])
def test_cancellation_free_series_are_accurate(name, ref, xmax):
    """The Taylor series behind the residuals and their derivatives, to a few roundings over
    their whole range (the docstrings say ~1 ulp). Measured largest relative errors: 3.3, 2.2,
    3.7 and 3.1 units of 2^-53. cosh H − 1 enters only the Halley derivative, so the solver's
    results do not see a wrong coefficient there (found by cosmic-ray): this test does."""
    f = getattr(K, name)
    x = np.concatenate([np.linspace(-xmax, xmax, 2001), np.geomspace(1e-8, xmax, 300)])
    worst = 0.0
    with mp.workdps(40):
        for xi in x.tolist():
            r = ref(mp.mpf(xi))
            if r == 0:
                assert f(xi) == 0.0
                continue
            worst = max(worst, float(abs(mp.mpf(f(xi)) - r) / abs(r)) / 2.0**-53)
    assert worst <= 8.0, worst


def _residual_error(Ei, Mi, li, ei, worst):
    """Error of the kernel's residual beyond the rounding of f0, in units of 2^-106 M."""
    f0, _, sn, _ = K._kepler_residual(Ei, Mi, li, ei, 1.0 - ei)
    with mp.workdps(60):  # whatever global precision other test modules set
        if Ei < 1.0:
            # the series value the kernel's residual uses
            S = getattr(K, "_x_minus_sin_kepler", K._x_minus_sin)(Ei)
            exact = mp.mpf(1.0 - ei) * Ei + mp.mpf(ei) * S - Mi - li
            key = "below 1"
        else:
            exact = mp.mpf(Ei) - mp.mpf(ei) * sn - Mi - li
            key = "above 1"
        err = abs(mp.mpf(f0) - exact) - 2.0**-53 * abs(f0)
        worst[key] = max(worst[key], float(err / (2.0**-106 * Mi)))


def test_solve_kepler_large_mean_anomaly_reduction():
    # M far outside [−π, π], including M = 2πk + tiny (the hard corner after reduction).
    rng = np.random.default_rng(SEED + 1)
    M = np.concatenate(
        [
            rng.uniform(-40.0, 40.0, 200),
            [2 * math.pi * 1000 + 1e-9, -2 * math.pi * 7 + 1e-13, 1e6 + 0.5, -3.3e9, 1e15],
            2 * math.pi * rng.integers(1, 10**6, 40) + 10 ** rng.uniform(-12, 0, 40),
        ]
    )
    e = np.concatenate([rng.uniform(0, 1, 200), [0.99999, 1 - 1e-9, 0.5, 0.3, 0.9]])
    e = np.concatenate([e, 1 - 10 ** rng.uniform(-9, -1, 40)])
    E = solve_kepler(M, e)
    for Mi, ei, Ei in zip(M.tolist(), e.tolist(), E.tolist(), strict=True):
        Ex = exact_E(Mi, ei)
        err = abs(mp.mpf(Ei) - Ex)
        res = abs(mp.mpf(Ei) - mp.mpf(ei) * mp.sin(mp.mpf(Ei)) - mp.mpf(Mi))
        assert res <= 4e-16 * max(1.0, abs(Mi)), (Mi, ei)
        # |E| <= 64: 1e-14 rad; beyond, E is a float of spacing ulp(E) > 1e-14: 1 ulp.
        assert err <= max(1e-14, 1.0 * ulp(Ei)), (Mi, ei, float(err))


def test_solve_kepler_edge_values_and_symmetry():
    e = np.array([0.0, 0.2, 0.9, 1 - 1e-9])
    assert np.all(solve_kepler(0.0, e) == 0.0)
    assert np.all(solve_kepler(math.pi, e) == math.pi)
    M = np.linspace(-12.0, 12.0, 997)
    assert np.array_equal(solve_kepler(M, 0.0), M)  # e = 0: E = M exactly
    for ei in e:
        assert np.array_equal(solve_kepler(-M, ei), -solve_kepler(M, ei))
    assert isinstance(solve_kepler(1.0, 0.5), float)
    assert solve_kepler(np.ones((2, 3)), np.array([0.1, 0.2, 0.3])).shape == (2, 3)


@pytest.mark.parametrize("e", [0.0, 0.3, 0.97, 1 - 1e-9])
def test_solve_kepler_continuous_across_reduction_boundaries(e):
    # Across M = (2k + 1)π the reduction switches k; E must not jump, and E(M + 2π) = E(M) + 2π.
    for k in (0, 1, 5, -3, 1000):
        c = (2 * k + 1) * math.pi
        M = c + np.arange(-20, 21) * ulp(c)
        E = solve_kepler(M, e)
        dE = np.diff(E)
        assert np.all(dE >= -2 * ulp(c)) and np.all(dE <= 4 * ulp(c))
        assert abs(E[20] - c) <= 2 * ulp(c)
    # E(M + 2πk) − 2πk = E(M): the float M + 2πk carries a rounding of ulp/2, amplified by
    # dE/dM = 1/(1 − e cos E) <= 1/(1 − e) (exact periodicity is checked against mpmath above).
    M = np.linspace(-3.2, 3.2, 641)
    for k in (1, 3, 100):
        shifted = solve_kepler(M + 2 * math.pi * k, e) - 2 * math.pi * k
        tol = 2 * ulp(2 * math.pi * k + 4) * (1 + 1 / (1 - e))
        assert np.max(np.abs(shifted - solve_kepler(M, e))) <= tol


def test_solve_kepler_monotone_near_hard_corner():
    M = np.geomspace(1e-16, 1e-2, 4000)
    for e in (1 - 1e-6, 1 - 1e-9):
        E = solve_kepler(M, e)
        assert np.all(np.diff(E) > 0)


# ---------------------------------------------------------------------------------------------
def _grid_hyperbolic():
    rng = np.random.default_rng(SEED + 2)
    e_min = np.nextafter(1.0, 2.0)
    es = np.concatenate(
        [[e_min, 1 + 1e-12], 1 + np.geomspace(1e-9, 1e-1, 5), [1.5, 2, 5, 100, 1e6]]
    )
    Ms = np.concatenate([[1e-300, 1e-20], np.geomspace(1e-12, 1e12, 25), [1e300]])
    MM, EE = np.meshgrid(np.concatenate([Ms, -Ms[::4]]), es)
    n = 1200
    Mr = 10 ** rng.uniform(-14, 11, n)
    er = 1 + 10 ** rng.uniform(-9, 3, n)
    return np.concatenate([MM.ravel(), Mr]), np.concatenate([EE.ravel(), er])


def test_solve_kepler_hyperbolic_against_mpmath():
    M, e = _grid_hyperbolic()
    H = solve_kepler_hyperbolic(M, e)
    worst_ulp = worst_res = 0.0
    for Mi, ei, Hi in zip(M.tolist(), e.tolist(), H.tolist(), strict=True):
        Hx = exact_H(Mi, ei)
        err = abs(mp.mpf(Hi) - Hx)
        res = abs(mp.mpf(ei) * mp.sinh(mp.mpf(Hi)) - mp.mpf(Hi) - mp.mpf(Mi))
        # The float spacing of H sets the floor: residual <= 4e-16 max(1, |M|) max(1, |H|).
        worst_res = max(worst_res, float(res / (4e-16 * max(1, abs(Mi)) * max(1, abs(Hi)))))
        assert err <= 1e-14 * max(1.0, abs(Hi)), (Mi, ei)
        if abs(Hi) > 1e-290:
            worst_ulp = max(worst_ulp, float(err / ulp(Hi)))
    assert worst_res <= 1.0
    assert worst_ulp <= 1.5


def test_solve_kepler_hyperbolic_iteration_count_is_bounded():
    M = np.geomspace(1e-12, 1e12, 300)
    e = 1 + np.geomspace(1e-12, 1e4, 300)
    MM, EE = np.meshgrid(M, e)
    nit = np.empty(MM.size)
    K.kepler_H_iterations_loop(MM.ravel(), EE.ravel(), nit)
    assert nit.max() <= 3  # the loop guard (12) is never reached


def test_solve_kepler_hyperbolic_symmetry_and_zero():
    M = np.geomspace(1e-10, 1e10, 101)
    assert np.array_equal(solve_kepler_hyperbolic(-M, 1.7), -solve_kepler_hyperbolic(M, 1.7))
    assert solve_kepler_hyperbolic(0.0, 3.0) == 0.0


# ---------------------------------------------------------------------------------------------
# Anomaly conversions: closed forms evaluated in mpmath, and round trips.
def _true_from_E_mp(E, e):
    E, e = mp.mpf(E), mp.mpf(e)
    # continuous branch: f − E = 2 atan(β sin E / (1 − β cos E)), β = e/(1 + sqrt(1 − e²))
    b = e / (1 + mp.sqrt(1 - e * e))
    return E + 2 * mp.atan(b * mp.sin(E) / (1 - b * mp.cos(E)))


def test_true_eccentric_conversions_against_mpmath():
    rng = np.random.default_rng(SEED + 3)
    E = np.concatenate([rng.uniform(-20, 20, 300), [0.0, math.pi, -math.pi, 1e-200]])
    e = np.concatenate([rng.uniform(0, 1, 150), 1 - 10 ** rng.uniform(-9, -1, 150), [0.5] * 4])
    f = true_from_eccentric(E, e)
    for Ei, ei, fi in zip(E.tolist(), e.tolist(), f.tolist(), strict=True):
        fx = _true_from_E_mp(Ei, ei)
        assert abs(mp.mpf(fi) - fx) <= 8e-16 * max(1.0, abs(fx)), (Ei, ei)
    E2 = eccentric_from_true(f, e)
    # The inverse is ill-conditioned near apoapsis as e -> 1 (dE/df = sqrt(1 − e²)/(1 + e cos f)
    # is tiny there, df/dE huge): compare in f.
    f2 = true_from_eccentric(E2, e)
    assert np.max(np.abs(f2 - f) / np.maximum(1, np.abs(f))) <= 2e-15
    assert np.max(np.abs(E2 - E)[e < 0.99] / np.maximum(1, np.abs(E[e < 0.99]))) <= 1e-14


def test_mean_from_eccentric_against_mpmath():
    rng = np.random.default_rng(SEED + 4)
    E = np.concatenate([rng.uniform(-10, 10, 200), 10 ** rng.uniform(-12, 0, 100)])
    e = np.concatenate([rng.uniform(0, 1, 200), 1 - 10 ** rng.uniform(-9, -3, 100)])
    M = mean_from_eccentric(E, e)
    for Ei, ei, Mi in zip(E.tolist(), e.tolist(), M.tolist(), strict=True):
        Mx = mp.mpf(Ei) - mp.mpf(ei) * mp.sin(mp.mpf(Ei))
        # relative accuracy (a few ulp) even in the hard corner (E small, e -> 1)
        assert abs(mp.mpf(Mi) - Mx) <= 6e-16 * max(abs(Mx), 4e-16 * abs(Ei)) + 1e-300, (Ei, ei)


def test_true_mean_round_trip_elliptic():
    rng = np.random.default_rng(SEED + 5)
    M = rng.uniform(-50, 50, 2000)
    e = rng.uniform(0, 0.98, 2000)
    f = true_from_mean(M, e)
    assert np.allclose(f, true_from_eccentric(solve_kepler(M, e), e), rtol=0, atol=1e-14)
    M2 = mean_from_true(f, e)
    assert np.max(np.abs(M2 - M)) <= 1e-13
    # f is continuous in M: no jumps of 2π.
    Ms = np.linspace(-30, 30, 20001)
    fs = true_from_mean(Ms, 0.7)
    assert np.all(np.diff(fs) > 0) and np.max(np.diff(fs)) < 0.1


def test_hyperbolic_conversions_against_mpmath():
    rng = np.random.default_rng(SEED + 6)
    H = np.concatenate([rng.uniform(-8, 8, 200), 10 ** rng.uniform(-12, 0, 50)])
    e = np.concatenate([1 + 10 ** rng.uniform(-6, 2, 200), 1 + 10 ** rng.uniform(-9, 0, 50)])
    f = true_from_hyperbolic(H, e)
    M = mean_from_hyperbolic(H, e)
    for Hi, ei, fi, Mi in zip(H.tolist(), e.tolist(), f.tolist(), M.tolist(), strict=True):
        Hm, em = mp.mpf(Hi), mp.mpf(ei)
        fx = 2 * mp.atan(mp.sqrt((em + 1) / (em - 1)) * mp.tanh(Hm / 2))
        Mx = em * mp.sinh(Hm) - Hm
        assert abs(mp.mpf(fi) - fx) <= 1e-15 * max(1, abs(fx)), (Hi, ei)
        assert abs(mp.mpf(Mi) - Mx) <= 1e-15 * abs(Mx) + 1e-300, (Hi, ei)
        assert abs(fi) < math.acos(-1 / ei)
    assert np.allclose(hyperbolic_from_true(f, e), H, rtol=1e-9, atol=1e-12)
    assert np.allclose(true_from_mean_hyperbolic(M, e), f, rtol=1e-12, atol=1e-13)
    assert np.allclose(mean_from_true_hyperbolic(f, e), M, rtol=1e-8, atol=1e-12)


def test_units_are_converted():
    from astropy import units as u

    assert solve_kepler(60 * u.deg, 0.3) == pytest.approx(solve_kepler(math.pi / 3, 0.3), 1e-15)
    assert true_from_mean(1 * u.rad, 0.1 * u.one) == true_from_mean(1.0, 0.1)
    with pytest.raises(OrbitTypeError, match="M"):
        solve_kepler(3 * u.m, 0.1)
    with pytest.raises(OrbitTypeError, match="e"):
        solve_kepler(1.0, 0.1 * u.s)


@pytest.mark.parametrize(
    "func, args, match",
    [
        (solve_kepler, (1.0, 1.0), "e: .*parabola"),
        (solve_kepler, (1.0, -0.1), "e: .*negative"),
        (solve_kepler, (1.0, 1.2), "solve_kepler_hyperbolic"),
        (solve_kepler, (np.nan, 0.1), "M: must be finite"),
        (solve_kepler, (1.0, np.inf), "e: must be finite"),
        (solve_kepler, (2.0**51, 0.1), "M: .*2\\*\\*50"),
        (solve_kepler_hyperbolic, (1.0, 1.0), "e: .*e > 1"),
        (solve_kepler_hyperbolic, (1.0, 0.5), "e: .*elliptic"),
        (solve_kepler_hyperbolic, (1.0, 1e200), "e: .*1e100"),
        (true_from_mean, (1.0, 1.5), "true_from_mean_hyperbolic"),
        (hyperbolic_from_true, (2.5, 1.5), "f: .*acos"),
        (mean_from_true_hyperbolic, (-2.5, 1.5), "f: .*acos"),
        (mean_from_hyperbolic, (800.0, 1.5), "H: .*709"),
        (solve_kepler, ("x", 0.1), "M: expected real numbers"),
        (solve_kepler, (np.ones(3), np.full(2, 0.1)), "broadcast"),
    ],
)
def test_bad_input_raises_named_errors(func, args, match):
    with pytest.raises((OrbitValueError, OrbitTypeError), match=match):
        func(*args)


# ---------------------------------------------------------------------------------------------
# Internals the accuracy rests on.
def test_two_product_and_reduction_are_exact():
    rng = np.random.default_rng(SEED + 7)
    for a, b in zip(rng.normal(size=200) * 1e3, rng.normal(size=200), strict=True):
        p, err = K._two_prod(float(a), float(b))
        assert Fraction(p) + Fraction(err) == Fraction(float(a)) * Fraction(float(b))
        s, err = K._two_sum(float(a), float(b))
        assert Fraction(s) + Fraction(err) == Fraction(float(a)) + Fraction(float(b))
    for x in np.concatenate([rng.uniform(-1e6, 1e6, 100), [7.0, -4.0, 2 * math.pi * 3e8]]):
        r, r_lo, k = K.reduce_angle(float(x))
        with mp.workdps(80):
            exact = mp.mpf(float(x)) - 2 * mp.pi * int(k)
            assert -mp.pi <= exact <= mp.pi
            assert abs(mp.mpf(r) + mp.mpf(r_lo) - exact) <= mp.mpf(1e-30) * (1 + abs(k))


def test_starter_two_thirds_power_against_mpmath():
    # Markley's cube root without libm: relative error below 1e-9 (the starter needs 2.9e-4)
    # over the range the starter meets (x >= ~1e-25 for e <= 1 - 1e-16) and beyond.
    rng = np.random.default_rng(SEED + 8)
    xs = np.concatenate([10 ** rng.uniform(-40, 40, 300), [1.0, 8.0, 1e-300, 1e300]])
    for x in xs.tolist():
        got = K._pow_two_thirds(x)
        with mp.workdps(30):
            want = mp.mpf(x) ** (mp.mpf(2) / 3)
            assert abs(mp.mpf(got) / want - 1) < 1e-9, x


@pytest.mark.skipif(JIT_DISABLED, reason="numba JIT disabled")
def test_callable_from_numba():
    import numba

    @numba.njit
    def use(M, e):
        return solve_kepler(M, e), solve_kepler_hyperbolic(M, e + 1.0), K.kepler_E(M, e)

    E, H, E2 = use(1.3, 0.4)
    assert E == solve_kepler(1.3, 0.4) == E2
    assert H == solve_kepler_hyperbolic(1.3, 1.4)

    @numba.njit
    def use_array(M, e):
        return solve_kepler(M, e)

    M = np.linspace(-7, 7, 12).reshape(3, 4)
    assert np.array_equal(use_array(M, 0.6), solve_kepler(M, 0.6))
    with pytest.raises(OrbitValueError):
        use(1.0, 1.0)
