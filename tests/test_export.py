"""`attitude export --gltf/--czml`: the files re-read with their own libraries (pygltflib,
czml3), the keyframes against the run's quaternions, and Cesium's orientation convention
checked on known rotations against astropy's GCRS -> ITRS transformation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import attitude
from attitude import cli, io, scenario
from attitude.errors import AttitudeFileError, AttitudeValueError
from attitude.quaternion import conjugate, from_axis_angle, from_matrix, multiply, rotate

G = pytest.importorskip("pygltflib", reason="pygltflib is not installed (the view extra)")
czml3 = pytest.importorskip("czml3", reason="czml3 is not installed (the view extra)")

from attitude.plotting import write_czml, write_gltf  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
F32 = 2.0**-24  # float32's relative rounding (round to nearest)


@pytest.fixture(scope="module")
def free_run():
    body = attitude.RigidBody([1.0, 2.0, 2.5], units="kg m2")
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.3, 0.5, 1.1], body)
    return attitude.propagate(body, q0, Q0, np.linspace(0.0, 20.0, 401))


@pytest.fixture(scope="module")
def orbit_file(tmp_path_factory):
    """A dated orbit (the microsatellite near LVLH, GCRS), as `attitude run` writes it."""
    sc = scenario.load(ROOT / "scenarios/lvlh_pointing_events.toml")
    path = tmp_path_factory.mktemp("export") / "ev.nc"
    sc.run_to_file(path)
    return path


@pytest.fixture(scope="module")
def orbit_run(orbit_file):
    return io.read(orbit_file)


def _accessor(gltf, i: int) -> np.ndarray:
    acc = gltf.accessors[i]
    view = gltf.bufferViews[acc.bufferView]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc.type]
    assert acc.componentType == G.FLOAT
    blob = gltf.binary_blob()
    a = np.frombuffer(blob, "<f4", acc.count * width, view.byteOffset + (acc.byteOffset or 0))
    return a.reshape(acc.count, width) if width > 1 else a


def test_gltf_keyframes_are_the_runs_quaternions(free_run, tmp_path):
    path = write_gltf(free_run, tmp_path / "free.glb")
    g = G.GLTF2().load(str(path))  # re-read by the library
    assert g.asset.version == "2.0"
    (anim,) = g.animations
    (ch,) = anim.channels
    assert ch.target.path == "rotation" and g.nodes[ch.target.node].name == "spacecraft"
    sampler = anim.samplers[ch.sampler]
    assert sampler.interpolation == "LINEAR"
    t = free_run.time.values
    q = free_run.q.values
    keys = _accessor(g, sampler.output)
    times = _accessor(g, sampler.input)
    # glTF 2.0 has no 64-bit accessor: float32, each the nearest float32 of the run's x, y, z, w
    xyzw = q[:, [1, 2, 3, 0]]
    assert np.array_equal(keys, xyzw.astype(np.float32))
    assert np.all(np.abs(keys - xyzw) <= F32 * np.abs(xyzw))
    assert np.array_equal(times, (t - t[0]).astype(np.float32))
    # the float64 copy the file carries: the run's numbers, bit for bit
    extra = anim.extras["attitude_float64"]
    view = g.bufferViews[extra["bufferView"]]
    exact = np.frombuffer(g.binary_blob(), "<f8", view.byteLength // 8, view.byteOffset)
    exact = exact.reshape(extra["count"], 5)
    assert np.abs(exact[:, 1:] - q).max() <= 1e-12 and np.array_equal(exact[:, 1:], q)
    assert np.array_equal(exact[:, 0], t)


def test_gltf_rotation_convention_on_a_known_rotation(free_run, tmp_path):
    """A 90 deg turn about space z: glTF's node rotation is [0, 0, sin 45, cos 45] (x, y, z,
    w), and the inertial node turns the run's z axis to glTF's up (+y)."""
    ds = free_run.isel(time=slice(0, 2)).copy(deep=True)
    q90 = from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)
    ds["q"].values[:] = q90
    g = G.GLTF2().load(str(write_gltf(ds, tmp_path / "q90.glb")))
    keys = _accessor(g, g.animations[0].samplers[0].output)
    np.testing.assert_allclose(keys[0], [0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-7)
    root = g.nodes[g.scenes[0].nodes[0]]
    assert root.name == "inertial"
    x, y, z, w = root.rotation
    np.testing.assert_allclose(rotate([w, x, y, z], [0.0, 0.0, 1.0]), [0.0, 1.0, 0.0], atol=1e-15)


def test_gltf_mesh_is_the_box_of_the_inertia(free_run, tmp_path):
    from attitude.plotting._scene import box_from_inertia

    g = G.GLTF2().load(str(write_gltf(free_run, tmp_path / "box.glb")))
    prim = g.meshes[g.nodes[1].mesh].primitives[0]
    v = _accessor(g, prim.attributes.POSITION)
    assert v.shape == (36, 3)  # 6 faces, 2 triangles each
    sides = np.asarray(box_from_inertia([1.0, 2.0, 2.5]))
    np.testing.assert_allclose(v.max(axis=0), sides / 2, rtol=1e-7)
    np.testing.assert_allclose(v.min(axis=0), -sides / 2, rtol=1e-7)
    # I1 : I2 : I3 of a homogeneous box with these sides
    a, b, c = sides
    inertia = np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(inertia / inertia[0], [1.0, 2.0, 2.5], rtol=1e-12)


def _czml_orientation(packets: list[dict]) -> tuple[np.ndarray, np.ndarray, str]:
    """(seconds, unit quaternions x, y, z, w) of the spacecraft's orientation, re-read and
    validated by czml3."""
    sc = next(czml3.Packet.model_validate(p) for p in packets if p["id"] == "spacecraft")
    o = sc.orientation
    values = o.unitQuaternion.values if hasattr(o.unitQuaternion, "values") else o.unitQuaternion
    s = np.asarray(values, dtype=np.float64).reshape(-1, 5)
    return s[:, 0], s[:, 1:], str(o.epoch)


def _itrs_matrices(ds: xr.Dataset, t: np.ndarray) -> np.ndarray:
    from astropy.time import Time, TimeDelta

    from orbit.frames import gcrs_to_itrs_matrix

    times = Time(str(ds.attrs["epoch"]).rstrip("Z"), scale="utc") + TimeDelta(t, format="sec")
    return gcrs_to_itrs_matrix(times)


def test_czml_orientation_is_the_runs_attitude_in_earth_fixed_axes(orbit_run, tmp_path):
    path = write_czml(orbit_run, tmp_path / "ev.czml")
    packets = json.loads(path.read_text())
    assert packets[0]["id"] == "document" and packets[0]["version"] == "1.0"
    t_czml, xyzw, epoch = _czml_orientation(packets)
    t = orbit_run.time.values
    q = orbit_run.q.values
    assert np.array_equal(t_czml, t)
    assert epoch.startswith("2024-03-20T12:00:00")
    # back to the GCRS with astropy's rotation (not interpolated): the run's q, to 1e-12
    r = _itrs_matrices(orbit_run, t)
    q_czml = xyzw[:, [3, 0, 1, 2]]
    back = multiply(conjugate(from_matrix(r)), q_czml)
    err = np.abs(np.abs(np.sum(back * q, axis=1)) - 1.0).max()
    assert err < 1e-12, err
    assert np.abs(back * np.sign(np.sum(back * q, axis=1))[:, None] - q).max() < 1e-12
    # the position: the orbit's, in the ITRS, metres, referenceFrame FIXED
    from attitude.plotting._reference import orbit_of, scenario_of

    pos = packets[1]["position"]
    assert pos["referenceFrame"] == "FIXED"
    p = np.asarray(pos["cartesian"]).reshape(-1, 4)
    gcrs = orbit_of(scenario_of(orbit_run)).position(t)
    np.testing.assert_allclose(p[:, 1:], np.einsum("nij,nj->ni", r, gcrs) * 1e3, rtol=0, atol=1e-3)


def test_czml_box_has_the_proportions_of_the_inertia(orbit_run, tmp_path):
    """Without facets the spacecraft is the box of its inertia's proportions, in CZML as in
    glTF and the view: a uniform box a x b x c has I1 ∝ b² + c², so a² ∝ I2 + I3 - I1. (It was a
    cube, 2 |half-diagonal| wide, that hid the attitude.)"""
    box = next(p for p in json.loads(write_czml(orbit_run, tmp_path / "b.czml").read_text())
               if p["id"] == "spacecraft")["box"]["dimensions"]["cartesian"]  # fmt: skip
    i1, i2, i3 = orbit_run.attrs["inertia"]
    want = np.sqrt([i2 + i3 - i1, i1 + i3 - i2, i1 + i2 - i3])
    np.testing.assert_allclose(np.asarray(box) / box[0], want / want[0], rtol=1e-12)


def _cesium_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Cesium's Matrix3.fromQuaternion (Source/Core/Matrix3.js), written out."""
    return np.array([
        [x * x - y * y - z * z + w * w, 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), -x * x + y * y - z * z + w * w, 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), -x * x - y * y + z * z + w * w],
    ])  # fmt: skip


@pytest.mark.parametrize(
    "axis, angle", [([1.0, 0.0, 0.0], 0.0), ([0.0, 0.0, 1.0], np.pi / 2), ([1.0, 1.0, 0.0], 2.0)]
)
def test_cesium_orientation_convention_on_known_rotations(orbit_run, tmp_path, axis, angle):
    """A body held at a known rotation from the GCRS: Cesium's matrix of the CZML quaternion
    carries each body axis to its Earth-fixed direction as astropy transforms it."""
    from orbit.frames import gcrs_to_itrs

    ds = orbit_run.isel(time=[0, 20, 40]).copy(deep=True)
    qk = from_axis_angle(np.asarray(axis) / np.linalg.norm(axis), angle)
    ds["q"].values[:] = qk
    _, xyzw, _ = _czml_orientation(json.loads(write_czml(ds, tmp_path / "k.czml").read_text()))
    t = ds.time.values
    from astropy.time import Time, TimeDelta

    times = Time(str(ds.attrs["epoch"]).rstrip("Z"), scale="utc") + TimeDelta(t, format="sec")
    for k in range(t.size):
        m = _cesium_matrix(*xyzw[k])
        for e in np.eye(3):
            in_gcrs = rotate(qk, e)  # the body axis in the GCRS
            in_itrs = gcrs_to_itrs(times[k : k + 1], in_gcrs[None, :] * 7000.0)[0] / 7000.0
            np.testing.assert_allclose(m @ e, in_itrs, atol=1e-12)


def test_czml_needs_a_dated_orbit_and_bad_paths_leave_nothing(free_run, orbit_run, tmp_path):
    with pytest.raises(AttitudeValueError, match="needs a dated orbit"):
        write_czml(free_run, tmp_path / "x.czml")
    with pytest.raises(AttitudeValueError, match="not an attitude result"):
        write_gltf(xr.Dataset(), tmp_path / "x.glb")
    with pytest.raises(AttitudeFileError, match="is a directory"):
        write_gltf(free_run, tmp_path)
    with pytest.raises(AttitudeFileError, match="not a directory"):
        (tmp_path / "f").write_text("")
        write_czml(orbit_run, tmp_path / "f" / "x.czml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_cli_export_gltf_and_czml(orbit_file, tmp_path, capsys):
    nc = orbit_file
    glb, cz = tmp_path / "ev.glb", tmp_path / "ev.czml"
    assert cli.main(["export", str(nc), "--gltf", str(glb), "--czml", str(cz)]) == 0
    out = capsys.readouterr().out
    assert f"glTF        {glb}" in out and f"CZML        {cz}" in out
    assert G.GLTF2().load(str(glb)).animations[0].channels[0].target.path == "rotation"
    assert cli.main(["export", str(nc)]) == 2
    assert "--gltf FILE.glb" in capsys.readouterr().err
    free = tmp_path / "free.nc"
    io.write(attitude.propagate(attitude.RigidBody([1.0, 2.0, 3.0]), [1.0, 0, 0, 0],
                                [0, 0.1, 0.2, 0.3], [0.0, 1.0]), free)  # fmt: skip
    assert cli.main(["export", str(free), "--czml", str(tmp_path / "free.czml")]) == 2
    assert "needs a dated orbit" in capsys.readouterr().err
    assert not (tmp_path / "free.czml").exists()


THREE = ROOT / "tests/data/three"  # three.js r170's GLTFLoader: an independent reader


def test_three_js_gltf_loader_reads_the_keyframes(free_run, tmp_path):
    """three.js's own GLTFLoader, in Chromium, parses the .glb: one quaternion track on the
    spacecraft node whose values are the run's x, y, z, w (float32), and the animated node
    at the keyframes' times holds those quaternions."""
    import base64
    import shutil

    sync = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no Chromium on this machine (.ci/run installs it: apt-get install chromium)")
    from importlib import resources

    def data_url(text: str) -> str:
        return "data:text/javascript;base64," + base64.b64encode(text.encode()).decode()

    view_files = resources.files("attitude.plotting").joinpath("view")
    loader = (
        (THREE / "GLTFLoader.js")
        .read_text()
        .replace("'../utils/BufferGeometryUtils.js'", "'three/addons/utils/BufferGeometryUtils.js'")
    )
    imports = {
        "three": data_url(view_files.joinpath("three.module.min.js").read_text()),
        "three/addons/utils/BufferGeometryUtils.js": data_url(
            (THREE / "BufferGeometryUtils.js").read_text()
        ),
        "three/addons/loaders/GLTFLoader.js": data_url(loader),
    }
    glb = base64.b64encode(write_gltf(free_run, tmp_path / "f.glb").read_bytes()).decode()
    page_text = f"""<!DOCTYPE html><html><head><script type="importmap">
{json.dumps({"imports": imports})}</script></head><body><script type="module">
import * as THREE from "three";
import {{ GLTFLoader }} from "three/addons/loaders/GLTFLoader.js";
const bytes = Uint8Array.from(atob("{glb}"), (c) => c.charCodeAt(0));
new GLTFLoader().parse(bytes.buffer, "", (gltf) => {{
  const clip = gltf.animations[0];
  const track = clip.tracks[0];
  const mixer = new THREE.AnimationMixer(gltf.scene);
  mixer.clipAction(clip).play();
  const node = gltf.scene.getObjectByName("spacecraft");
  const atKeys = [0, 7, 200].map((k) => {{
    mixer.setTime(track.times[k]);
    return [node.quaternion.x, node.quaternion.y, node.quaternion.z, node.quaternion.w];
  }});
  window.result = {{ name: track.name, times: Array.from(track.times),
                    values: Array.from(track.values), atKeys }};
}}, (e) => {{ window.result = {{ error: String(e) }}; }});
</script></body></html>"""
    html = tmp_path / "load.html"
    html.write_text(page_text)
    with sync.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=["--headless", "--no-sandbox",
                              "--disable-gpu", "--no-first-run"])  # fmt: skip
        page = b.new_page()
        page.goto(html.as_uri())
        page.wait_for_function("window.result !== undefined")
        r = page.evaluate("window.result")
        b.close()
    assert "error" not in r, r
    assert r["name"] == "spacecraft.quaternion"
    xyzw = free_run.q.values[:, [1, 2, 3, 0]].astype(np.float32)
    assert np.array_equal(np.asarray(r["values"], np.float32).reshape(-1, 4), xyzw)
    t = free_run.time.values
    assert np.array_equal(np.asarray(r["times"], np.float32), (t - t[0]).astype(np.float32))
    for k, q in zip([0, 7, 200], r["atKeys"], strict=True):
        np.testing.assert_allclose(q, xyzw[k], rtol=0, atol=2e-7)  # the keyframe, float32
