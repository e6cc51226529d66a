"""Write tests/data/heyoka_numerical_orbit.npz: a one-day orbit under the EGM2008 field to degree
and order 20, integrated by heyoka's Taylor integrator, for tests/test_numerical_heyoka.py.

The model is the one ``orbit.NumericalOrbit(..., earth_rotation="uniform")`` integrates, written
independently in heyoka's expressions: r̈ = R3(θ)ᵀ g(R3(θ) r) in the GCRS (SI units), with
g = ``heyoka.model.egm2008_acc`` (GM 3.986004415e14 m³/s², a = 6378136.3 m, degree and order 20),
R3(θ) = [[c, s, 0], [−s, c, 0], [0, 0, 1]], θ = θ0 + ω t, t the integrator's time (seconds
since the epoch, heyoka's ``time`` starting at 0), θ0 the Earth rotation angle at the epoch
(ERFA ``era00`` of UT1, UT1 from astropy's bundled IERS-A table, no network: the project's
policy, orbit.timescales) and ω = 2π·1.00273781191135448/86400 rad/s. θ0 and ω are stored,
so the test needs nothing of this script's environment.

heyoka runs in a scratch environment, never a dependency of the project (here with numpy,
astropy and pyerfa; the project itself is not imported):

    python tools/heyoka_numerical_orbit_reference.py tests/data/heyoka_numerical_orbit.npz

It integrates twice, at tol 1e-15 (stored) and 1e-13, and prints (and stores) their largest
position difference: the stored trajectory's own convergence.
"""

import math
import sys
import time
import warnings

import heyoka as hy
import numpy as np

EPOCH = "2026-03-20T00:00:00"  # UTC
DEGREE = ORDER = 20
R0_KM = np.array([6878.137, 0.0, 0.0])
INCLINATION = math.radians(51.6)
V0_KM_S = 7.6127 * np.array([0.0, math.cos(INCLINATION), math.sin(INCLINATION)])
DAY = 86_400.0
STEP = 60.0
OMEGA = 2.0 * math.pi * 1.00273781191135448 / 86400.0
TOL = 1e-15
TOL_CHECK = 1e-13


def earth_rotation_angle(epoch: str) -> float:
    """ERA (rad) at the UTC ``epoch``, UT1 from astropy's bundled IERS-A table."""
    import erfa
    from astropy.time import Time
    from astropy.utils import iers

    table = iers.IERS_A.open(iers.IERS_A_FILE)
    with (
        iers.conf.set_temp("auto_download", False),
        iers.conf.set_temp("iers_degraded_accuracy", "ignore"),
        iers.earth_orientation_table.set(table),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        ut1 = Time(epoch, scale="utc").ut1
        return float(erfa.era00(ut1.jd1, ut1.jd2))


def equations(theta0: float) -> list:
    x, y, z, vx, vy, vz = hy.make_vars("x", "y", "z", "vx", "vy", "vz")
    th = theta0 + OMEGA * hy.time
    c, s = hy.cos(th), hy.sin(th)
    # Earth-fixed position R3(θ) r, the field there, turned back by R3(θ)ᵀ
    gx, gy, gz = hy.model.egm2008_acc([c * x + s * y, c * y - s * x, z], DEGREE, ORDER)
    return [
        (x, vx), (y, vy), (z, vz),
        (vx, c * gx - s * gy), (vy, s * gx + c * gy), (vz, gz),
    ]  # fmt: skip


def integrate(sys_, y0: np.ndarray, t: np.ndarray, tol: float) -> tuple[np.ndarray, dict]:
    t0 = time.perf_counter()
    ta = hy.taylor_adaptive(sys_, y0, time=0.0, tol=tol, high_accuracy=True, compact_mode=True)
    t1 = time.perf_counter()
    res = ta.propagate_grid(t)
    t2 = time.perf_counter()
    outcome, _min_h, _max_h, n_steps = res[0], res[1], res[2], res[3]
    if outcome != hy.taylor_outcome.time_limit:
        raise RuntimeError(f"heyoka stopped: {outcome}")
    info = {"order": ta.order, "steps": n_steps, "compile_s": t1 - t0, "integrate_s": t2 - t1}
    return np.asarray(res[-1]), info


def main() -> None:
    theta0 = earth_rotation_angle(EPOCH)
    y0 = np.concatenate([R0_KM, V0_KM_S]) * 1e3
    t = np.arange(0.0, DAY + STEP / 2, STEP)
    sys_ = equations(theta0)
    states, info = integrate(sys_, y0, t, TOL)
    check, info_c = integrate(sys_, y0, t, TOL_CHECK)
    dr = np.linalg.norm(states[:, :3] - check[:, :3], axis=1)
    dv = np.linalg.norm(states[:, 3:] - check[:, 3:], axis=1)
    print(f"theta0 = {theta0!r} rad, heyoka {hy.__version__}")
    for tol, inf in ((TOL, info), (TOL_CHECK, info_c)):
        print(
            f"tol {tol:g}: order {inf['order']}, {inf['steps']} steps, "
            f"compile {inf['compile_s']:.1f} s, integrate {inf['integrate_s']:.2f} s"
        )
    print(
        f"|r(1e-15) - r(1e-13)| max {dr.max():.3e} m (final {dr[-1]:.3e} m), "
        f"|v| diff max {dv.max():.3e} m/s"
    )
    np.savez_compressed(
        sys.argv[1],
        t=t,
        r=states[:, :3].copy(),
        v=states[:, 3:].copy(),
        r0=y0[:3].copy(),
        v0=y0[3:].copy(),
        r0_km=R0_KM,
        v0_km_s=V0_KM_S,
        epoch=np.str_(EPOCH),
        theta0=np.float64(theta0),
        omega=np.float64(OMEGA),
        degree=np.int64(DEGREE),
        order=np.int64(ORDER),
        mu=np.float64(hy.model.get_egm2008_mu()),
        radius=np.float64(hy.model.get_egm2008_a()),
        heyoka=np.str_(hy.__version__),
        tol=np.float64(TOL),
        tol_check=np.float64(TOL_CHECK),
        check_max_dr=np.float64(dr.max()),
        taylor_order=np.int64(info["order"]),
        steps=np.int64(info["steps"]),
    )


if __name__ == "__main__":
    main()
