"""Write tests/data/orekit_numerical_orbit.npz: Orekit's numerically propagated reference orbits.

Orekit (CS GROUP's flight-dynamics library, through ``orekit_jpype``; an independent
implementation of the force models, frames and integrator) propagates a 500 km sun-synchronous
orbit for one day from 2026-03-20T00:00:00 UTC, sampled every 60 s, in the GCRF:

* case ``A``: EGM2008 20 × 20 (Orekit's ``HolmesFeatherstoneAttractionModel`` for the
  non-central terms plus the propagator's ``NewtonianAttraction`` for GM/r²);
* case ``B``: case A plus the Sun and the Moon as point masses (``ThirdBodyAttraction``) at
  the positions ``orbit.ThirdBody(name).position`` gives (astropy's built-in ephemeris,
  geometric, geocentric), tabulated every 600 s and interpolated (degree 7 Lagrange) inside
  Orekit through a Python ``ExtendedPositionProvider``, with the package's GM values;
* case ``C``: case A with the field to degree and order 70.

Orekit's data (leap seconds, Earth orientation, the gravity field) are written from the
package's own sources by ``tools/orekit_data_from_astropy.py``, so that Orekit's GCRF → ITRF is
astropy's GCRS → ITRS: the EOP (UT1 − UTC, polar motion) are the bundled IERS-A table's,
interpolated linearly between the daily values as astropy does (Orekit's own interpolation,
cubic Hermite, differs from astropy's by up to 2.5e-5 s of UT1 in mid-day, 1.8e-9 rad; see
:func:`linear_eop_itrf`), without the celestial-pole offsets dX, dY and without Orekit's tidal
EOP corrections (simple EOP), neither of which astropy applies. The script checks the rotation
against ``orbit.frames.gcrs_to_itrs_matrix`` at 50 times over the day, between the EOP entries
given to Orekit, and stores the largest angle between them.

The integrator is Dormand-Prince 8(5,3) (``DormandPrince853Integrator``) on Cartesian
coordinates with absolute tolerances of 5e-8 m and 5e-11 m/s (no relative tolerance) and steps
of at most 30 s; the propagation stops at every sample (no dense-output interpolation). Each
case is run again with tolerances ten times smaller and steps of at most 15 s, and the largest
position and velocity differences between the two runs are stored as the convergence estimate.
(The step limit matters for the 70 × 70 field: with steps up to 300 s the step-size control
was occasionally fooled by its short wavelengths, and runs at different tolerances differed by
up to 0.8 mm after a day; with 30 s they agree to a few micrometres.)

Reproduce (Java 17 installed; a scratch environment, never a dependency of the package)::

    python3 -m venv /work/scratch/orekit
    /work/scratch/orekit/bin/pip install orekit-jpype numpy astropy astropy-iers-data
    /work/scratch/orekit/bin/pip install -e .            # the package, for its ephemeris
    /work/scratch/orekit/bin/python tools/orekit_data_from_astropy.py /work/scratch/orekit-data
    /work/scratch/orekit/bin/python tools/orekit_numerical_orbit_reference.py \\
        /work/scratch/orekit-data tests/data/orekit_numerical_orbit.npz

``--cases AB`` runs some of the cases only (the file then holds those).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

EPOCH = "2026-03-20T00:00:00"  # UTC
DURATION = 86400.0
SAMPLE = 60.0
MU = 3.986004415e14  # EGM2008's GM, m³/s²
ELEMENTS = {  # initial osculating Keplerian elements in the GCRF (m, rad)
    "a": 6878137.0,
    "e": 0.001,
    "i": np.radians(97.4),
    "raan": np.radians(30.0),
    "argp": np.radians(40.0),
    "mean_anomaly": 0.0,
}
CASES = {
    "A": {"degree": 20, "bodies": ()},
    "B": {"degree": 20, "bodies": ("sun", "moon")},
    "C": {"degree": 70, "bodies": ()},
}
POS_TOL = 5e-8  # m (and 5e-11 m/s): the stored runs
MAX_STEP = 30.0  # s, the integrator's largest step (see the module docstring)
BODY_STEP = 600.0  # s between tabulated Sun/Moon positions
EOP_STEP = 600.0  # s between the EOP entries given to Orekit


def start_orekit(data_dir: Path) -> None:
    import orekit_jpype

    orekit_jpype.initVM()
    from orekit_jpype.pyhelpers import setup_orekit_data

    setup_orekit_data(filenames=str(data_dir), from_pip_library=False)


def astropy_epoch():
    from astropy.time import Time

    return Time(EPOCH, scale="utc")


def orekit_epoch():
    from org.orekit.time import AbsoluteDate, TimeScalesFactory

    y, mo, d = (int(x) for x in EPOCH[:10].split("-"))
    h, mi, s = (int(x) for x in EPOCH[11:].split(":"))
    return AbsoluteDate(y, mo, d, h, mi, float(s), TimeScalesFactory.getUTC())


def linear_eop_itrf():
    """Orekit's ITRF (IERS 2010, simple EOP, no dX, dY) with astropy's EOP: UT1 − UTC and polar
    motion interpolated linearly between the daily values of the IERS table.

    Orekit's EOP interpolation is Hermite of degree 4k − 1 on the values and their rates (LOD,
    pole rates); astropy's is linear. So Orekit gets entries every EOP_STEP seconds from two
    days before the epoch to three after, with astropy's values and, as rates, the slope of the
    day's linear piece: Orekit's cubics then reproduce astropy's lines (except in the last
    EOP_STEP before each midnight, where the rate is the next day's: ~1e-12 rad).
    """
    from astropy.time import TimeDelta
    from org.orekit.frames import EOPEntry, EOPHistory, FramesFactory
    from org.orekit.time import TimeScalesFactory
    from org.orekit.utils import IERSConventions

    from orbit.timescales import iers_table, offline_iers

    conv = IERSConventions.IERS_2010
    loaded = FramesFactory.getEOPHistory(conv, True)
    ep, aep = orekit_epoch(), astropy_epoch()
    ref = loaded.getEntries().get(0)
    t = np.arange(-2 * 86400.0, 3 * 86400.0 + 1.0, EOP_STEP)
    day0 = np.floor(t / 86400.0) * 86400.0  # the UTC midnight before (the epoch is one)
    with offline_iers():
        tab = iers_table()

        def values(s):
            times = aep + TimeDelta(s, format="sec")
            dut = tab.ut1_utc(times).to_value("s")
            xp, yp = (q.to_value("rad") for q in tab.pm_xy(times))
            return np.stack([dut, xp, yp])

        val = values(t)
        slope = (values(day0 + 86400.0) - values(day0)) / 86400.0  # per SI second
    entries = []
    for k, s in enumerate(t):
        date = ep.shiftedBy(float(s))
        mjd = round(aep.mjd + day0[k] / 86400.0)
        lod = -slope[0, k] * 86400.0  # d(UT1 − UTC)/dt = −LOD / 86400 s
        entries.append(EOPEntry(mjd, float(val[0, k]), float(lod), float(val[1, k]),
                                float(val[2, k]), float(slope[1, k]), float(slope[2, k]),
                                0.0, 0.0, 0.0, 0.0, ref.getITRFType(), date,
                                ref.getEopDataType()))  # fmt: skip
    from java.util import ArrayList

    lst = ArrayList()
    for e in entries:
        lst.add(e)
    hist = EOPHistory(conv, 3, lst, True, loaded.getTimeScales())
    # FramesFactory.buildUncachedITRF still interpolates the CIRF (6 points an hour apart, on a
    # grid that starts wherever the first request falls, so the results depend on the order of
    # the calls at the micrometre level): rebuild the chain with its exact providers.
    from org.orekit.frames import Frame

    uncached = FramesFactory.buildUncachedITRF(hist, TimeScalesFactory.getUTC())
    tirf_u = uncached.getParent()
    cirf_raw = tirf_u.getParent().getTransformProvider().getRawProvider()
    cirf = Frame(FramesFactory.getGCRF(), cirf_raw, "CIRF (exact)", True)
    tirf = Frame(cirf, tirf_u.getTransformProvider(), "TIRF (exact)", False)
    return Frame(tirf, uncached.getTransformProvider(), "ITRF (exact)", False)


def rotation(f_from, f_to, date) -> np.ndarray:
    """The matrix M with x_to = M x_from (Orekit's transform of the three axis vectors)."""
    from org.hipparchus.geometry.euclidean.threed import Vector3D

    tr = f_from.getStaticTransformTo(f_to, date)
    m = np.empty((3, 3))
    for j, e in enumerate(np.eye(3)):
        w = tr.transformVector(Vector3D(*(float(x) for x in e)))
        m[:, j] = (w.getX(), w.getY(), w.getZ())
    return m


def rotation_angle(d: np.ndarray) -> float:
    """The angle of a rotation matrix near the identity, rad (from its antisymmetric part)."""
    return 0.5 * float(np.linalg.norm([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]))


def frame_check(itrf) -> dict:
    """The largest angles between Orekit's GCRF → ITRF rotations and astropy's (50 times over
    the day, none on an EOP entry; one in the last EOP_STEP before midnight), for the frame used
    here and for Orekit's default IERS 2010 ones; TT − UTC."""
    from astropy.time import TimeDelta
    from org.orekit.frames import FramesFactory
    from org.orekit.time import TimeScalesFactory
    from org.orekit.utils import IERSConventions

    from orbit.frames import gcrs_to_itrs_matrix

    ep, aep = orekit_epoch(), astropy_epoch()
    t = np.append(1800.0 * np.arange(49) + 137.0, DURATION - 0.6 * EOP_STEP)
    t = np.sort(t[t < DURATION])
    ra = gcrs_to_itrs_matrix(aep + TimeDelta(t, format="sec"))
    gcrf = FramesFactory.getGCRF()
    frames = {
        "linear_simple": itrf,
        "default_simple": FramesFactory.getITRF(IERSConventions.IERS_2010, True),
        "default_tidal": FramesFactory.getITRF(IERSConventions.IERS_2010, False),
    }
    out = {}
    for name, f in frames.items():
        ang = [rotation_angle(rotation(gcrf, f, ep.shiftedBy(float(s))) @ ra[k].T)
               for k, s in enumerate(t)]  # fmt: skip
        out[f"frame_angle_{name}"] = max(ang)
    utc, tt = TimeScalesFactory.getUTC(), TimeScalesFactory.getTT()
    off = [s.offsetFromTAI(ep) for s in (tt, utc)]
    off = [o.toDouble() if hasattr(o, "toDouble") else float(o) for o in off]
    out["tt_minus_utc_orekit"] = off[0] - off[1]
    out["tt_minus_utc_astropy"] = float(
        (aep.tt.jd1 - aep.jd1) * 86400 + (aep.tt.jd2 - aep.jd2) * 86400
    )
    return out


def body_table(name: str) -> tuple[np.ndarray, np.ndarray]:
    """``orbit.ThirdBody(name).position`` every BODY_STEP s from 4 steps before the epoch to
    4 after the end (m, GCRS)."""
    from orbit import ThirdBody

    tg = BODY_STEP * np.arange(-4, int(DURATION / BODY_STEP) + 5, dtype=np.float64)
    return tg, ThirdBody(name).position(EPOCH, tg)


_W8 = np.array([(-1.0) ** j * math.comb(7, j) for j in range(8)])  # barycentric weights
_J8 = np.arange(8, dtype=np.float64)


def lagrange8(tg: np.ndarray, yg: np.ndarray, t: float) -> np.ndarray:
    """Degree-7 Lagrange interpolation (barycentric form) of rows ``yg`` at uniform ``tg``."""
    h = tg[1] - tg[0]
    i = int(np.floor((t - tg[0]) / h))
    j0 = min(max(i - 3, 0), tg.size - 8)
    x = (t - tg[j0]) / h
    d = x - _J8
    hit = np.flatnonzero(d == 0.0)
    if hit.size:
        return yg[j0 + hit[0]].copy()
    q = _W8 / d
    return (q @ yg[j0 : j0 + 8]) / q.sum()


def make_body(name: str, gcrf, epoch):
    """An Orekit ``ExtendedPositionProvider`` for ``orbit.ThirdBody(name)``'s positions."""
    from jpype import JImplements, JOverride
    from org.hipparchus.geometry.euclidean.threed import Vector3D
    from org.orekit.time import AbsoluteDate
    from org.orekit.utils import TimeStampedPVCoordinates

    tg, yg = body_table(name)

    @JImplements("org.orekit.utils.ExtendedPositionProvider")
    class TabulatedBody:
        calls = 0

        def _xyz(self, date, frame) -> np.ndarray:
            if not isinstance(date, AbsoluteDate):
                raise NotImplementedError("field dates are not supported")
            if not frame.equals(gcrf):
                raise NotImplementedError(f"positions in the GCRF only, not {frame.getName()}")
            TabulatedBody.calls += 1
            return lagrange8(tg, yg, float(date.durationFrom(epoch)))

        @JOverride
        def getPosition(self, date, frame):
            p = self._xyz(date, frame)
            return Vector3D(float(p[0]), float(p[1]), float(p[2]))

        @JOverride
        def getPVCoordinates(self, date, frame):  # velocity by a central difference (unused)
            p = self._xyz(date, frame)
            v = (self._xyz(date.shiftedBy(1.0), frame) - self._xyz(date.shiftedBy(-1.0), frame)) / 2
            return TimeStampedPVCoordinates(date, Vector3D(*(float(x) for x in p)),
                                            Vector3D(*(float(x) for x in v)))  # fmt: skip

    return TabulatedBody(), (tg, yg)


def interpolation_error(name: str, tg: np.ndarray, yg: np.ndarray) -> float:
    """Largest |interpolated − astropy| position (m) at 97 times between the nodes."""
    from orbit import ThirdBody

    t = np.linspace(0.0, DURATION, 97) + 0.37 * BODY_STEP
    direct = ThirdBody(name).position(EPOCH, t)
    interp = np.array([lagrange8(tg, yg, float(s)) for s in t])
    return float(np.max(np.linalg.norm(interp - direct, axis=1)))


def initial_orbit(gcrf, epoch):
    from org.orekit.orbits import CartesianOrbit, KeplerianOrbit, PositionAngleType

    el = ELEMENTS
    kep = KeplerianOrbit(el["a"], el["e"], el["i"], el["argp"], el["raan"], el["mean_anomaly"],
                         PositionAngleType.MEAN, gcrf, epoch, MU)  # fmt: skip
    return CartesianOrbit(kep)


def propagate(case: dict, itrf, bodies: dict, pos_tol: float, vel_tol: float, max_step: float):
    """One case at the given absolute tolerances and step limit: t, r, v, the force models."""
    from jpype import JArray, JDouble
    from org.hipparchus.ode.nonstiff import DormandPrince853Integrator
    from org.orekit.forces.gravity import HolmesFeatherstoneAttractionModel, ThirdBodyAttraction
    from org.orekit.forces.gravity.potential import GravityFieldFactory
    from org.orekit.frames import FramesFactory
    from org.orekit.orbits import OrbitType
    from org.orekit.propagation import SpacecraftState
    from org.orekit.propagation.numerical import NumericalPropagator

    from orbit.third_body import MU as BODY_MU

    gcrf, epoch = FramesFactory.getGCRF(), orekit_epoch()
    orbit0 = initial_orbit(gcrf, epoch)
    abs_tol = JArray(JDouble)([pos_tol] * 3 + [vel_tol] * 3 + [1e-9])
    rel_tol = JArray(JDouble)([0.0] * 7)
    integ = DormandPrince853Integrator(1e-3, max_step, abs_tol, rel_tol)
    prop = NumericalPropagator(integ)
    prop.setOrbitType(OrbitType.CARTESIAN)
    prop.setMu(MU)
    field = GravityFieldFactory.getNormalizedProvider(case["degree"], case["degree"])
    assert field.getMu() == MU and field.getMaxDegree() == case["degree"]
    prop.addForceModel(HolmesFeatherstoneAttractionModel(itrf, field))
    for name in case["bodies"]:
        prop.addForceModel(ThirdBodyAttraction(bodies[name], name, BODY_MU[name]))
    prop.setInitialState(SpacecraftState(orbit0))
    models = [str(f.getClass().getSimpleName()) for f in prop.getAllForceModels()]
    t = np.arange(0.0, DURATION + SAMPLE / 2, SAMPLE)
    r = np.empty((t.size, 3))
    v = np.empty((t.size, 3))
    for k, s in enumerate(t):
        st = prop.propagate(epoch.shiftedBy(float(s))) if s > 0 else prop.getInitialState()
        pv = st.getPVCoordinates(gcrf)
        p, w = pv.getPosition(), pv.getVelocity()
        r[k] = (p.getX(), p.getY(), p.getZ())
        v[k] = (w.getX(), w.getY(), w.getZ())
    return t, r, v, models


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("data_dir", type=Path, help="from tools/orekit_data_from_astropy.py")
    p.add_argument("output", type=Path)
    p.add_argument("--cases", default="ABC")
    p.add_argument("--max-step", type=float, default=MAX_STEP, help="s")
    p.add_argument("--pos-tol", type=float, default=POS_TOL,
                   help="absolute position tolerance, m (velocity: 1e-3 of it in m/s)")  # fmt: skip
    args = p.parse_args()
    start_orekit(args.data_dir)
    from org.orekit.forces.gravity.potential import GravityFieldFactory, ICGEMFormatReader
    from org.orekit.frames import FramesFactory

    GravityFieldFactory.clearPotentialCoefficientsReaders()
    GravityFieldFactory.addPotentialCoefficientsReader(ICGEMFormatReader("egm2008.gfc", False))
    from importlib.metadata import version

    import orekit_jpype

    from orbit.third_body import MU as BODY_MU

    jars = Path(orekit_jpype.__file__).parent / "jars"
    orekit = next(j.stem for j in sorted(jars.glob("orekit-*.jar")))  # e.g. orekit-13.1.9
    itrf = linear_eop_itrf()
    gcrf, epoch = FramesFactory.getGCRF(), orekit_epoch()
    out: dict = {
        "epoch": np.str_(EPOCH + " UTC"),
        "orekit": np.str_(orekit),
        "orekit_jpype": np.str_(version("orekit-jpype")),
    }
    print("Orekit", orekit, "orekit_jpype", version("orekit-jpype"), flush=True)
    fc = frame_check(itrf)
    print("frame check:", fc, flush=True)
    out.update({k: np.float64(x) for k, x in fc.items()})
    bodies, interp_err = {}, {}
    for name in ("sun", "moon"):
        bodies[name], (tg, yg) = make_body(name, gcrf, epoch)
        interp_err[name] = interpolation_error(name, tg, yg)
        out[f"{name}_interpolation_error"] = np.float64(interp_err[name])
    print("ephemeris interpolation error (m):", interp_err, flush=True)
    for case_name in args.cases:
        case = CASES[case_name]
        runs = []
        for tol, step in ((args.pos_tol, args.max_step), (args.pos_tol / 10, args.max_step / 2)):
            t0 = time.time()
            t, r, v, models = propagate(case, itrf, bodies, tol, tol * 1e-3, step)
            runs.append((r, v))
            print(f"case {case_name} tol {tol:.1e} m, max step {step} s: "
                  f"{time.time() - t0:.1f} s, {models}", flush=True)  # fmt: skip
        dr = float(np.max(np.linalg.norm(runs[0][0] - runs[1][0], axis=1)))
        dv = float(np.max(np.linalg.norm(runs[0][1] - runs[1][1], axis=1)))
        print(f"case {case_name}: convergence |dr| {dr:.3e} m, |dv| {dv:.3e} m/s", flush=True)
        r, v = runs[0]
        case_out = {
            "t": t,
            "r": r,
            "v": v,
            "r0": r[0].copy(),
            "v0": v[0].copy(),
            "degree": np.int64(case["degree"]),
            "order": np.int64(case["degree"]),
            "bodies": np.array(case["bodies"], dtype="U4"),
            "pos_tol": np.float64(args.pos_tol),
            "vel_tol": np.float64(args.pos_tol * 1e-3),
            "max_step": np.float64(args.max_step),
            "convergence_r": np.float64(dr),
            "convergence_v": np.float64(dv),
            "force_models": np.array(models),
        }
        out.update({f"{case_name}_{k}": x for k, x in case_out.items()})
    out["mu"] = np.float64(MU)
    out["radius"] = np.float64(6378136.3)
    out["elements"] = np.array(list(ELEMENTS.values()))
    out["elements_names"] = np.array(list(ELEMENTS))
    out["body_names"] = np.array(["sun", "moon"])
    out["body_mu"] = np.array([BODY_MU["sun"], BODY_MU["moon"]])
    out["cases"] = np.str_(args.cases)
    np.savez_compressed(args.output, **out)
    print("wrote", args.output)


if __name__ == "__main__":
    main()
