"""``attitude plot``, ``attitude view`` and ``attitude export``: figures, the 3D page, files."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from ._common import _READ_ERRORS, EXIT_OK, BadInput, _one_member, _open, _unreadable
from ._run import _output_path


def cmd_plot(args: argparse.Namespace) -> int:
    try:
        import matplotlib  # noqa: F401 - optional: the plot extra
    except ImportError:
        raise BadInput(
            "plot: matplotlib is not installed; install the plot extra: "
            "pip install 'attitude[plot]'"
        ) from None
    from matplotlib.figure import Figure

    from .._files import OutputFile
    from ..errors import AttitudeError
    from ..plotting import plot_ensemble, plot_result, plot_torque_budget

    default = Path(args.file).with_suffix(".png")
    out = _output_path(args.output, Path(default.name)) if args.output else default
    formats = Figure().canvas.get_supported_filetypes()
    if not out.suffix:  # matplotlib would add ".png": name the file that is written
        out = out.with_name(out.name + ".png")
    fmt = out.suffix[1:].lower()
    if fmt not in formats:
        raise BadInput(
            f"-o {out}: unknown figure format {out.suffix!r}; use one of "
            + ", ".join(f".{f}" for f in sorted(formats))
        )
    if not (isinstance(args.dpi, int) and 1 <= args.dpi <= 2400):
        raise BadInput(f"--dpi {args.dpi}: expected an integer 1..2400")
    target = OutputFile(out, "-o")  # checked before drawing; written atomically
    ds = _open(args.file)
    try:
        try:
            if getattr(args, "torques", False):
                if "torque" not in ds.data_vars:
                    raise BadInput(f"plot: {args.file} has no per-model torque variable")
                if "member" in ds.dims:
                    raise BadInput(
                        f"plot --torques: draws the torque budget of one run, and {args.file} "
                        "is an ensemble; attitude info prints its torque budget over members"
                    )
                fig = plot_torque_budget(ds)
            elif "member" in ds.dims:  # percentile bands over the members
                fig = plot_ensemble(ds)
            else:
                panels = None
                if args.panels:
                    panels = [p.strip() for p in args.panels.split(",") if p.strip()]
                fig = plot_result(ds, layout=args.layout, frame=args.frame, panels=panels)
        except AttitudeError as exc:  # --frame, --panels, --layout that do not fit the run
            raise BadInput(f"plot: {exc}") from None
        except _READ_ERRORS as exc:
            raise _unreadable(args.file, exc) from None
    finally:
        ds.close()
    import matplotlib.pyplot as plt

    try:
        with target.writing() as tmp:
            fig.savefig(tmp, dpi=args.dpi, format=fmt)
            target.commit()
    finally:
        plt.close(fig)
    args._written = out
    print(f"figure      {out}")
    return EXIT_OK


def cmd_view(args: argparse.Namespace) -> int:
    """``attitude view RUN.nc -o RUN.html``: the offline 3D page (attitude.plotting.view)."""
    from .._files import OutputFile
    from ..errors import AttitudeError
    from ..plotting import view

    default = Path(args.file).with_suffix(".html")
    out = _output_path(args.output, Path(default.name)) if args.output else default
    OutputFile(out, "-o")  # checked before reading the run
    ds = _open(args.file)
    try:
        try:
            opts = {} if args.max_frames is None else {"max_frames": args.max_frames}
            view(ds, out, member=args.member, **opts)
        except AttitudeError as exc:
            raise BadInput(f"view: {exc}") from None
        except _READ_ERRORS as exc:
            raise _unreadable(args.file, exc) from None
    finally:
        ds.close()
    args._written = out
    print(f"page        {out} ({os.path.getsize(out) / 1e6:.2f} MB): open it in a browser")
    return EXIT_OK


def _export_3d(ds: Any, args: argparse.Namespace) -> list[str]:
    """``export --gltf/--czml`` of one run (attitude.plotting.write_gltf, write_czml)."""
    from ..errors import AttitudeError
    from ..plotting import write_czml, write_gltf

    out = []
    try:
        if args.gltf:
            out.append(f"glTF        {write_gltf(ds, args.gltf)}")
        if args.czml:
            out.append(f"CZML        {write_czml(ds, args.czml)}")
    except AttitudeError as exc:
        raise BadInput(f"export: {exc}") from None
    return out


def cmd_export(args: argparse.Namespace) -> int:
    from .._files import OutputFile
    from ..acm import write_acm
    from ..aem import write_aem

    three_d = bool(args.gltf or args.czml)
    if not args.ccsds_aem and not args.ccsds_acm and not three_d:
        raise BadInput(
            "export: give a format, e.g. --ccsds-aem FILE.aem, --ccsds-acm FILE.acm, --gltf "
            "FILE.glb or --czml FILE.czml"
        )
    for given, opt in ((args.gltf, "--gltf"), (args.czml, "--czml")):
        if given:
            OutputFile(given, opt)  # checked before reading the run
    ds = _open(args.file)
    written = []
    try:
        if three_d and not (args.ccsds_aem or args.ccsds_acm) and args.member is None:
            if "member" in ds.dims:
                n = ds.sizes["member"]
                raise BadInput(
                    f"export: {args.file} is an ensemble of {n} members; a glTF or CZML file "
                    f"holds one attitude history: choose a member with --member K (0..{n - 1})"
                )
        elif "member" in ds.dims or args.member is not None:
            ds = _one_member(ds, args)
        if three_d:
            written += _export_3d(ds, args)
        common = dict(
            epoch=args.epoch,
            object_name=args.object_name,
            center_name=args.center_name,
            ref_frame_a=args.ref_frame_a,
            ref_frame_b=args.ref_frame_b,
            originator=args.originator,
            time_unit_seconds=args.time_unit_seconds,
        )
        try:
            if args.ccsds_aem:
                path = write_aem(
                    ds,
                    args.ccsds_aem,
                    version=args.aem_version,
                    object_id=args.object_id,
                    attitude_type=args.aem_type,
                    **common,
                )
                written.append(f"CCSDS AEM   {path}")
            if args.ccsds_acm:
                path = write_acm(
                    ds,
                    args.ccsds_acm,
                    international_designator=args.object_id,
                    cov_type=args.acm_cov_type,
                    **common,
                )
                written.append(f"CCSDS ACM   {path}")
        except ValueError as exc:
            raise BadInput(str(exc)) from None
        except (OSError, RuntimeError, KeyError, IndexError, TypeError) as exc:
            raise _unreadable(args.file, exc) from None
    finally:
        ds.close()
    print("\n".join(written))
    return EXIT_OK
