"""The command line's grammar: every command's options."""

from __future__ import annotations

import argparse
import sys

from .._version import __version__
from ._common import EXIT_BAD_INPUT


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit code 2
        self.print_usage(sys.stderr)
        sys.stderr.write(f"attitude: error: {message}\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _percentile_list(text: str) -> list[float]:
    try:
        vals = [float(x) for x in text.replace(" ", "").split(",") if x]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected numbers in [0, 100] separated by commas, e.g. 5,50,95,100, got {text!r}"
        ) from None
    if not vals or not all(0 <= v <= 100 for v in vals):
        raise argparse.ArgumentTypeError(
            f"expected numbers in [0, 100] separated by commas, e.g. 5,50,95,100, got {text!r}"
        )
    return vals


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="attitude",
        description="Rigid-body attitude propagation in canonical quaternion variables "
        "(Arribas, Elipe & Palacios 2006). See docs/cli.md.",
    )
    p.add_argument("--version", action="version", version=f"attitude {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    r = sub.add_parser(
        "run",
        help="run a scenario and write netCDF",
        description=("Run a TOML scenario (docs/scenarios.md) and write the result as netCDF4."),
    )
    r.add_argument("scenario", metavar="SCENARIO", help="scenario TOML file")
    r.add_argument(
        "-o",
        "--output",
        metavar="OUT.nc",
        help="output file (default: the scenario's output.path, else NAME.nc)",
    )
    r.add_argument("--method", help="integration method (auto, taylor, dop853, scipy:DOP853, ...)")
    r.add_argument("--rtol", type=float, help="relative tolerance")
    r.add_argument(
        "--dt", type=float, help="step of the fixed-step methods (nosquish, splitting), time unit"
    )
    r.add_argument("--order", type=int, choices=(2, 4, 6), help="order of nosquish/splitting")
    r.add_argument(
        "--formulation",
        help="equations: canonical (default), euler_angles, schwab, euler_equations",
    )
    r.add_argument("--atol", type=float, help="absolute tolerance")
    r.add_argument(
        "--stop",
        metavar="T",
        help="stop at time T instead of time.stop, a shorter run: a number in the scenario's "
        "time unit, or with a unit (600s, 10min, 1.5h)",
    )
    r.add_argument(
        "--progress",
        choices=("auto", "always", "never"),
        default="auto",
        help="progress bar on runs longer than 1 s (auto: when stderr is a terminal)",
    )
    r.add_argument("-q", "--quiet", action="store_true", help="no summary")
    r.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run an [ensemble] scenario on a Dask cluster (e.g. tcp://host:8786; needs "
        "pip install 'attitude[dask]'); default: local threads",
    )
    r.add_argument(
        "--ensemble-output",
        choices=("samples", "final", "statistics"),
        help="[ensemble] scenarios: store every member's samples, every member's final state, "
        "or only percentiles over members of the pointing error and |omega| (default: the "
        "scenario's ensemble.output, else samples)",
    )
    r.add_argument(
        "--every",
        type=_positive_int,
        metavar="K",
        help="[ensemble] scenarios: store every K-th output time",
    )
    r.add_argument(
        "--percentiles",
        type=_percentile_list,
        metavar="P,P,...",
        help="[ensemble] scenarios with --ensemble-output statistics: the percentiles "
        "(default 5,50,95,100; 100 is the maximum)",
    )
    r.add_argument(
        "--max-output-size",
        metavar="SIZE",
        help="[ensemble] scenarios: refuse to write a file expected to be larger (e.g. 500MB, "
        "2GB; none: no limit; default: the scenario's ensemble.max_output_size, else 1 GB)",
    )

    pl = sub.add_parser(
        "plot",
        help="plot a result file",
        description=(
            "A run with an orbit or a reference frame: pointing error and roll/pitch/yaw "
            "against the frame, body rates in deg/s, the Earth's shadow and the events on a "
            "time axis in s, min, h or days. A run with actuators or flight software: the "
            "attitude error at every tick (or |omega| for rate damping), wheel speeds in rpm "
            "with their limits and saturation, motor torques, dipoles and thrust with their "
            "limits, the flight-software modes, the estimation error inside its 3-sigma "
            "bounds and the gyro bias. The paper's layout (q left, Q right, angular "
            "velocity and energy: Figs. 1-3) with --layout paper (the paper's scenarios ask "
            "for it). Ensembles: percentile bands over the members."
        ),
    )
    pl.add_argument("file", metavar="OUT.nc")
    pl.add_argument("-o", "--output", metavar="FIG.png", help="figure file (default OUT.png)")
    pl.add_argument("--dpi", type=int, default=110)
    pl.add_argument(
        "--torques",
        action="store_true",
        help="the torque budget instead: |torque| per model against time, max and RMS",
    )
    pl.add_argument(
        "--layout",
        choices=("auto", "engineer", "paper"),
        default="auto",
        help="engineer (pointing, angles, rates...) or paper (q, Q, omega, energy); default: "
        "the scenario's plot_layout, else engineer for a run with an orbit, actuators or "
        "flight software",
    )
    pl.add_argument(
        "--frame",
        choices=("inertial", "orbital", "rsw", "lvlh", "vnc", "nadir", "sun_pointing", "none"),
        help="reference frame of the pointing error and the angles (default: the scenario's: "
        "its initial state's frame, else its pointing event's, else lvlh on an orbit)",
    )
    pl.add_argument(
        "--panels",
        metavar="P1,P2,...",
        help="engineer's panels, in order: pointing, angles, rates, rates_relative, energy, "
        "torque; closed loop: control_error, rate_norm, wheel_speeds, wheel_torque, dipoles, "
        "thrust, estimation, gyro_bias",
    )

    v = sub.add_parser(
        "view",
        help="an offline 3D view of a run in the browser (one HTML file)",
        description=(
            "Write one self-contained HTML page (no network needed) that animates the run: the "
            "spacecraft, its body axes, the reference and LVLH frames, the Earth and the Sun "
            "(dimmed in the shadow), sensor boresights with their exclusion cones, thruster "
            "plumes, and the pointing error, rates, wheel speeds and modes beside it. "
            "Ensembles: choose a member, or see the members' boresights as a cloud."
        ),
    )
    v.add_argument("file", metavar="RUN.nc")
    v.add_argument("-o", "--output", metavar="RUN.html", help="page to write (default RUN.html)")
    v.add_argument(
        "--member", type=int, metavar="K", help="ensembles: the member drawn first (default: the "
        "first; the page can switch among up to 200)"
    )  # fmt: skip
    v.add_argument(
        "--max-frames",
        type=_positive_int,
        metavar="N",
        help="frames at most (default 20000: evenly spaced, plus each stretch's extremes, the "
        "events and the mode switches)",
    )

    i = sub.add_parser("info", help="what was run and the invariant diagnostics")
    i.add_argument("file", metavar="OUT.nc")
    i.add_argument(
        "--settle",
        metavar="T|P%",
        default=None,
        help="closed loop: the pointing error's statistics leave out the run's first T seconds "
        "(60, 2min) or P %% of it (default 10%%)",
    )

    e = sub.add_parser(
        "export",
        help="export the attitude history (CCSDS AEM) or the estimate (CCSDS ACM)",
        description=(
            "Write the attitude history as a CCSDS Attitude Ephemeris Message (KVN, CCSDS "
            "504.0-B-2): quaternion from REF_FRAME_A (inertial) to REF_FRAME_B (body); and/or "
            "the estimator's attitude, gyro bias and covariance as a CCSDS Attitude "
            "Comprehensive Message (ACM, 504.0-B-2 sect. 5), with the true attitude."
        ),
    )
    e.add_argument("file", metavar="OUT.nc")
    e.add_argument("--ccsds-aem", metavar="FILE.aem", help="AEM file to write")
    e.add_argument(
        "--gltf",
        metavar="FILE.glb",
        help="binary glTF 2.0: the spacecraft with its attitude as rotation keyframes (x, y, z, "
        "w; Blender, three.js viewers); needs pip install 'attitude[view]'",
    )
    e.add_argument(
        "--czml",
        metavar="FILE.czml",
        help="CZML for Cesium: the orbit (Earth-fixed) and the orientation (body to Earth-fixed "
        "axes); a run with a dated orbit; needs pip install 'attitude[view]'",
    )
    e.add_argument(
        "--ccsds-acm",
        metavar="FILE.acm",
        help="ACM file to write: the estimate and its covariance (a run with an estimator)",
    )
    e.add_argument(
        "--acm-cov-type",
        choices=("ANGLE_GYROBIAS", "ANGLE"),
        default="ANGLE_GYROBIAS",
        help="COV_TYPE of the ACM: attitude and gyro-bias variances (default) or attitude only",
    )
    e.add_argument(
        "--aem-version",
        type=int,
        choices=(1, 2),
        default=2,
        help="2: CCSDS 504.0-B-2 (default); 1: 504.0-B-1 (older readers, e.g. GMAT)",
    )
    e.add_argument(
        "--aem-type",
        choices=("QUATERNION", "QUATERNION/ANGVEL"),
        default="QUATERNION",
        help="ATTITUDE_TYPE: quaternions only (default) or with the body angular velocity "
        "(QUATERNION/ANGVEL, deg/s; AEM version 2)",
    )
    e.add_argument("--epoch", help="UTC epoch of time 0 (ISO 8601), if the run has none")
    e.add_argument(
        "--time-unit-seconds",
        type=float,
        metavar="S",
        help="seconds per time unit, to export a dimensionless run",
    )
    e.add_argument(
        "--member",
        type=int,
        metavar="K",
        help="ensemble files: export member K (its stored samples)",
    )
    e.add_argument("--object-name")
    e.add_argument("--object-id", help="OBJECT_ID (AEM), INTERNATIONAL_DESIGNATOR (ACM)")
    e.add_argument("--center-name")
    e.add_argument("--ref-frame-a", help="inertial frame (default: the run's, else EME2000)")
    e.add_argument("--ref-frame-b", default="SC_BODY_1", help="body frame (default SC_BODY_1)")
    e.add_argument("--originator", default="attitude")

    w = sub.add_parser(
        "warmup",
        help="compile the kernels the scenarios need, ahead of their first run",
        description="Run each scenario for its first samples in parallel worker processes, so "
        "that numba compiles (and caches) every kernel they need; later runs load them. "
        "Idempotent: a second warmup compiles nothing. Default: the shipped scenarios/*.toml.",
    )
    w.add_argument("scenarios", nargs="*", metavar="SCENARIO", help="scenario files (TOML)")
    w.add_argument("-j", "--jobs", type=int, help="worker processes (default: the CPUs)")
    w.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return p
