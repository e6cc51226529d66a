"""3D exports of a run: glTF 2.0 binary (pygltflib) and CZML (czml3), ``attitude export``.

glTF (:func:`write_gltf`): the spacecraft (its facets, else the box of its inertia; body axes
as coloured lines) in a node ``spacecraft`` whose rotation is animated with one keyframe per
sample: the run's q, body → space, in glTF's x, y, z, w order. The node sits under a node
``inertial`` that turns the run's inertial z axis to glTF's +y (up), so viewers show the
inertial frame upright, and the keyframes are the run's quaternions unchanged. glTF 2.0 has no
64-bit accessors: the keyframe times and quaternions are float32 (the rounding of a float32,
≤ 2⁻²⁴ relative, 6e-8 rad on the attitude), and the file also carries them in float64 in a
buffer view of its own, named in the ``extras`` of the animation (``attitude_float64``:
time, w, x, y, z per sample, little-endian), which readers that know it use and others ignore.

CZML (:func:`write_czml`): a document packet (clock over the run) and a spacecraft packet with
the orbit's position (``referenceFrame`` FIXED, the ITRS, metres, with its path) and the
orientation. Cesium's ``orientation.unitQuaternion`` is x, y, z, w and rotates the object's
axes to the **Earth-fixed** axes (Cesium's Entity.orientation: "in respect to
Earth-fixed-Earth-centered (ECEF)"), never to an inertial frame: it is q_ITRS←GCRS ∘ q, the run's
body → GCRS quaternion turned by the Earth's orientation (astropy, :func:`orbit.frames.
gcrs_to_itrs_matrix`). A ``box`` of the spacecraft's size is drawn in those axes.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..errors import AttitudeValueError

__all__ = ["write_czml", "write_gltf"]

#: Axis colours of the glTF's body axes (x red, y green, z blue).
_AXIS_RGB = ((1.0, 0.25, 0.25), (0.25, 0.88, 0.25), (0.25, 0.5, 1.0))


def _run(ds: xr.Dataset, member: Any) -> tuple[xr.Dataset, np.ndarray, np.ndarray]:
    from ..results import time_values
    from ._scene import _member

    if not isinstance(ds, xr.Dataset) or "q" not in ds or "time" not in ds.dims:
        raise AttitudeValueError(
            "ds: not an attitude result (expected a Dataset with q(time, component), as "
            "attitude.io.read returns)"
        )
    run, _ = _member(ds, member)
    t = time_values(run)
    q = np.asarray(run["q"].values, dtype=np.float64)
    if t.size < 2:
        raise AttitudeValueError("ds: an attitude history of at least 2 samples is needed")
    return run, t, q


def _mesh(ds: xr.Dataset, facets: Any = None) -> tuple[np.ndarray, np.ndarray, float]:
    """Triangles of the spacecraft (vertices (n, 3), normals (n, 3)) in body axes [m], size."""
    from ._reference import scenario_of
    from ._scene import Scene, _shape

    s = Scene(title="", index=np.zeros(0, int), t=np.zeros(0), q=np.zeros((0, 4)))
    _shape(s, ds, scenario_of(ds), facets)
    verts, norms = [], []
    if s.facets:
        for area, nx, ny, nz, cx, cy, cz in s.facets:
            n = np.array([nx, ny, nz]) / np.linalg.norm([nx, ny, nz])
            a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
            a /= np.linalg.norm(a)
            b = np.cross(n, a)
            h = 0.5 * np.sqrt(area)
            c = np.array([cx, cy, cz])
            p = [c + h * (sa * a + sb * b) for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            for tri in ((0, 1, 2), (0, 2, 3)):
                verts += [p[k] for k in tri]
                norms += [n] * 3
        size = float(max(np.linalg.norm(f[4:7]) + 0.5 * np.sqrt(f[0]) for f in s.facets))
    else:
        half = 0.5 * np.asarray(s.box)
        for axis in range(3):
            for sign in (1.0, -1.0):
                n = np.zeros(3)
                n[axis] = sign
                u, v = (axis + 1) % 3, (axis + 2) % 3
                p = []
                for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    x = np.zeros(3)
                    x[axis], x[u], x[v] = sign * half[axis], su * half[u], sv * half[v]
                    p.append(x)
                order = ((0, 1, 2), (0, 2, 3)) if sign > 0 else ((0, 2, 1), (0, 3, 2))
                for tri in order:
                    verts += [p[k] for k in tri]
                    norms += [n] * 3
        size = float(np.linalg.norm(half))
    return np.asarray(verts), np.asarray(norms), size


def gltf_document(ds: xr.Dataset, *, member: int | None = None, facets: Any = None) -> Any:
    """The glTF document of :func:`write_gltf`, its binary blob set.

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result.
    member : int, optional
        An ensemble's member (default: its first).
    facets : sequence of attitude.Facet, optional
        The spacecraft's surface (default: the scenario's, else the box of the inertia).

    Returns
    -------
    pygltflib.GLTF2
    """
    import pygltflib as G

    run, t, q = _run(ds, member)
    verts, norms, size = _mesh(run, facets)
    axes = np.zeros((6, 3))
    for k in range(3):
        axes[2 * k + 1, k] = 1.6 * size
    axis_rgb = np.repeat(np.asarray(_AXIS_RGB), 2, axis=0)
    xyzw = q[:, [1, 2, 3, 0]]
    f32 = [
        verts.astype("<f4"),
        norms.astype("<f4"),
        axes.astype("<f4"),
        axis_rgb.astype("<f4"),
        (t - t[0]).astype("<f4"),
        xyzw.astype("<f4"),
    ]
    exact = np.column_stack([t, q]).astype("<f8")  # time, w, x, y, z in float64
    blobs = [a.tobytes() for a in f32] + [exact.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    targets = [G.ARRAY_BUFFER] * 4 + [None, None, None]
    views = [
        G.BufferView(buffer=0, byteOffset=int(offsets[i]), byteLength=len(b), target=targets[i])
        for i, b in enumerate(blobs)
    ]
    types = [G.VEC3, G.VEC3, G.VEC3, G.VEC3, G.SCALAR, G.VEC4]
    accessors = []
    for i, a in enumerate(f32):
        two = a.reshape(a.shape[0], -1)
        acc = G.Accessor(bufferView=i, componentType=G.FLOAT, count=int(a.shape[0]), type=types[i])
        if i in (0, 2, 4):  # positions and animation input need their bounds
            acc.min = [float(x) for x in two.min(axis=0)]
            acc.max = [float(x) for x in two.max(axis=0)]
        accessors.append(acc)
    gltf = G.GLTF2(
        asset=G.Asset(version="2.0", generator="attitude (pygltflib)"),
        scene=0,
        scenes=[G.Scene(nodes=[0])],
        nodes=[
            # the run's inertial axes with z up: glTF's up is +y (a -90 deg turn about x)
            G.Node(name="inertial", rotation=[-np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)], children=[1]),
            G.Node(name="spacecraft", mesh=0, rotation=[float(x) for x in xyzw[0]], children=[2]),
            G.Node(name="body axes", mesh=1),
        ],
        meshes=[
            G.Mesh(
                name="spacecraft",
                primitives=[G.Primitive(attributes=G.Attributes(POSITION=0, NORMAL=1), material=0)],
            ),
            G.Mesh(
                name="body axes (x red, y green, z blue)",
                primitives=[
                    G.Primitive(
                        attributes=G.Attributes(POSITION=2, COLOR_0=3), mode=G.LINES, material=1
                    )
                ],
            ),
        ],
        materials=[
            G.Material(
                name="hull",
                doubleSided=True,
                pbrMetallicRoughness=G.PbrMetallicRoughness(
                    baseColorFactor=[0.72, 0.74, 0.78, 1.0], metallicFactor=0.3, roughnessFactor=0.6
                ),
            ),
            G.Material(name="axes", extensions={"KHR_materials_unlit": {}}),
        ],
        extensionsUsed=["KHR_materials_unlit"],
        animations=[
            G.Animation(
                name="attitude",
                samplers=[G.AnimationSampler(input=4, output=5, interpolation="LINEAR")],
                channels=[
                    G.AnimationChannel(
                        sampler=0, target=G.AnimationChannelTarget(node=1, path=G.ROTATION)
                    )
                ],
                extras={
                    "attitude_float64": {
                        "bufferView": len(blobs) - 1,
                        "layout": "per sample: time [s], q w, x, y, z (body -> space, scalar "
                        "first), float64 little-endian",
                        "count": int(t.size),
                        "time_origin": float(t[0]),
                        "epoch": str(run.attrs.get("epoch") or ""),
                    }
                },
            )
        ],
        accessors=accessors,
        bufferViews=views,
        buffers=[G.Buffer(byteLength=int(offsets[-1]))],
        extras={"title": str(run.attrs.get("title", "")), "source": "attitude"},
    )
    gltf.set_binary_blob(b"".join(blobs))
    return gltf


def write_gltf(
    ds: xr.Dataset, path: str | os.PathLike, *, member: int | None = None, facets: Any = None
) -> Path:
    """The spacecraft and its attitude as a binary glTF 2.0 file (``.glb``).

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result; an ensemble needs ``member``.
    path : str or Path
        The ``.glb`` to write (atomically: nothing is left under the name on failure).
    member : int, optional
        An ensemble's member (default: its first).
    facets : sequence of attitude.Facet, optional
        The spacecraft's surface (default: the scenario's, else the box of the inertia).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    AttitudeValueError
        Not a run, an unknown member.
    AttitudeFileError
        The path cannot be written.
    """
    try:
        import pygltflib  # noqa: F401
    except ImportError:
        raise AttitudeValueError(
            "--gltf needs pygltflib; install the view extra: pip install 'attitude[view]'"
        ) from None
    from .._files import OutputFile

    target = OutputFile(path, "path")
    gltf = gltf_document(ds, member=member, facets=facets)
    with target.writing() as tmp:
        gltf.save_binary(str(tmp))
        return Path(target.commit())


def _itrs(run: xr.Dataset, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions [m] and body -> ITRS quaternions (scalar first) at the samples."""
    from astropy.time import Time, TimeDelta

    from orbit.frames import gcrs_to_itrs_matrix

    from ..quaternion import from_matrix, multiply
    from ._reference import orbit_of_run

    epoch = run.attrs.get("epoch")
    frame = str(run.attrs.get("orbit_frame", "GCRS")).upper()
    o = orbit_of_run(run)
    if not epoch or (o is None and not {"r", "p"} <= set(run.variables)):
        raise AttitudeValueError(
            "CZML: the run needs a dated orbit (an epoch and an orbit) to be placed around the "
            "Earth; this run has "
            + ("no epoch" if not epoch else "no orbit")
            + " (export --gltf writes the attitude alone)"
        )
    if frame not in ("GCRS", "GCRF", ""):  # (a dated orbit's frame is the GCRS)
        raise AttitudeValueError(f"CZML: the run's inertial frame {frame} is not supported")
    from ._scene import Scene, _orbit

    s = Scene(title="", index=np.zeros(0, int), t=t, q=q)
    _orbit(s, run, np.arange(t.size), t, o)
    times = Time(str(epoch).rstrip("Z"), scale="utc") + TimeDelta(t, format="sec")
    r = gcrs_to_itrs_matrix(times, step=600.0 if t.size > 64 else None)
    pos = np.einsum("nij,nj->ni", r, s.position) * 1e3
    q_itrs = multiply(from_matrix(r), q)
    return pos, q_itrs


def czml_document(ds: xr.Dataset, *, member: int | None = None) -> list[dict[str, Any]]:
    """The packets of :func:`write_czml`, built and validated by czml3.

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result with an epoch and an orbit.
    member : int, optional
        An ensemble's member (default: its first).

    Returns
    -------
    list of dict
        The document packet and the spacecraft's, as JSON objects.
    """
    from czml3 import Document, Packet
    from czml3.properties import Box, BoxDimensions, Clock, Orientation, Path, Position

    run, t, q = _run(ds, member)
    pos, qf = _itrs(run, t, q)
    verts, _, _ = _mesh(run)
    dims = 2.0 * np.abs(verts).max(axis=0)  # (the box about the centre that holds the body)
    epoch = str(run.attrs["epoch"]).rstrip("Z")
    from astropy.time import Time, TimeDelta

    t0 = Time(epoch, scale="utc")
    iso = [(t0 + TimeDelta(x, format="sec")).isot + "Z" for x in (t[0], t[-1])]
    xyzw = qf[:, [1, 2, 3, 0]]
    name = str(run.attrs.get("object_name") or run.attrs.get("title") or "spacecraft")
    pos_samples = np.column_stack([t, pos]).ravel().tolist()
    q_samples = np.column_stack([t, xyzw]).ravel().tolist()
    doc = Document(
        packets=[
            Packet(
                id="document",
                name=str(run.attrs.get("title", "attitude run")),
                version="1.0",
                clock=Clock(interval=f"{iso[0]}/{iso[1]}", currentTime=iso[0], multiplier=60),
            ),
            Packet(
                id="spacecraft",
                name=name,
                availability=f"{iso[0]}/{iso[1]}",
                position=Position(
                    epoch=t0.isot + "Z",
                    referenceFrame="FIXED",
                    cartesian=pos_samples,
                    interpolationAlgorithm="LAGRANGE",
                    interpolationDegree=5,
                ),
                orientation=Orientation(
                    epoch=t0.isot + "Z", unitQuaternion=q_samples, interpolationAlgorithm="LINEAR"
                ),
                path=Path(show=True, width=1, leadTime=0, trailTime=float(t[-1] - t[0])),
                box=Box(dimensions=BoxDimensions(cartesian=[float(x) for x in dims])),
            ),
        ]
    )
    return json.loads(doc.dumps())


def write_czml(ds: xr.Dataset, path: str | os.PathLike, *, member: int | None = None) -> Path:
    """The orbit and attitude as CZML for Cesium (see the module's docstring for the frames).

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result with an epoch and an orbit; an ensemble needs ``member``.
    path : str or Path
        The ``.czml`` to write (atomically).
    member : int, optional
        An ensemble's member (default: its first).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    AttitudeValueError
        Not a run, no dated orbit, an unknown member.
    AttitudeFileError
        The path cannot be written.
    """
    try:
        import czml3  # noqa: F401
    except ImportError:
        raise AttitudeValueError(
            "--czml needs czml3; install the view extra: pip install 'attitude[view]'"
        ) from None
    from .._files import OutputFile

    target = OutputFile(path, "path")
    packets = czml_document(ds, member=member)
    with target.writing() as tmp:
        Path(tmp).write_text(json.dumps(packets, allow_nan=False), encoding="utf-8")
        return Path(target.commit())
