"""Propagate the cases of tests/data/orekit_numerical_orbit.npz with scipy and the package's
force models and frames, and print how far Orekit's orbits are from them.

An independent check of the Orekit reference (tools/orekit_numerical_orbit_reference.py), not of
the package's propagator: plain ``scipy.integrate.solve_ivp`` (DOP853) on r'' = a(t, r) in the
GCRS, with

* the gravity field of ``orbit.SphericalHarmonics(degree)`` (EGM2008, central term included)
  evaluated at R(t) r and rotated back by R(t)ᵀ, where R(t) is astropy's GCRS → ITRS
  (``orbit.frames.gcrs_to_itrs_matrix``) every 600 s, interpolated as R3(θ(t)) M(t): the Earth
  rotation angle θ (ERFA ``era00`` of UT1, with UT1 − UTC interpolated linearly between the
  daily values of the IERS table, as astropy does) at every time, M = R3(θ)ᵀ R by degree-7
  Lagrange (the script prints its largest difference from astropy at 97 other times);
* for case B, the Sun and the Moon of ``orbit.ThirdBody`` (positions every 600 s, degree-7
  Lagrange; the package's third-body formula and GM).

Runs in the package's environment (no Orekit)::

    python tools/orekit_numerical_orbit_crosscheck.py [tests/data/orekit_numerical_orbit.npz]
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

NODE = 600.0  # s between the tabulated rotations and body positions
_W8 = np.array([(-1.0) ** j * math.comb(7, j) for j in range(8)])
_J8 = np.arange(8, dtype=np.float64)


def lagrange8(tg: np.ndarray, yg: np.ndarray, t: float) -> np.ndarray:
    """Degree-7 Lagrange interpolation (barycentric form) of ``yg`` at uniform nodes ``tg``."""
    h = tg[1] - tg[0]
    j0 = min(max(int(np.floor((t - tg[0]) / h)) - 3, 0), tg.size - 8)
    d = (t - tg[j0]) / h - _J8
    hit = np.flatnonzero(d == 0.0)
    if hit.size:
        return yg[j0 + hit[0]].copy()
    q = _W8 / d
    return np.tensordot(q, yg[j0 : j0 + 8], axes=1) / q.sum()


def r3(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


class Rotation:
    """R(t), x_ITRS = R x_GCRS, t in seconds from a UTC midnight, for one day."""

    def __init__(self, epoch, duration: float) -> None:
        import erfa
        from astropy.time import TimeDelta

        from orbit.frames import gcrs_to_itrs_matrix
        from orbit.timescales import iers_table, offline_iers

        assert epoch.utc.isot.endswith("T00:00:00.000") and duration <= 86400.0
        self.jd1 = float(epoch.utc.jd1 + epoch.utc.jd2)
        with offline_iers():
            tab = iers_table()
            ends = epoch + TimeDelta([0.0, 86400.0], format="sec")
            self.dut = tab.ut1_utc(ends).to_value("s")  # astropy: linear between these
        self.tc = NODE * np.arange(-4, int(duration / NODE) + 5, dtype=np.float64)
        rc = gcrs_to_itrs_matrix(epoch + TimeDelta(self.tc, format="sec"))
        self.era00 = erfa.era00
        self.mc = np.array([r3(self.theta(s)).T @ r for s, r in zip(self.tc, rc, strict=True)])

    def theta(self, t: float) -> float:
        dut = self.dut[0] + (self.dut[1] - self.dut[0]) * t / 86400.0  # exact on the day only
        return float(self.era00(self.jd1, (t + dut) / 86400.0))

    def __call__(self, t: float) -> np.ndarray:
        return r3(self.theta(t)) @ lagrange8(self.tc, self.mc, t)


def angle(d: np.ndarray) -> float:
    return 0.5 * float(np.linalg.norm([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]))


def propagate(ref, case: str, t_end: float | None = None, rtol: float = 3e-14):
    """scipy's solution of ``case`` of the reference file ``ref`` (a mapping) at its sample
    times up to ``t_end`` (default: all): t, r, v, the number of evaluations."""
    from astropy.time import Time
    from scipy.integrate import solve_ivp

    from orbit import SphericalHarmonics, ThirdBody
    from orbit import _gravity_field_kernels as kg

    epoch = Time(str(ref["epoch"]).removesuffix(" UTC"), scale="utc")
    t = ref[f"{case}_t"]
    t = t[t <= (t[-1] if t_end is None else t_end)]
    duration = float(t[-1])
    rot = Rotation(epoch, duration)
    field = SphericalHarmonics(int(ref[f"{case}_degree"]), int(ref[f"{case}_order"]))
    bodies = [str(b) for b in ref[f"{case}_bodies"]]
    tg = NODE * np.arange(-4, int(duration / NODE) + 5, dtype=np.float64)
    tables = {b: ThirdBody(b).position(epoch, tg) for b in bodies}
    mus = {b: ThirdBody(b).mu for b in bodies}

    def rhs(t, y):
        r = rot(t)
        a = r.T @ field.acceleration(r @ y[:3])
        for b in bodies:
            s = lagrange8(tg, tables[b], t)
            a = a + np.array(kg.third_body(mus[b], s[0], s[1], s[2], y[0], y[1], y[2]))
        return np.concatenate([y[3:], a])

    y0 = np.concatenate([ref[f"{case}_r0"], ref[f"{case}_v0"]])
    sol = solve_ivp(rhs, (0.0, duration), y0, method="DOP853", t_eval=t, rtol=rtol, atol=1e-9,
                    max_step=30.0)  # fmt: skip
    assert sol.success, sol.message
    return t, sol.y[:3].T, sol.y[3:].T, sol.nfev


def main() -> None:
    from astropy.time import Time, TimeDelta

    from orbit.frames import gcrs_to_itrs_matrix

    path = Path(sys.argv[1] if len(sys.argv) > 1 else "tests/data/orekit_numerical_orbit.npz")
    ref = dict(np.load(path))
    epoch = Time(str(ref["epoch"]).removesuffix(" UTC"), scale="utc")
    duration = float(ref["A_t"][-1])
    rot = Rotation(epoch, duration)
    tt = np.linspace(0.0, duration, 97) + 0.37 * NODE
    tt = tt[tt <= duration]
    direct = gcrs_to_itrs_matrix(epoch + TimeDelta(tt, format="sec"))
    err = max(angle(rot(s) @ m.T) for s, m in zip(tt, direct, strict=True))
    print(f"R(t) interpolation: largest angle from astropy {err:.2e} rad")
    for case in [c for c in "ABC" if f"{c}_r" in ref]:
        sols = []
        for rtol in (1e-13, 3e-14):
            t0 = time.time()
            t, r, v, nfev = propagate(ref, case, rtol=rtol)
            sols.append((r, v))
            print(f"case {case} rtol {rtol:.0e}: {nfev} evaluations, {time.time() - t0:.0f} s",
                  flush=True)  # fmt: skip
        conv = np.max(np.linalg.norm(sols[0][0] - sols[1][0], axis=1))
        dr = np.linalg.norm(sols[1][0] - ref[f"{case}_r"], axis=1)
        dv = np.linalg.norm(sols[1][1] - ref[f"{case}_v"], axis=1)
        bodies = "+".join(str(b) for b in ref[f"{case}_bodies"])
        print(f"case {case} ({ref[f'{case}_degree']}x{ref[f'{case}_order']}"
              f"{', ' + bodies if bodies else ''}): scipy convergence {conv:.1e} m; "
              f"scipy - Orekit: |dr| max {dr.max():.2e} m (at {t[dr.argmax()]:.0f} s), "
              f"|dv| max {dv.max():.2e} m/s", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
