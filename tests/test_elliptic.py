"""Tests of the compiled special functions in attitude._core.elliptic.

Truth: mpmath at 60–400 digits (ellipfun, ellipk, ellipf, ellippi, elliprf, elliprj) and
scipy.special (ellipj, ellipk, ellipkm1, elliprf, elliprj, elliprd, elliprc) where scipy is
itself accurate. Tolerances are stated in units of eps = 2**-52.

Jacobi functions are compared with a condition-aware error: a double-precision argument u
carries an uncertainty of ~eps (|u| + K) (representation of u and of the period used for the
reduction), so near a zero of cn (u ≈ K) no algorithm can deliver relative accuracy; the
error is therefore measured as |f − f_ref| / (eps (|f_ref| + (|u| + 4K) |f'_ref|)).
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import scipy.special as sp

from attitude._core import elliptic as E

EPS = 2.0**-52
M1_VALUES = [1.0, 0.9, 0.5, 0.49999, 0.3, 1e-3, 1e-4, 1e-8, 1e-12, 1e-16, 1e-30, 1e-100, 1e-300]


def _sncndn(u, m, m1, K):
    s, c, d, j = E.ellipj_reduced(u, m, m1, K)
    if j % 2:
        s, c = -s, -c
    return s, c, d


@pytest.mark.parametrize("m1", M1_VALUES)
def test_ellipj_against_mpmath_including_near_m_1(m1):
    rng = np.random.default_rng(int(-math.log10(m1) * 7) + 1)
    dps = 60 if m1 > 1e-40 else 400
    with mpmath.workdps(dps):
        mm = 1 - mpmath.mpf(m1)  # exact m = 1 - m1 (m itself is not representable near 1)
        m = 1.0 - m1
        K = E.ellipkm1(m1)
        assert abs(K - mpmath.ellipk(mm)) <= 2 * EPS * K
        us = np.concatenate(
            [
                rng.uniform(-4 * K, 4 * K, 25),
                [0.0, 1e-300, 1e-10, K, K / 2, K * 0.5000001, K * 0.4999999, K - 1e-9],
                [K * 0.99, K * 1.01, 3 * K, -2.5 * K, 37.25 * K],
            ]
        )
        worst = 0.0
        for u in us:
            s, c, d = _sncndn(u, m, m1, K)
            mu = mpmath.mpf(u)
            rs, rc, rd = (mpmath.ellipfun(f, mu, m=mm) for f in ("sn", "cn", "dn"))
            cond = abs(u) + 4 * K
            errs = (
                abs(s - rs) / (abs(rs) + cond * abs(rc * rd)),
                abs(c - rc) / (abs(rc) + cond * abs(rs * rd)),
                abs(d - rd) / (abs(rd) + cond * abs(mm * rs * rc)),
            )
            worst = max(worst, *(float(e) / EPS for e in errs))
        assert worst < 4.0, worst


def test_ellipj_against_scipy_for_moderate_m():
    rng = np.random.default_rng(2)
    m = rng.uniform(0.0, 0.999, 400)
    m[:3] = [0.0, 0.5, 0.25]
    u = rng.uniform(-30.0, 30.0, 400)
    ref = sp.ellipj(u, m)
    for i in range(400):
        K = E.ellipk(m[i])
        s, c, d = E.ellipj(u[i], m[i])
        rs, rc, rd = ref[0][i], ref[1][i], ref[2][i]
        cond = EPS * (abs(u[i]) + 4 * K) * 4
        assert abs(s - rs) <= 8 * EPS * abs(rs) + cond
        assert abs(c - rc) <= 8 * EPS * abs(rc) + cond
        assert abs(d - rd) <= 8 * EPS * abs(rd) + cond


def test_ellipj_identities_and_limits():
    rng = np.random.default_rng(3)
    for m1 in [0.7, 0.2, 1e-6, 1e-14]:
        m = 1.0 - m1
        K = E.ellipkm1(m1)
        for u in rng.uniform(-10 * K, 10 * K, 50):
            s, c, d = _sncndn(u, m, m1, K)
            assert abs(s * s + c * c - 1.0) <= 6 * EPS  # DLMF 22.6.1
            assert abs(d * d - (m1 + m * c * c)) <= 6 * EPS  # DLMF 22.6.1
            s4, c4, d4 = _sncndn(u + 4 * K, m, m1, K)
            tol = 8 * EPS * (abs(u) + 8 * K)
            assert abs(s4 - s) < tol and abs(c4 - c) < tol and abs(d4 - d) < tol
    # m = 0: circular functions; m = 1: hyperbolic functions (DLMF 22.5.3, 22.5.4)
    for u in [0.3, -2.0, 7.5]:
        s, c, d = E.ellipj(u, 0.0)
        assert abs(s - math.sin(u)) < 2 * EPS and abs(c - math.cos(u)) < 4 * EPS * 8 and d == 1
        s, c, d = E.ellipj(u, 1.0)
        assert abs(s - math.tanh(u)) < 2 * EPS and abs(c - 1 / math.cosh(u)) < 4 * EPS * c
        assert d == c
    s, c, d = E.ellipj(800.0, 1.0)  # no overflow far along the separatrix
    assert s == 1.0 and 0.0 <= c < 1e-300


@pytest.mark.parametrize("p", [1.0, 0.5, 1e-3, 1e-8, 1e-16, 1e-40, 1e-300, 3.0])
def test_ellipkm1_against_scipy_and_mpmath(p):
    K = E.ellipkm1(p)
    assert abs(K - sp.ellipkm1(p)) <= 2 * EPS * K
    with mpmath.workdps(400):
        assert abs(K - float(mpmath.ellipk(1 - mpmath.mpf(p)))) <= 2 * EPS * K
    if 1e-10 < p <= 1.0:
        assert abs(E.ellipk(1.0 - p) - sp.ellipk(1.0 - p)) <= 2 * EPS * K
    assert E.ellipkm1(0.0) == math.inf


def test_carlson_against_scipy():
    rng = np.random.default_rng(4)
    worst = np.zeros(4)
    for _ in range(1500):
        x, y, z = 10.0 ** rng.uniform(-20, 5, 3)
        if rng.random() < 0.1:
            x = 0.0
        p = max(x, y, z) * 10.0 ** rng.uniform(0, 3)  # the range used by Π with n ≤ 0
        vals = (
            (E.elliprf(x, y, z), sp.elliprf(x, y, z)),
            (E.elliprj(x, y, z, p), sp.elliprj(x, y, z, p)),
            (E.elliprd(x, y, z), sp.elliprd(x, y, z)),
            (E.elliprc(y, z), sp.elliprc(y, z)),
        )
        worst = np.maximum(worst, [abs(a - b) / abs(b) / EPS for a, b in vals])
    # scipy's RJ itself is off by up to ~10 ulp here (checked against mpmath below), so the
    # comparison allows 16 ulp for RJ and 4 ulp for the others
    assert np.all(worst < [4.0, 16.0, 4.0, 4.0]), worst


def test_carlson_against_mpmath_wide_range():
    # including p far below x, y, z, where scipy's RJ loses up to 1e5 ulp but ours must not
    rng = np.random.default_rng(5)
    with mpmath.workdps(40):
        for _ in range(150):
            x, y, z = 10.0 ** rng.uniform(-20, 5, 3)
            p = 10.0 ** rng.uniform(-10, 5)
            rf, rj = E.elliprf_rj(x, y, z, p)
            assert abs(rf - float(mpmath.elliprf(x, y, z))) <= 6 * EPS * rf
            assert abs(rj - float(mpmath.elliprj(x, y, z, p))) <= 8 * EPS * rj
            assert abs(rf - E.elliprf(x, y, z)) <= 8 * EPS * rf
    # closed-form special values (DLMF 19.20.1, 19.20.5, 19.2.17-19)
    assert abs(E.elliprf(1.0, 1.0, 1.0) - 1.0) < EPS
    assert abs(E.elliprj(2.0, 2.0, 2.0, 2.0) - 2.0**-1.5) < 2 * EPS
    assert abs(E.elliprc(0.0, 1.0) - math.pi / 2) < 2 * EPS
    assert abs(E.elliprc(1.0, 0.5) - math.log(1 + math.sqrt(2)) * math.sqrt(2)) < 4 * EPS
    assert abs(E.elliprc(1.0, -3.0) - sp.elliprc(1.0, -3.0)) < 4 * EPS * abs(sp.elliprc(1, -3))


def test_legendre_integrals_against_mpmath():
    rng = np.random.default_rng(6)
    with mpmath.workdps(60):
        for m1 in [0.9, 0.4, 1e-5, 1e-12]:
            m = 1.0 - m1
            mm = 1 - mpmath.mpf(m1)
            K = E.ellipkm1(m1)
            for n in [0.0, -0.3, -1.0, -m]:
                Pic = E.ellippi_complete(n, m1, K)
                ref = mpmath.ellippi(n, mm)
                assert abs(Pic - ref) <= 4 * EPS * abs(ref)
            for r in rng.uniform(-K, K, 8):
                s, c, d, j = E.ellipj_reduced(r, m, m1, K)
                assert j == 0 and c >= 0
                phi = mpmath.atan2(s, c)  # |phi| <= pi/2 since cn >= 0
                F = E.ellipf_sc(s, c, d)
                assert abs(F - float(mpmath.ellipf(phi, mm))) <= 4 * EPS * (abs(F) + 1)
                assert abs(F - r) <= 16 * EPS * K  # F inverts sn on [-K, K]
                for n in [-0.3, -1.0, -m]:
                    Pi = E.ellippi_sc(n, s, c, d)
                    ref = float(mpmath.ellippi(n, phi, mm))
                    assert abs(Pi - ref) <= 6 * EPS * (abs(ref) + 1)
