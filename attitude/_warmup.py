"""``attitude warmup``: compile the kernels that scenarios need, ahead of their first run.

numba compiles a kernel on its first call and caches it on disk (:mod:`orbit._shared_jit`); the
first closed-loop run of a fresh install spends most of a minute compiling. :func:`warmup` runs
each scenario for its first three output samples, in parallel worker processes, so that the
later full runs load everything from the cache. It is idempotent: kernels already in the cache
are loaded, not compiled, and a second warmup compiles nothing.

Every closed-loop run with the built-in models, laws, sensors, estimator and actuators shares
one driver per method (:mod:`attitude._core.models`), so the scenarios are ordered to compile
each driver in one worker only: first one scenario of each kind (closed loop or not, method,
ensemble or not), in parallel, then the rest, which mostly load what the first compiled.

The default scenarios are the ones shipped with the source tree (``scenarios/*.toml`` beside the
packages: the README's editable install); give your own files to compile what they need.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

from .errors import AttitudeValueError

__all__ = ["WarmupReport", "default_scenarios", "warmup"]

#: Output samples each scenario runs for (its first ones, more for three ticks of its flight
#: software): enough to call every kernel.
SAMPLES = 3


@dataclass
class WarmupReport:
    """What a :func:`warmup` did.

    Attributes
    ----------
    seconds : float
        Wall-clock time of the whole warmup, s.
    compiled : dict of str to int
        Functions numba compiled for each scenario (0: everything was in the cache).
    compile_seconds : dict of str to float
        Wall-clock seconds each scenario's worker spent compiling, s.
    failed : dict of str to str
        The scenarios whose run raised, with the error (the others are warmed up).
    """

    seconds: float = 0.0
    compiled: dict[str, int] = field(default_factory=dict)
    compile_seconds: dict[str, float] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)

    @property
    def n_compiled(self) -> int:
        """Functions compiled in all (0: nothing was compiled)."""
        return sum(self.compiled.values())


#: A closed-loop scenario carrying a numerical orbit (the Sun, the Moon, a field, a VNC
#: guidance and initial frame, a thruster): building it compiles what such a run calls from
#: Python before its driver (the orbit's own integrator for its start and tables, the Kepler
#: elements' state, the frames' tables; 5.4 s after another closed-loop scenario).
_NUMERICAL_ORBIT_SCENARIO = """
[scenario]
name = "warm"
epoch = "2026-03-20T00:00:00"
[body]
inertia = [18.0, 22.0, 15.0]
inertia_unit = "kg m2"
[orbit]
type = "numerical"
a = 6878.137
a_unit = "km"
e = 0.001
inc = 97.4
inc_unit = "deg"
raan = 30.0
raan_unit = "deg"
argp = 40.0
argp_unit = "deg"
f0 = 0.0
f0_unit = "deg"
degree = 2
third_bodies = ["sun", "moon"]
[spacecraft]
mass = 150.0
mass_unit = "kg"
[[spacecraft.thrusters]]
position = [-0.6, 0.0, 0.0]
position_unit = "m"
direction = [1.0, 0.0, 0.0]
max_thrust = 1.0
max_thrust_unit = "N"
isp = 220.0
isp_unit = "s"
[software]
period = 1.0
period_unit = "s"
guidance = "vnc"
control = "rate_damping"
C = 1.0
C_unit = "N m s"
[initial_state]
form = "body_rates"
frame = "vnc"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.0, 0.0, 0.0]
omega_unit = "rad/s"
[time]
start = 0.0
stop = 60.0
unit = "s"
count = 7
"""


def build_numerical_orbit_scenario() -> None:
    """Build :data:`_NUMERICAL_ORBIT_SCENARIO` and evaluate its orbit, prepare environment
    models over an orbit and seed a sensor: what runs of these kinds call from Python before
    their driver. The compile helper of a first closed-loop run does
    (:data:`attitude._compiling.NUMERICAL_ORBIT_ITEM`), so that such runs after it compile
    nothing."""
    import numpy as np

    import orbit

    from . import scenario
    from .facets import Facet
    from .potentials import AerodynamicDrag, MagneticDipole, SolarRadiation
    from .sensors import Magnetometer
    from .sensors._models import stream_state

    sc = scenario.loads(_NUMERICAL_ORBIT_SCENARIO)
    o = sc.spacecraft.orbit
    t = np.linspace(0.0, 60.0, 7)
    o.to_state(t), o.radius(t), o.frame_quaternion(t)  # (the run's r, f, p and its frames)
    # the tables of the field, the density and the Sun (with the shadow) over an orbit
    kep = orbit.KeplerOrbit(6878.137, 0.001, 1.7, 0.5, 0.3, epoch="2026-03-20T00:00:00")
    plates = [Facet(0.1, [1.0, 0.0, 0.0], [0.05, 0.0, 0.0])]
    model = MagneticDipole(kep, [0.0, 0.0, 0.1]) + AerodynamicDrag(kep, plates)
    (model + SolarRadiation(kep, plates)).prepare(np.linspace(0.0, 5700.0, 571))
    stream_state(Magnetometer(1e-7, seed=1))  # (a sensor's random stream)


def default_scenarios() -> list[Path]:
    """The scenarios shipped with the source tree, ``[]`` for an installed wheel without them."""
    root = Path(__file__).resolve().parent.parent / "scenarios"
    return sorted(root.glob("*.toml")) if root.is_dir() else []


def _kind(path: Path) -> tuple:
    """What a scenario compiles: (closed loop, method, ensemble), from its TOML alone."""
    from .scenario import tomllib

    try:
        doc = tomllib.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise AttitudeValueError(f"scenarios: cannot read {path}: {exc}") from None
    method = doc.get("integrator", {}).get("method", "auto")
    return ("software" in doc, str(method), "ensemble" in doc)


def _order(paths: Sequence[Path]) -> tuple[list[Path], list[Path]]:
    """One scenario of each kind first (they compile the drivers), then the others."""
    first: dict[tuple, Path] = {}
    rest = []
    for p in paths:
        k = _kind(p)
        if k in first:
            rest.append(p)
        else:
            first[k] = p
    return list(first.values()), rest


def _run_one(path: str, outdir: str) -> tuple[str, int, float]:
    """In a worker: ``path``'s first :data:`SAMPLES` samples; the compilations it made."""
    from . import scenario
    from ._compiling import HELPER_ENV, _Compiles
    from ._times import TimeGrid

    os.environ[HELPER_ENV] = "0"  # (the workers fill the cores already)
    compiles = _Compiles()
    warnings.simplefilter("ignore")  # (the scenarios' own warnings: said when they run)
    try:
        sc = scenario.load(path)
        n = min(SAMPLES, len(sc.t))
        period = getattr(sc.software, "period", None)
        while period is not None and n < len(sc.t) and sc.t[n - 1] - sc.t[0] <= 3 * period:
            n += 1  # (a few ticks of the flight software: a shorter span is refused)
        sc.t = sc.t.head(float(sc.t[n - 1])) if isinstance(sc.t, TimeGrid) else sc.t[:n]
        out = Path(outdir) / (Path(path).stem + ".nc")
        if sc.ensemble is not None:
            from .ensemble import run_scenario

            run_scenario(sc, out)
        else:
            sc.run_to_file(out)
        out.unlink(missing_ok=True)
    finally:
        compiles.close()
    return path, compiles.functions, compiles.seconds


def warmup(
    scenarios: Sequence[str | os.PathLike] | None = None,
    *,
    jobs: int | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> WarmupReport:
    """Compile what ``scenarios`` need, in ``jobs`` worker processes.

    Parameters
    ----------
    scenarios : sequence of path-like, optional
        Scenario files (TOML). Default: :func:`default_scenarios`.
    jobs : int, optional
        Worker processes; default the number of CPUs (numba compiles on one core).
    progress : callable, optional
        ``progress(done, total, name)`` after each scenario.

    Returns
    -------
    WarmupReport
        Per scenario, the functions compiled and the seconds spent compiling.

    Raises
    ------
    AttitudeValueError
        No scenario to warm up, a file that does not exist or is not TOML, or ``jobs < 1``.
    """
    paths = [Path(p) for p in (default_scenarios() if scenarios is None else scenarios)]
    if not paths:
        raise AttitudeValueError(
            "scenarios: none given, and no scenarios/ directory beside the package (an "
            "installed wheel); give the scenario files whose kernels to compile"
        )
    for p in paths:
        if not p.is_file():
            raise AttitudeValueError(f"scenarios: {p} is not a file")
    if jobs is None:
        jobs = os.cpu_count() or 1
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise AttitudeValueError(f"jobs: a positive number of worker processes, got {jobs!r}")
    first, rest = _order(paths)
    report = WarmupReport()
    t0 = time.perf_counter()
    import multiprocessing

    if progress is not None:
        progress(0, len(paths), "")
    ctx = multiprocessing.get_context("spawn")  # (numba's state does not survive a fork)
    with tempfile.TemporaryDirectory(prefix="attitude-warmup-") as tmp:
        with ProcessPoolExecutor(max_workers=min(jobs, len(paths)), mp_context=ctx) as pool:
            for batch in (first, rest):
                futures = {pool.submit(_run_one, str(p), tmp): str(p) for p in batch}
                for f in as_completed(futures):
                    name = futures[f]
                    try:
                        _, report.compiled[name], report.compile_seconds[name] = f.result()
                    except Exception as exc:  # a scenario that does not run: said, not fatal
                        report.failed[name] = f"{type(exc).__name__}: {exc}"
                    if progress is not None:
                        done = len(report.compiled) + len(report.failed)
                        progress(done, len(paths), Path(name).stem)
    report.seconds = time.perf_counter() - t0
    return report


if __name__ == "__main__":  # pragma: no cover - python -m attitude._warmup FILE...
    r = warmup(sys.argv[1:] or None)
    print(f"{r.n_compiled} functions compiled in {r.seconds:.1f} s")
