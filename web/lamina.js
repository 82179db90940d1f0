// The page of `lamina serve --web` (docs/web.md): the organ and its anatomy as the server's
// simulation deforms them, in a desktop browser (orbit, zoom, a drag that pushes or pulls the
// tissue) or in a headset (WebXR immersive-vr: a controller is the tool tip, its trigger pushes,
// its grip grasps, and it vibrates with the reaction force the server computes).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { MeshoptDecoder } from './vendor/meshopt_decoder.mjs';
import { setupPlan } from './plan.js';

const KIND_SURFACE = 1, KIND_REST = 2, KIND_FRAME = 3;
const token = new URLSearchParams(location.search).get('token') || '';

// What the tests (and a curious user, in the console) can read: window.lamina.stats.
const stats = {
  connected: false, hello: null, frames: 0, framesApplied: 0, lastFrame: null,
  decodeMs: [], applyMs: [], frameBytes: [], latencyMs: [], renderFrames: 0, xrFrames: 0, pulses: [],
  closes: 0, errors: [], cuts: [],
};
window.lamina = { stats };
// For the browser tests (tests/web): the drawn positions, a ray cast on the organ in world
// coordinates, the XR session.
window.lamina.organPositions = () => surfaces.filter((s) => s.desc.organ)
  .map((s) => Array.from(s.geometry.attributes.position.array));
window.lamina.hitOrgan = (origin, direction) => {
  const r = new THREE.Raycaster(new THREE.Vector3(...origin), new THREE.Vector3(...direction).normalize());
  const hits = r.intersectObjects(surfaces.filter((s) => s.desc.organ).map((s) => s.mesh));
  return hits.length ? hits[0].point.toArray() : null;
};
window.lamina.organBox = () => {
  const b = organBox();
  return { min: b.min.toArray(), max: b.max.toArray() };
};
// The organ's box as the camera shows it, in normalized device coordinates (-1..1 across the
// view): the first view frames the organ, not the anatomy reaching beyond it.
window.lamina.organOnScreen = () => {
  const b = organBox(), lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
  for (let c = 0; c < 8; ++c) {
    const p = new THREE.Vector3(c & 1 ? b.max.x : b.min.x, c & 2 ? b.max.y : b.min.y,
      c & 4 ? b.max.z : b.min.z).project(camera);
    lo[0] = Math.min(lo[0], p.x); lo[1] = Math.min(lo[1], p.y);
    hi[0] = Math.max(hi[0], p.x); hi[1] = Math.max(hi[1], p.y);
  }
  return { lo, hi };
};
window.lamina.session = () => renderer.xr.getSession();
// Whether the organ's skin is drawn in the plan's vertex colours.
window.lamina.skinHasColours = () => surfaces.some((s) => s.desc.organ && s.mesh.material.vertexColors);
window.lamina.closeSocket = () => ws && ws.close();

// --- Scene ---
const view = document.getElementById('view');
// Antialiasing is the headset's own business (its compositor); on a software renderer (no GPU)
// multisampling costs more than the whole scene.
const renderer = new THREE.WebGLRenderer({ antialias: false });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
renderer.setSize(view.clientWidth, view.clientHeight);
renderer.xr.enabled = true;
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1b1d22);
scene.add(new THREE.HemisphereLight(0xffffff, 0x303040, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(0.4, 1, 0.8);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, view.clientWidth / view.clientHeight, 1, 20000);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;

// The model's frame is LPS in mm (x left, y posterior, z superior); three.js's is y-up. The organ
// group turns LPS so that superior is up and anterior faces the camera; in a headset it is also
// scaled to metres and put at table height.
const organ = new THREE.Group();
organ.rotation.x = -Math.PI / 2;
scene.add(organ);

let hello = null;        // the server's description of the model
let surfaces = [];       // per drawn surface: {mesh, geometry, corners, weights, offsets}
let restQ = null;        // Uint16Array, 4 per streamed point
let points = null;       // Float32Array, 3 per streamed point, mm
let pendingFrame = null; // the newest frame not yet drawn
let setupDone = 0;

function resetModel() {
  for (const s of surfaces) { organ.remove(s.mesh); s.geometry.dispose(); s.mesh.material.dispose(); }
  surfaces = []; restQ = null; points = null; setupDone = 0;
}

function makeSurfaces(h) {
  resetModel();
  hello = h;
  stats.hello = h;
  for (const d of h.surfaces) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * d.vertices), 3));
    const color = new THREE.Color(d.color[0] / 255, d.color[1] / 255, d.color[2] / 255);
    const material = new THREE.MeshLambertMaterial({
      color, side: THREE.DoubleSide,
      transparent: d.organ && h.surfaces.length > 1, opacity: d.organ && h.surfaces.length > 1 ? 0.55 : 1.0,
      depthWrite: !(d.organ && h.surfaces.length > 1),
    });
    const mesh = new THREE.Mesh(geometry, material);
    mesh.renderOrder = d.organ ? 1 : 0;
    mesh.userData.organ = d.organ;
    mesh.frustumCulled = false;
    organ.add(mesh);
    surfaces.push({ mesh, geometry, desc: d, corners: null, weights: null, offsets: null });
  }
}

// --- The stream's binary messages (docs/web.md "The stream") ---
function decodeVertices(view, at, count, size) {
  const n = view.getUint32(at, true);
  const out = new Uint8Array(count * size);
  if (count > 0) MeshoptDecoder.decodeVertexBuffer(out, count, size, new Uint8Array(view.buffer, at + 4, n));
  return [out, at + 4 + n];
}

function onSurface(buf) {
  const v = new DataView(buf);
  const index = v.getUint32(4, true), nv = v.getUint32(8, true), nt = v.getUint32(12, true);
  const s = surfaces[index];
  if (!s || s.desc.vertices !== nv || s.desc.triangles !== nt) throw new Error('surface message does not match the hello');
  const n = v.getUint32(16, true);
  const indices = new Uint32Array(3 * nt);
  MeshoptDecoder.decodeIndexBuffer(new Uint8Array(indices.buffer), 3 * nt, 4, new Uint8Array(buf, 20, n));
  s.geometry.setIndex(new THREE.BufferAttribute(indices, 1));
  let at = 20 + n;
  if (hello.carried_by === 'nodes') {
    let bytes;
    [bytes, at] = decodeVertices(v, at, nv, 16); s.corners = new Uint32Array(bytes.buffer);
    [bytes, at] = decodeVertices(v, at, nv, 16); s.weights = new Float32Array(bytes.buffer);
    [bytes, at] = decodeVertices(v, at, nv, 16); s.offsets = new Float32Array(bytes.buffer);
  }
  ++setupDone;
}

function onRest(buf) {
  const v = new DataView(buf);
  const count = v.getUint32(4, true);
  const [bytes] = decodeVertices(v, 8, count, 8);
  restQ = new Uint16Array(bytes.buffer);
  points = new Float32Array(3 * count);
  applyQuantized(restQ);
  if (!camera.userData.placed) placeCamera();
}

// Quantized points (4 uint16 per point) to mm, then every drawn vertex.
function applyQuantized(q) {
  const o = hello.origin_mm, step = hello.step_mm, n = q.length / 4;
  for (let i = 0; i < n; ++i) {
    points[3 * i] = o[0] + step * q[4 * i];
    points[3 * i + 1] = o[1] + step * q[4 * i + 1];
    points[3 * i + 2] = o[2] + step * q[4 * i + 2];
  }
  let first = 0;
  for (const s of surfaces) {
    const pos = s.geometry.attributes.position.array, nv = s.desc.vertices;
    if (hello.carried_by === 'nodes') {
      const c = s.corners, w = s.weights, off = s.offsets;
      for (let i = 0; i < nv; ++i) {
        let x = off[4 * i], y = off[4 * i + 1], z = off[4 * i + 2];
        for (let k = 0; k < 4; ++k) {
          const wk = w[4 * i + k];
          if (wk === 0) continue;
          const p = 3 * c[4 * i + k];
          x += wk * points[p]; y += wk * points[p + 1]; z += wk * points[p + 2];
        }
        pos[3 * i] = x; pos[3 * i + 1] = y; pos[3 * i + 2] = z;
      }
    } else {
      pos.set(points.subarray(3 * first, 3 * (first + nv)));
      first += nv;
    }
    s.geometry.attributes.position.needsUpdate = true;
    s.geometry.computeVertexNormals();
    // The bounds follow the shape (picking and the renderer's sorting use them).
    s.geometry.boundingSphere = null;
    s.geometry.boundingBox = null;
  }
}

function onFrame(buf) {
  const v = new DataView(buf);
  const f = {
    frame: v.getUint32(4, true), modelVersion: v.getUint32(8, true),
    time: v.getFloat64(16, true), steps: v.getFloat64(24, true), sentAtUs: v.getFloat64(32, true),
    tools: [0, 1].map((k) => ({
      client: v.getInt32(40 + 24 * k, true), hand: v.getInt32(44 + 24 * k, true),
      pose: v.getUint32(48 + 24 * k, true),
      reaction: [v.getFloat32(52 + 24 * k, true), v.getFloat32(56 + 24 * k, true), v.getFloat32(60 + 24 * k, true)],
      contact: v.getUint8(92 + k) !== 0,
    })),
    volumeChange: v.getFloat32(88, true), unstable: v.getUint8(94) !== 0,
    behind: v.getUint8(95) !== 0, count: v.getUint32(96, true),
  };
  ++stats.frames;
  stats.time = f.time;  // the simulated clock of the newest frame
  stats.frameBytes.push(buf.byteLength);
  const now = performance.now();
  // Latency: from a pose sent to the first frame whose positions reflect it (a tool this page
  // holds names its newest pose applied before the frame's step).
  const reflected = Math.max(0, ...f.tools.filter((t) => t.client === hello.client).map((t) => t.pose));
  for (const [pose, sentAt] of poseSent) {
    if (pose > reflected) break;
    if (f.tools.some((t) => t.client === hello.client && t.pose === pose)) stats.latencyMs.push(now - sentAt);
    poseSent.delete(pose);
  }
  if (!restQ || f.count * 4 !== restQ.length) return;  // a frame of another model: wait
  const t0 = performance.now();
  const [bytes] = decodeVertices(v, 100, f.count, 8);
  const q = new Uint16Array(bytes.buffer);
  for (let k = 0; k < q.length; ++k) q[k] = (q[k] + restQ[k]) & 0xffff;
  stats.decodeMs.push(performance.now() - t0);
  pendingFrame = { f, q };
  stats.lastFrame = f;
}

// A cut the server made (a scalpel over OpenIGTLink): what it divided and each vessel it crossed,
// a simulator's bleeding cue. The model that follows comes as a new hello.
function onCut(m) {
  stats.cuts.push(m);
  const crossed = m.structures_cut.map((c) => `${c.name} (${c.diameter_mm.toFixed(1)} mm)`);
  status(`cut ${m.cuts}: ${m.cut_tets} tetrahedra divided, ${m.pieces.length} piece(s)` +
         (crossed.length ? `; crossed ${crossed.join(', ')}` : ''), crossed.length > 0);
}

// --- Connection ---
let ws = null;
let poseNumber = 0;
const poseSent = new Map();  // pose number -> when sent (performance.now()), oldest first

function send(message) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message));
}

function status(text, bad) {
  const el = document.getElementById('status');
  el.textContent = text;
  el.className = bad ? 'bad' : '';
}

function connect() {
  const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
  ws = new WebSocket(`${scheme}://${location.host}/stream?token=${encodeURIComponent(token)}`);
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { stats.connected = true; status('connected'); };
  ws.onmessage = (event) => {
    try {
      if (typeof event.data === 'string') {
        const m = JSON.parse(event.data);
        if (m.type === 'hello') { makeSurfaces(m); plan.onModel(); }
        else if (m.type === 'plan') plan.onReply(m);
        else if (m.type === 'event') status(m.text, m.bad);
        else if (m.type === 'cut') onCut(m);
        return;
      }
      const kind = new DataView(event.data).getUint32(0, true);
      if (kind === KIND_SURFACE) onSurface(event.data);
      else if (kind === KIND_REST) onRest(event.data);
      else if (kind === KIND_FRAME) onFrame(event.data);
    } catch (e) {
      stats.errors.push(String(e));
      status('stream error: ' + e, true);
    }
  };
  ws.onclose = () => {
    stats.connected = false;
    ++stats.closes;
    status('disconnected: reconnecting...', true);
    setTimeout(connect, 1000);
  };
}

// --- Desktop: a drag on the organ pushes or pulls it (force = gain x drag, as lamina view) ---
const raycaster = new THREE.Raycaster();
let dragging = null;  // {plane, start (world)}

function ndc(event) {
  const r = renderer.domElement.getBoundingClientRect();
  return new THREE.Vector2(((event.clientX - r.left) / r.width) * 2 - 1,
                           -((event.clientY - r.top) / r.height) * 2 + 1);
}

function toModel(worldPoint) { return organ.worldToLocal(worldPoint.clone()).toArray(); }

renderer.domElement.addEventListener('pointerdown', (event) => {
  if (event.button !== 0 || renderer.xr.isPresenting || !hello) return;
  raycaster.setFromCamera(ndc(event), camera);
  const hits = raycaster.intersectObjects(surfaces.filter((s) => s.desc.organ).map((s) => s.mesh));
  if (hits.length === 0) return;
  controls.enabled = false;
  const start = hits[0].point.clone();
  const normal = camera.getWorldDirection(new THREE.Vector3()).negate();
  dragging = { plane: new THREE.Plane().setFromNormalAndCoplanarPoint(normal, start), start };
  const origin = toModel(raycaster.ray.origin);
  const through = toModel(raycaster.ray.origin.clone().add(raycaster.ray.direction));
  send({ type: 'press', origin, direction: through.map((t, i) => t - origin[i]) });
});

renderer.domElement.addEventListener('pointermove', (event) => {
  if (!dragging) return;
  raycaster.setFromCamera(ndc(event), camera);
  const at = raycaster.ray.intersectPlane(dragging.plane, new THREE.Vector3());
  if (!at) return;
  const a = toModel(dragging.start), b = toModel(at);
  send({ type: 'drag', drag_mm: b.map((t, i) => t - a[i]) });
});

window.addEventListener('pointerup', () => {
  if (!dragging) return;
  dragging = null;
  controls.enabled = true;
  send({ type: 'release' });
});

// The organ's own surfaces' box (the display skin; the skin layer of a model without one), not
// everything drawn: a real segmentation's vena cava and portal trunk run far beyond the liver.
function organBox() {
  organ.updateMatrixWorld(true);
  const box = new THREE.Box3();
  const own = surfaces.filter((s) => s.desc.role === 'display_skin');
  for (const s of (own.length ? own : surfaces)) box.expandByObject(s.mesh);
  return box;
}

function placeCamera() {
  const box = organBox();
  const center = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3()).length();
  controls.target.copy(center);
  camera.position.copy(center).add(new THREE.Vector3(0, 0, 1.4 * size));
  camera.near = size / 100; camera.far = size * 20;
  camera.updateProjectionMatrix();
  controls.update();
  camera.userData.placed = true;
}

// --- Headset: each controller is a tool; trigger pushes (tool tip), grip grasps ---
// Hand 0 is the right controller, hand 1 the left; each drawn as a small sphere at its pose.
const hands = [0, 1].map(() => {
  const tip = new THREE.Mesh(new THREE.SphereGeometry(0.005, 16, 12),
                             new THREE.MeshStandardMaterial({ color: 0xdddddd }));
  tip.visible = false;
  scene.add(tip);
  return { tip, source: null };
});
const enterVr = document.getElementById('enter-vr');
if (navigator.xr) {
  navigator.xr.isSessionSupported('immersive-vr').then((ok) => { enterVr.hidden = !ok; });
}
enterVr.addEventListener('click', async () => {
  const session = await navigator.xr.requestSession('immersive-vr', { optionalFeatures: ['local-floor'] });
  renderer.xr.setReferenceSpaceType('local-floor');
  await renderer.xr.setSession(session);
});
let placeInXr = false;  // the organ is put before the user at the session's first frame
let desktopClip = null;  // the desktop camera's near and far (mm), put back after the session
renderer.xr.addEventListener('sessionstart', () => {
  organ.scale.setScalar(0.001);  // mm to m
  placeInXr = true;
  // The session's clipping planes are the camera's, and the headset's units are metres.
  desktopClip = [camera.near, camera.far];
  camera.near = 0.01;
  camera.far = 50;
  camera.updateProjectionMatrix();
  const session = renderer.xr.getSession();
  const assign = () => {
    for (const h of hands) h.source = null;
    for (const source of session.inputSources) {
      if (source.handedness === 'right') hands[0].source = source;
      else if (source.handedness === 'left') hands[1].source = source;
    }
  };
  session.addEventListener('inputsourceschange', assign);
  assign();
});
renderer.xr.addEventListener('sessionend', () => {
  organ.scale.setScalar(1); organ.position.set(0, 0, 0);
  if (desktopClip) [camera.near, camera.far] = desktopClip;
  camera.updateProjectionMatrix();
});

// At table height before the user: half a metre ahead of the eyes and 35 cm below them.
function placeBeforeUser(xrFrame) {
  const viewer = xrFrame.getViewerPose(renderer.xr.getReferenceSpace());
  if (!viewer || !surfaces.length) return;
  const eye = viewer.transform.position;
  const ahead = new THREE.Vector3(0, 0, -1).applyQuaternion(new THREE.Quaternion(
    viewer.transform.orientation.x, viewer.transform.orientation.y, viewer.transform.orientation.z,
    viewer.transform.orientation.w));
  ahead.y = 0;
  if (ahead.lengthSq() < 1e-6) ahead.set(0, 0, -1);
  ahead.normalize();
  organ.position.set(0, 0, 0);
  organ.updateMatrixWorld(true);
  const c = organBox().getCenter(new THREE.Vector3());
  organ.position.set(eye.x, eye.y - 0.35, eye.z).addScaledVector(ahead, 0.5).sub(c);
  placeInXr = false;
}

// Each XR frame: every controller's pose (its target ray's origin, in the model's frame, mm),
// trigger and grip, numbered so that the frames can say which one they show.
function sendHands(xrFrame) {
  const space = renderer.xr.getReferenceSpace();
  for (let i = 0; i < 2; ++i) {
    const h = hands[i];
    const pad = h.source && h.source.gamepad;
    const pose = h.source && xrFrame.getPose(h.source.targetRaySpace, space);
    h.tip.visible = !!pose;
    if (!pad || !pose) continue;
    const p = pose.transform.position;
    h.tip.position.set(p.x, p.y, p.z);
    const trigger = pad.buttons[0] ? pad.buttons[0].value : 0, grip = pad.buttons[1] ? pad.buttons[1].value : 0;
    const position = toModel(new THREE.Vector3(p.x, p.y, p.z));
    const number = ++poseNumber;
    poseSent.set(number, performance.now());
    if (poseSent.size > 1000) poseSent.delete(poseSent.keys().next().value);
    send({ type: 'hand', hand: i, pose: number, position, trigger, grip });
  }
}

// Vibration with the reaction the server computed on each tool this page's hands hold, as a
// share of the most it sends (hello.max_force_mn).
function pulse(f) {
  for (const tool of f.tools) {
    if (tool.client !== hello.client || tool.hand < 0 || tool.hand > 1 || !tool.contact) continue;
    const h = hands[tool.hand];
    const pad = h.source && h.source.gamepad;
    const actuator = pad && pad.hapticActuators && pad.hapticActuators[0];
    if (!actuator) continue;
    const magnitude = Math.hypot(...tool.reaction);
    const amplitude = Math.min(1, magnitude / hello.max_force_mn);
    actuator.pulse(amplitude, 20);
    stats.pulses.push({ hand: tool.hand, amplitude, reaction_mn: magnitude });
  }
}

// --- Plots ---
const history = { reaction: [], volume: [] };
function plot(id, values, color) {
  const c = document.getElementById(id), g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  if (values.length < 2) return;
  let lo = Math.min(...values), hi = Math.max(...values);
  if (hi - lo < 1e-9) { hi += 1; lo -= 1; }
  g.strokeStyle = color; g.beginPath();
  values.forEach((y, i) => {
    const px = (i / (values.length - 1)) * c.width, py = c.height - ((y - lo) / (hi - lo)) * (c.height - 4) - 2;
    if (i === 0) g.moveTo(px, py); else g.lineTo(px, py);
  });
  g.stroke();
}

function showFrame(f) {
  const r = Math.max(...f.tools.map((t) => Math.hypot(...t.reaction)));
  history.reaction.push(r); history.volume.push(f.volumeChange);
  if (history.reaction.length > 240) { history.reaction.shift(); history.volume.shift(); }
  if (stats.frames % 4 === 0) {
    document.getElementById('reaction').textContent = r.toFixed(1);
    document.getElementById('volume').textContent = f.volumeChange.toFixed(2);
    plot('reaction-plot', history.reaction, '#ffb347');
    plot('volume-plot', history.volume, '#7ec8ff');
    document.getElementById('rates').textContent =
      `t = ${f.time.toFixed(2)} s, ${f.steps} steps` + (f.behind ? ' - BEHIND real time' : '');
  }
  if (f.unstable) status('the simulation became unstable: reset to rest', true);
}

renderer.setAnimationLoop((time, xrFrame) => {
  ++stats.renderFrames;
  if (xrFrame) {
    ++stats.xrFrames;
    if (placeInXr) placeBeforeUser(xrFrame);
    sendHands(xrFrame);
  }
  if (pendingFrame && restQ && setupDone === surfaces.length) {
    const t0 = performance.now();
    applyQuantized(pendingFrame.q);
    stats.applyMs.push(performance.now() - t0);
    showFrame(pendingFrame.f);
    if (renderer.xr.isPresenting) pulse(pendingFrame.f);
    ++stats.framesApplied;
    pendingFrame = null;
  }
  if (!renderer.xr.isPresenting) controls.update();
  renderer.render(scene, camera);
});

window.addEventListener('resize', () => {
  camera.aspect = view.clientWidth / view.clientHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(view.clientWidth, view.clientHeight);
});

// The resection plan (plan.js): a plane the server plans along, the skin coloured by its answer.
const plan = setupPlan({ organ, surfaces: () => surfaces, send, organBox, stats });

MeshoptDecoder.ready.then(connect);
