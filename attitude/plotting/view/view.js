// The scene of `attitude view` (docs/cli.md). World axes = the run's inertial (space) axes;
// the spacecraft sits at the origin; lengths in metres (the body's size), the Earth drawn at
// the angular size it has from the spacecraft. Quaternions are the package's: scalar first,
// body -> space (docs/conventions.md); three.js stores them x, y, z, w.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";

const D = JSON.parse(document.getElementById("attitude-data").textContent);

function decode(a) {
  if (a === null || a === undefined) return null;
  const bin = atob(a.b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  const T = { f64: Float64Array, f32: Float32Array, i32: Int32Array }[a.dtype];
  return new T(bytes.buffer);
}

const t = decode(D.t);
const N = t.length;
const A = {
  q: decode(D.q), ref: decode(D.refQ), lvlh: decode(D.lvlhQ), pos: decode(D.position),
  sun: decode(D.sun), shadow: decode(D.shadow), mode: decode(D.mode),
  thrust: D.thrusters ? decode(D.thrusters.force) : null,
  members: D.ensemble ? decode(D.ensemble.q) : null,
};
const M = D.ensemble ? D.ensemble.members.length : 0;
const errors = [];

// ---------------------------------------------------------------------------------- helpers
const V = (x, y, z) => new THREE.Vector3(x, y, z);
const DEG = 180 / Math.PI;
const quatAt = (arr, i, out) => out.set(arr[4 * i + 1], arr[4 * i + 2], arr[4 * i + 3], arr[4 * i]);
const finiteQ = (arr, i) => arr && Number.isFinite(arr[4 * i]);
function fmtTime(s) {
  if (D.timeUnit !== "s") return `t = ${s.toPrecision(6)}${D.timeUnit === "1" ? "" : " " + D.timeUnit}`;
  const sign = s < 0 ? "-" : "";
  let r = Math.abs(s);
  const d = Math.floor(r / 86400); r -= 86400 * d;
  const h = Math.floor(r / 3600); r -= 3600 * h;
  const m = Math.floor(r / 60); r -= 60 * m;
  const hh = String(h).padStart(2, "0"), mm = String(m).padStart(2, "0");
  const ss = r.toFixed(r < 10 && Number.isInteger(r) ? 0 : 1).padStart(2, "0");
  return `t = ${s.toFixed(3)} s (${sign}${d ? d + " d " : ""}${hh}:${mm}:${ss})`;
}

// ---------------------------------------------------------------------------------- the scene
const host = document.getElementById("scene");
let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  host.appendChild(renderer.domElement);
} catch (e) {
  renderer = null;
  document.getElementById("warn").textContent = "WebGL is not available: the scene is not drawn (the plots and the state are).";
}
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x0b0e14);
const L = D.size; // body size [m]
const camera = new THREE.PerspectiveCamera(40, 1, L / 100, L * 1e5);
const proxy = new THREE.PerspectiveCamera(40, 1, L / 100, L * 1e5); // the camera in the chosen frame
// default: from behind and above in LVLH (x along-track, z nadir) with a run on an orbit,
// else from +x, -y, +z of the inertial axes
const startLvlh = !!(D.lvlhQ);
if (startLvlh) { proxy.up.set(0, 0, -1); proxy.position.set(-6.0 * L, -3.9 * L, -2.9 * L); }
else { proxy.up.set(0, 0, 1); proxy.position.set(4.3 * L, -5.7 * L, 3.2 * L); }
const controls = new OrbitControls(proxy, renderer ? renderer.domElement : document.createElement("div"));
controls.target.set(0, 0, 0);
controls.update();

const ambient = new THREE.AmbientLight(0xffffff, 0.5);
scene.add(ambient);
const sunLight = new THREE.DirectionalLight(0xffffff, 2.2);
scene.add(sunLight);
scene.add(sunLight.target);

function triad(len, colors, opts = {}) {
  const g = new THREE.Group();
  const dirs = [V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)];
  dirs.forEach((d, k) => {
    const a = new THREE.ArrowHelper(d, V(0, 0, 0), len, colors[k], opts.head ?? 0.12 * len, opts.headW ?? 0.06 * len);
    if (opts.opacity !== undefined) {
      a.line.material.transparent = true; a.line.material.opacity = opts.opacity;
      a.cone.material.transparent = true; a.cone.material.opacity = opts.opacity;
    }
    g.add(a);
  });
  return g;
}

// the spacecraft
const body = new THREE.Group();
scene.add(body);
const hull = new THREE.MeshStandardMaterial({ color: 0xb8bcc8, metalness: 0.3, roughness: 0.55, side: THREE.DoubleSide });
const panel = new THREE.MeshStandardMaterial({ color: 0x3f6fd8, emissive: 0x0c1a3a, metalness: 0.1, roughness: 0.5, side: THREE.DoubleSide });
if (D.facets.length) {
  for (const f of D.facets) {
    const [area, nx, ny, nz, cx, cy, cz] = f;
    const side = Math.sqrt(area);
    const n = V(nx, ny, nz).normalize();
    const flat = Math.abs(cx * nx + cy * ny + cz * nz) < 0.2 * side; // a wing: its normal across its centre
    const m = new THREE.Mesh(new THREE.PlaneGeometry(side, side), flat ? panel : hull);
    m.quaternion.setFromUnitVectors(V(0, 0, 1), n);
    m.position.set(cx, cy, cz);
    body.add(m);
  }
} else {
  const [a, b, c] = D.box; // see-through: the axes start inside it
  const boxMat = hull.clone();
  boxMat.transparent = true; boxMat.opacity = 0.72; boxMat.depthWrite = false;
  body.add(new THREE.Mesh(new THREE.BoxGeometry(a, b, c), boxMat));
}
const bodyAxes = triad(1.7 * L, [0xff4040, 0x40e040, 0x4080ff]);
body.add(bodyAxes);

// sensors: boresights with their Sun (yellow) and Earth-limb (cyan) exclusion cones
function cone(axis, half, len, color) {
  const h = len * Math.cos(half), r = len * Math.sin(half);
  const g = new THREE.ConeGeometry(r, h, 48, 1, true);
  g.translate(0, -h / 2, 0); // apex at the origin, opening along -y
  const mesh = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color, transparent: true, opacity: 0.18, side: THREE.DoubleSide, depthWrite: false }));
  mesh.quaternion.setFromUnitVectors(V(0, -1, 0), axis.clone().normalize());
  return mesh;
}
const boresights = [], cones = [];
for (const s of D.sensors) {
  if (s.boresight) {
    const b = V(...s.boresight).normalize();
    const arrow = new THREE.ArrowHelper(b, V(0, 0, 0), 2.1 * L, 0xff66ff, 0.15 * L, 0.07 * L);
    boresights.push(arrow);
    body.add(arrow);
    // the Sun must stay outside the first cone; the Earth's limb outside the second
    const k = D.sensors.indexOf(s);
    if (s.sunExclusion > 0) cones.push({ kind: "sun", sensor: k, half: s.sunExclusion, mesh: cone(b, s.sunExclusion, 1.8 * L, 0xffdd33) });
    if (s.earthExclusion > 0) cones.push({ kind: "earth", sensor: k, half: s.earthExclusion, mesh: cone(b, s.earthExclusion, 1.5 * L, 0x33ddff) });
    cones.forEach((c) => c.mesh.parent || body.add(c.mesh));
  } else if (s.normals) {
    for (const n of s.normals) body.add(new THREE.ArrowHelper(V(...n).normalize(), V(0, 0, 0), 0.9 * L, 0xffaa44, 0.08 * L, 0.04 * L));
  }
}
// thrusters: a plume along -direction (the exhaust) when firing, its length by the force
const plumes = [];
if (D.thrusters) {
  D.thrusters.position.forEach((p, k) => {
    const d = V(...D.thrusters.direction[k]).normalize();
    const g = new THREE.ConeGeometry(0.08 * L, 1, 16, 1, true);
    g.translate(0, -0.5, 0);
    const m = new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color: 0xff8822, transparent: true, opacity: 0.7, depthWrite: false }));
    m.position.set(...p);
    m.quaternion.setFromUnitVectors(V(0, -1, 0), d.clone().negate());
    m.visible = false;
    body.add(m);
    plumes.push({ mesh: m, max: D.thrusters.maxThrust[k] || 1 });
  });
}

const refAxes = triad(2.3 * L, [0xff9999, 0x99ff99, 0x99bbff], { opacity: 0.55, head: 0.08 * L, headW: 0.05 * L });
scene.add(refAxes);
const lvlhAxes = triad(2.0 * L, [0xffaa00, 0xcc66ff, 0x00dddd], { opacity: 0.8, head: 0.08 * L, headW: 0.05 * L });
scene.add(lvlhAxes);
const inertialAxes = triad(0.6 * L, [0x777777, 0x777777, 0x777777], { opacity: 0.6 });
scene.add(inertialAxes);

// the Sun and the Earth
const sunArrow = new THREE.ArrowHelper(V(1, 0, 0), V(0, 0, 0), 2.8 * L, 0xffdd33, 0.2 * L, 0.1 * L);
scene.add(sunArrow);
const nadirArrow = new THREE.ArrowHelper(V(0, 0, -1), V(0, 0, 0), 2.4 * L, 0x33ddff, 0.16 * L, 0.08 * L);
scene.add(nadirArrow);
const EARTH_DIST = 200 * L; // the Earth's near side ~12 L below the body in LEO
const earth = new THREE.Group();
const earthMesh = new THREE.Mesh(new THREE.SphereGeometry(1, 160, 80), new THREE.MeshLambertMaterial({ color: 0x1f5fa8 }));
earthMesh.rotation.x = Math.PI / 2; // poles along the inertial z axis
earth.add(earthMesh);
// parallels every 30 deg and meridians every 30 deg (in the inertial axes: no Earth rotation)
const gratPts = [];
const R1 = 1.002, SEG = 96;
for (let lat = -60; lat <= 60; lat += 30) {
  const c = Math.cos(lat / DEG), z = Math.sin(lat / DEG);
  for (let k = 0; k < SEG; k++) {
    const a0 = 2 * Math.PI * k / SEG, a1 = 2 * Math.PI * (k + 1) / SEG;
    gratPts.push(V(R1 * c * Math.cos(a0), R1 * c * Math.sin(a0), R1 * z), V(R1 * c * Math.cos(a1), R1 * c * Math.sin(a1), R1 * z));
  }
}
for (let lon = 0; lon < 360; lon += 30) {
  const cl = Math.cos(lon / DEG), sl = Math.sin(lon / DEG);
  for (let k = 0; k < SEG / 2; k++) {
    const b0 = -Math.PI / 2 + Math.PI * k / (SEG / 2), b1 = -Math.PI / 2 + Math.PI * (k + 1) / (SEG / 2);
    gratPts.push(V(R1 * Math.cos(b0) * cl, R1 * Math.cos(b0) * sl, R1 * Math.sin(b0)), V(R1 * Math.cos(b1) * cl, R1 * Math.cos(b1) * sl, R1 * Math.sin(b1)));
  }
}
earth.add(new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(gratPts), new THREE.LineBasicMaterial({ color: 0x7fb0e8, transparent: true, opacity: 0.3 })));
scene.add(earth);
const limb = new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(
  Array.from({ length: 129 }, (_, k) => V(Math.cos(2 * Math.PI * k / 128), Math.sin(2 * Math.PI * k / 128), 0))),
  new THREE.LineBasicMaterial({ color: 0x33ddff }));
scene.add(limb);
const hasOrbit = !!A.pos;
const hasSun = !!A.sun;
[nadirArrow, earth, limb, lvlhAxes].forEach((o) => (o.visible = hasOrbit && (o !== lvlhAxes || !!A.lvlh)));
sunArrow.visible = hasSun;
if (!hasSun) { sunLight.position.set(1, -2, 3); ambient.intensity = 0.6; }

// ensemble: the members' boresights as a cloud of points
let cloud = null;
if (M) {
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(3 * M), 3));
  cloud = new THREE.Points(g, new THREE.PointsMaterial({ color: 0xff66ff, size: 0.12 * L }));
  scene.add(cloud);
}

// ---------------------------------------------------------------------------------- state
let frame = 0, member = D.ensemble ? D.ensemble.chosen : null, qArr = A.q;
const tmpQ = new THREE.Quaternion();
const nadir = V(0, 0, -1);

function setFrame(i) {
  frame = Math.max(0, Math.min(N - 1, Math.round(i)));
  slider.value = String(frame);
  quatAt(qArr, frame, body.quaternion);
  body.updateMatrixWorld(true);
  if (finiteQ(A.ref, frame)) { refAxes.visible = toggles.ref.checked; quatAt(A.ref, frame, refAxes.quaternion); }
  else refAxes.visible = false;
  if (A.lvlh && finiteQ(A.lvlh, frame)) quatAt(A.lvlh, frame, lvlhAxes.quaternion);
  lvlhAxes.visible = hasOrbit && !!A.lvlh && toggles.lvlh.checked;
  if (hasOrbit) {
    const p = V(A.pos[3 * frame], A.pos[3 * frame + 1], A.pos[3 * frame + 2]);
    const r = p.length();
    nadir.copy(p).multiplyScalar(-1 / r);
    nadirArrow.setDirection(nadir);
    const rho = Math.asin(Math.min(1, D.earthRadiusKm / r)); // the limb's angle from nadir
    earth.position.copy(nadir).multiplyScalar(EARTH_DIST);
    earth.scale.setScalar(EARTH_DIST * D.earthRadiusKm / r);
    const dl = 2.6 * L;
    limb.position.copy(nadir).multiplyScalar(dl * Math.cos(rho));
    limb.scale.setScalar(dl * Math.sin(rho));
    limb.quaternion.setFromUnitVectors(V(0, 0, 1), nadir);
  }
  let lit = 1;
  if (hasSun) {
    const s = V(A.sun[3 * frame], A.sun[3 * frame + 1], A.sun[3 * frame + 2]);
    sunArrow.setDirection(s);
    sunLight.position.copy(s).multiplyScalar(10 * L);
    lit = A.shadow ? A.shadow[frame] : 1;
    if (!Number.isFinite(lit)) lit = 1;
    sunLight.intensity = 0.15 + 2.05 * lit;
    ambient.intensity = 0.12 + 0.23 * lit;
  }
  plumes.forEach((pl, k) => {
    const f = A.thrust[frame * plumes.length + k];
    pl.mesh.visible = f > 0;
    pl.mesh.scale.set(1, Math.max(0.2, 1.5 * L * f / pl.max), 1);
  });
  if (cloud) {
    const pos = cloud.geometry.attributes.position;
    const b = V(...D.ensemble.boresight).normalize(), v = V(0, 0, 0);
    for (let k = 0; k < M; k++) {
      const o = 4 * (k * N + frame);
      tmpQ.set(A.members[o + 1], A.members[o + 2], A.members[o + 3], A.members[o]);
      v.copy(b).applyQuaternion(tmpQ).multiplyScalar(2.1 * L);
      pos.setXYZ(k, v.x, v.y, v.z);
    }
    pos.needsUpdate = true;
  }
  scene.updateMatrixWorld(true);
  timeLabel.textContent = fmtTime(t[frame]) + `  frame ${frame + 1}/${N}`;
  hud(lit);
  plots.forEach((p) => p.cursor(t[frame]));
  requestRender();
}

function hud(lit) {
  const rows = [];
  for (const s of D.series) {
    const ys = s.decoded.map((y) => (Number.isFinite(y[frame]) ? y[frame].toPrecision(4) : "-"));
    rows.push(`${s.short}: ${ys.join(", ")} ${s.unit}`);
  }
  if (A.mode && D.modeNames.length > 1) rows.push(`mode: ${D.modeNames[A.mode[frame]] ?? A.mode[frame]}`);
  if (hasSun) rows.push(lit >= 0.999 ? "sunlit" : lit <= 0.001 ? "umbra" : `penumbra ${(100 * lit).toFixed(0)} %`);
  rows.push(...exclusionRows());
  if (member !== null) rows.push(`member ${member}`);
  document.getElementById("hud").innerHTML = rows.join("<br>");
}

// each boresight's angle from the Sun and from the Earth's limb against its exclusion cones;
// a cone the Sun or the Earth is inside is drawn opaque
function exclusionRows() {
  const rows = [];
  D.sensors.forEach((s, k) => {
    if (!s.boresight || !(s.sunExclusion > 0 || s.earthExclusion > 0)) return;
    const b = V(...s.boresight).normalize().applyQuaternion(body.quaternion);
    const parts = [];
    for (const c of cones.filter((c) => c.sensor === k)) {
      let ang = null;
      if (c.kind === "sun" && hasSun) ang = b.angleTo(V(A.sun[3 * frame], A.sun[3 * frame + 1], A.sun[3 * frame + 2]));
      if (c.kind === "earth" && hasOrbit) {
        const r = V(A.pos[3 * frame], A.pos[3 * frame + 1], A.pos[3 * frame + 2]);
        ang = b.angleTo(r.clone().negate()) - Math.asin(Math.min(1, D.earthRadiusKm / r.length()));
      }
      if (ang === null) continue;
      const inside = ang < c.half;
      c.mesh.material.opacity = inside ? 0.55 : 0.18;
      parts.push(`${c.kind === "sun" ? "Sun" : "Earth limb"} ${(ang * DEG).toFixed(1)}° (excl. ${(c.half * DEG).toFixed(0)}°)${inside ? " BLINDED" : ""}`);
    }
    if (parts.length) rows.push(`${s.name}: ${parts.join(", ")}`);
  });
  return rows;
}

function axesOf(obj) {
  const e = obj.matrixWorld.elements; // column-major: columns = the object's axes in the world
  return [0, 1, 2].map((c) => { const v = V(e[4 * c], e[4 * c + 1], e[4 * c + 2]).normalize(); return [v.x, v.y, v.z]; });
}

// ---------------------------------------------------------------------------------- camera
let camMode = startLvlh ? "lvlh" : "inertial";
const frameQ = new THREE.Quaternion();
function placeCamera() {
  frameQ.identity();
  if (camMode === "body") frameQ.copy(body.quaternion);
  else if (camMode === "lvlh" && A.lvlh && finiteQ(A.lvlh, frame)) quatAt(A.lvlh, frame, frameQ);
  camera.position.copy(proxy.position).applyQuaternion(frameQ);
  camera.quaternion.copy(frameQ).multiply(proxy.quaternion);
  camera.updateMatrixWorld(true);
}

// ---------------------------------------------------------------------------------- plots
const side = document.getElementById("side");
const plots = [];
const COLORS = ["#4e9bff", "#ff9f40", "#4fd06a", "#c77dff", "#e0c050", "#40d0d0", "#ff6b8a"];
const MODE_COLORS = ["#4e9bff", "#4fd06a", "#ff9f40", "#c77dff", "#b0b040", "#40d0d0"];
const t0 = t[0], t1 = t[N - 1] > t[0] ? t[N - 1] : t[0] + 1;
// the plots' time unit, by the run's span (as attitude plot: s, min, h, days)
const [TS, TU] = D.timeUnit !== "s" ? [1, D.timeUnit === "1" ? "" : D.timeUnit] : t1 - t0 <= 600 ? [1, "s"] : t1 - t0 <= 10800 ? [60, "min"] : t1 - t0 <= 259200 ? [3600, "h"] : [86400, "d"];
for (const s of D.series) {
  s.decoded = s.lines.map((l) => decode(l.y));
  s.short = s.name.split(" from ")[0].split(" (")[0];
}
function makePlot(s) {
  const wrap = document.createElement("div");
  wrap.className = "plot";
  const h = document.createElement("h2");
  h.textContent = `${s.name} [${s.unit}]` + (s.limits.length ? " (limits dashed red)" : "");
  const cv = document.createElement("canvas");
  wrap.append(h, cv);
  side.appendChild(wrap);
  let bg = null, W = 0, H = 0;
  const pad = { l: 46, r: 14, t: 6, b: 16 };
  let ylo = Infinity, yhi = -Infinity;
  for (const y of s.decoded) for (const v of y) if (Number.isFinite(v)) { ylo = Math.min(ylo, v); yhi = Math.max(yhi, v); }
  for (const v of s.limits) { ylo = Math.min(ylo, v); yhi = Math.max(yhi, v); }
  if (!(yhi > ylo)) { ylo = Number.isFinite(ylo) ? ylo - 1 : 0; yhi = ylo + 2; }
  const pos = s.decoded.flatMap((y) => Array.from(y).filter((v) => v > 0));
  const log = s.log && pos.length > 0 && Math.max(...pos.slice(0, 1e5)) / Math.min(...pos.slice(0, 1e5)) > 30;
  if (log) { ylo = Math.log10(Math.min(...pos.slice(0, 1e5))); yhi = Math.log10(Math.max(...pos.slice(0, 1e5))); }
  const X = (tt) => pad.l + (W - pad.l - pad.r) * (tt - t0) / (t1 - t0);
  const Y = (v) => { const u = log ? Math.log10(v) : v; return H - pad.b - (H - pad.t - pad.b) * (u - ylo) / (yhi - ylo); };
  function draw() {
    const dpr = window.devicePixelRatio || 1;
    W = cv.clientWidth; H = cv.clientHeight;
    cv.width = W * dpr; cv.height = H * dpr;
    const c = cv.getContext("2d");
    c.setTransform(dpr, 0, 0, dpr, 0, 0);
    c.fillStyle = "#141925"; c.fillRect(0, 0, W, H);
    if (A.shadow) { // the Earth's shadow
      for (let i = 0; i < N - 1; i++) {
        const v = A.shadow[i];
        if (v < 0.999) { c.fillStyle = v < 0.001 ? "rgba(150,150,170,0.14)" : "rgba(150,150,170,0.07)"; c.fillRect(X(t[i]), pad.t, Math.max(1, X(t[i + 1]) - X(t[i])), H - pad.t - pad.b); }
      }
    }
    if (A.mode && D.modeNames.length > 1) {
      for (let i = 0; i < N - 1; i++) { c.fillStyle = MODE_COLORS[A.mode[i] % MODE_COLORS.length]; c.fillRect(X(t[i]), pad.t, Math.max(1, X(t[i + 1]) - X(t[i])), 3); }
    }
    c.strokeStyle = "#2a3244"; c.lineWidth = 1; c.fillStyle = "#99a"; c.font = "10px sans-serif";
    for (let k = 0; k <= 4; k++) {
      const u = ylo + (yhi - ylo) * k / 4, y = H - pad.b - (H - pad.t - pad.b) * k / 4;
      c.beginPath(); c.moveTo(pad.l, y); c.lineTo(W - pad.r, y); c.stroke();
      const v = log ? 10 ** u : u;
      c.fillText(Math.abs(v) >= 1e4 || (Math.abs(v) < 1e-2 && v !== 0) ? v.toExponential(1) : v.toPrecision(3), 2, y + 3);
    }
    c.textAlign = "center";
    for (let k = 0; k <= 5; k++) {
      const tt = t0 + (t1 - t0) * k / 5;
      if (k === 5) c.textAlign = "right";
      c.fillText(((tt - t0) / TS).toPrecision(3) + (k === 5 ? " " + TU : ""), k === 5 ? W - 2 : X(tt), H - 3);
    }
    c.textAlign = "left";
    c.setLineDash([2, 3]);
    for (const e of D.events) { c.strokeStyle = "#e05a5a"; c.beginPath(); c.moveTo(X(e.t), pad.t); c.lineTo(X(e.t), H - pad.b); c.stroke(); }
    c.setLineDash([6, 4]); c.strokeStyle = "#ff4040";
    for (const v of s.limits) { c.beginPath(); c.moveTo(pad.l, Y(v)); c.lineTo(W - pad.r, Y(v)); c.stroke(); }
    c.setLineDash([]);
    s.decoded.forEach((y, k) => {
      c.strokeStyle = COLORS[k % COLORS.length]; c.lineWidth = 1.2; c.beginPath();
      let pen = false;
      for (let i = 0; i < N; i++) {
        const v = y[i];
        if (!Number.isFinite(v) || (log && !(v > 0))) { pen = false; continue; }
        if (pen) c.lineTo(X(t[i]), Y(v)); else { c.moveTo(X(t[i]), Y(v)); pen = true; }
      }
      c.stroke();
    });
    if (s.lines.length > 1) s.lines.forEach((l, k) => { c.fillStyle = COLORS[k % COLORS.length]; c.fillText(l.label, W - pad.r - 60, pad.t + 10 + 11 * k); });
    bg = c.getImageData(0, 0, cv.width, cv.height);
  }
  function cursor(tt) {
    if (!bg) return;
    const c = cv.getContext("2d");
    c.putImageData(bg, 0, 0);
    c.strokeStyle = "#ffffff"; c.lineWidth = 1;
    c.beginPath(); c.moveTo(X(tt), pad.t); c.lineTo(X(tt), H - pad.b); c.stroke();
  }
  cv.addEventListener("pointerdown", (ev) => {
    const r = cv.getBoundingClientRect();
    const tt = t0 + (t1 - t0) * (ev.clientX - r.left - pad.l) / (W - pad.l - pad.r);
    pause(); setFrame(frameAt(tt));
  });
  return { draw, cursor };
}
D.series.forEach((s) => plots.push(makePlot(s)));
if (A.mode && D.modeNames.length > 1) {
  const h = document.createElement("div");
  h.className = "note";
  h.innerHTML = "modes (bands along the plots' tops): " + D.modeNames.map((n, k) => `<span style="color:${MODE_COLORS[k % MODE_COLORS.length]}">${n}</span>`).join(", ");
  side.appendChild(h);
}

// ---------------------------------------------------------------------------------- controls
const slider = document.getElementById("slider");
const timeLabel = document.getElementById("time");
slider.max = String(N - 1);
slider.addEventListener("input", () => { pause(); setFrame(+slider.value); });
function frameAt(tt) { // the last frame at or before tt
  let lo = 0, hi = N - 1;
  if (tt >= t[hi]) return hi;
  while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (t[mid] <= tt) lo = mid; else hi = mid; }
  return lo;
}
const span = t1 - t0;
const speeds = [1, 10, 60, 600, 3600, 86400].filter((x) => x < span);
const autoSpeed = span / 60;
const speedSel = document.getElementById("speed");
speedSel.innerHTML = `<option value="${autoSpeed}">run in 1 min (×${autoSpeed.toPrecision(3)})</option>` + speeds.map((x) => `<option value="${x}">×${x}</option>`).join("");
let playing = false, simT = t0, last = null;
const playBtn = document.getElementById("play");
function play() { playing = true; simT = t[frame] >= t1 ? t0 : t[frame]; last = null; playBtn.innerHTML = "&#10074;&#10074;"; requestRender(); }
function pause() { playing = false; playBtn.innerHTML = "&#9654;"; }
playBtn.addEventListener("click", () => (playing ? pause() : play()));
document.addEventListener("keydown", (e) => { if (e.code === "Space" && e.target.tagName !== "SELECT") { e.preventDefault(); playing ? pause() : play(); } });
const camSel = document.getElementById("camera");
camSel.value = camMode;
if (!A.lvlh) camSel.querySelector('option[value="lvlh"]').disabled = true;
camSel.addEventListener("change", () => { camMode = camSel.value; requestRender(); });
const toggles = {};
const togglesEl = document.getElementById("toggles");
for (const [key, label, on] of [["ref", "reference", !!A.ref], ["lvlh", "LVLH", !!A.lvlh], ["earth", "Earth", hasOrbit], ["sun", "Sun", hasSun]]) {
  const l = document.createElement("label");
  l.innerHTML = `<input type="checkbox" ${on ? "checked" : "disabled"}> ${label}`;
  togglesEl.appendChild(l);
  toggles[key] = l.querySelector("input");
  toggles[key].addEventListener("change", () => {
    earth.visible = limb.visible = nadirArrow.visible = hasOrbit && toggles.earth.checked;
    sunArrow.visible = hasSun && toggles.sun.checked;
    setFrame(frame);
  });
}
if (D.ensemble) {
  const el = document.getElementById("members");
  const opts = D.ensemble.members.map((k) => `<option value="${k}" ${k === member ? "selected" : ""}>${k}</option>`).join("");
  el.innerHTML = `<label>member <select id="member">${opts}</select></label> <label><input type="checkbox" id="cloud" checked> boresight cloud (${M} of ${D.ensemble.total})</label>`;
  el.querySelector("#member").addEventListener("change", (e) => setMember(+e.target.value));
  el.querySelector("#cloud").addEventListener("change", (e) => { cloud.visible = e.target.checked; requestRender(); });
}
function setMember(k) {
  const j = D.ensemble ? D.ensemble.members.indexOf(k) : -1;
  if (j < 0) throw new Error(`no member ${k} in this page`);
  member = k;
  qArr = A.members.subarray(4 * N * j, 4 * N * (j + 1));
  setFrame(frame);
}

// ---------------------------------------------------------------------------------- text
document.getElementById("title").textContent = D.title;
const notes = [...D.notes];
if (D.noOrbit) document.getElementById("warn").textContent = D.noOrbit + " (the body and its axes are drawn)";
document.getElementById("notes").innerHTML = notes.map((n) => n.replace(/&/g, "&amp;").replace(/</g, "&lt;")).join("<br>");
const leg = [["#ff4040", "body x"], ["#40e040", "body y"], ["#4080ff", "body z"]];
if (A.ref) leg.push(["#ffbbbb", D.refName + " (light)"]);
if (A.lvlh) leg.push(["#ffaa00", "LVLH x"], ["#cc66ff", "LVLH y"], ["#00dddd", "LVLH z"]);
if (hasSun) leg.push(["#ffdd33", "Sun"]);
if (hasOrbit) leg.push(["#33ddff", "nadir, limb"]);
if (D.sensors.some((s) => s.boresight)) leg.push(["#ff66ff", "boresight (cones: Sun yellow, Earth cyan exclusion)"]);
if (D.thrusters) leg.push(["#ff8822", "thruster plume"]);
document.getElementById("legend").innerHTML = leg.map(([c, n]) => `<span><i style="background:${c}"></i>${n}</span>`).join("");

// ---------------------------------------------------------------------------------- loop
let pending = false;
function requestRender() { if (!pending) { pending = true; requestAnimationFrame(tick); } }
function resize() {
  const w = host.clientWidth, h = host.clientHeight;
  if (renderer) renderer.setSize(w, h, false);
  camera.aspect = proxy.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix(); proxy.updateProjectionMatrix();
  plots.forEach((p) => p.draw());
  plots.forEach((p) => p.cursor(t[frame]));
}
function tick(now) {
  pending = false;
  if (playing) {
    if (last !== null) simT += (now - last) / 1000 * (+speedSel.value);
    last = now;
    if (simT >= t1) { simT = t1; pause(); }
    const f = frameAt(simT);
    if (f !== frame) setFrame(f);
    requestRender();
  }
  placeCamera();
  if (renderer) renderer.render(scene, camera);
}
controls.addEventListener("change", requestRender);
window.addEventListener("resize", () => { resize(); requestRender(); });
window.addEventListener("error", (e) => errors.push(String(e.message)));

resize();
setFrame(0);

// the page's state, for tests and scripts: what is drawn, read back from the scene
window.attitudeView = {
  ready: true,
  nFrames: N,
  webgl: !!renderer,
  setFrame: (i) => { pause(); setFrame(i); placeCamera(); if (renderer) renderer.render(scene, camera); return frame; },
  setMember,
  setCamera: (m) => { camMode = m; camSel.value = m; placeCamera(); if (renderer) renderer.render(scene, camera); },
  play, pause,
  state: () => {
    const q = body.quaternion;
    const sunDir = sunArrow.visible || hasSun ? V(0, 1, 0).applyQuaternion(sunArrow.quaternion) : null;
    const nd = hasOrbit ? V(0, 1, 0).applyQuaternion(nadirArrow.quaternion) : null;
    return {
      frame, member, camera: camMode, playing,
      t: t[frame], sliderValue: +slider.value, sliderTime: t[+slider.value], timeText: timeLabel.textContent,
      q: [q.w, q.x, q.y, q.z],
      bodyAxes: axesOf(body),
      referenceAxes: refAxes.visible ? axesOf(refAxes) : null,
      lvlhAxes: lvlhAxes.visible ? axesOf(lvlhAxes) : null,
      sun: sunDir ? [sunDir.x, sunDir.y, sunDir.z] : null,
      nadir: nd ? [nd.x, nd.y, nd.z] : null,
      lit: A.shadow ? A.shadow[frame] : null,
      sunLight: sunLight.intensity,
      cameraPosition: camera.position.toArray(),
      noOrbit: D.noOrbit,
      boresights: boresights.map((a) => { const v = V(0, 1, 0).applyQuaternion(a.getWorldQuaternion(new THREE.Quaternion())); return [v.x, v.y, v.z]; }),
      plumes: plumes.map((p) => p.mesh.visible),
      cones: cones.map((c) => { const v = V(0, -1, 0).applyQuaternion(c.mesh.getWorldQuaternion(new THREE.Quaternion())); return { kind: c.kind, halfAngle: c.half, axis: [v.x, v.y, v.z] }; }),
      cloud: cloud && cloud.visible ? Array.from(cloud.geometry.attributes.position.array, (x) => x / (2.1 * L)) : null,
      warning: document.getElementById("warn").textContent,
      hud: document.getElementById("hud").innerText,
      errors: [...errors],
    };
  },
};
document.body.dataset.ready = "1";
