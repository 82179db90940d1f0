// The resection plan on the page (docs/web.md "Planning a resection"): a plane through the organ
// moved along its normal by a slider (the axis chosen), sent to the server, which plans on the
// organ's current shape (the volumes, the FLR, the functional remnant when the model carries
// the portal and hepatic trees) and says what each vertex of the skin shows: the remnant's side
// coloured by the portal territory feeding it, its tissue cut off its inflow or outflow shaded,
// the resected side left as it was.
import * as THREE from 'three';

// model::SurfaceFunction: 0 resected side, 1-8 the portal sectors, 9 devascularized,
// 10 congested, 11 both, 12 functional without a portal tree. Linear RGB, as three.js lights it.
const STATE_COLORS = [
  null,
  [0.95, 0.75, 0.35], [0.4, 0.8, 0.6], [0.92, 0.6, 0.75], [0.98, 0.92, 0.5],
  [0.65, 0.85, 0.35], [0.6, 0.88, 0.9], [0.78, 0.7, 0.95], [0.8, 0.75, 0.6],
  [0.3, 0.24, 0.38], [0.2, 0.29, 0.42], [0.13, 0.13, 0.15], [0.75, 0.45, 0.4],
];
const AXES = { x: [1, 0, 0], y: [0, 1, 0], z: [0, 0, 1] };

// `page`: { organ (the model-frame group), surfaces () => the drawn surfaces, send, organBox,
// stats }. Returns what the page calls when a reply comes and when the model changes.
export function setupPlan(page) {
  const toggle = document.getElementById('plan');
  const controls = document.getElementById('plan-controls');
  const slider = document.getElementById('plan-at');
  const axis = document.getElementById('plan-axis');
  const text = document.getElementById('plan-report');
  let on = false, plane = null, pending = false, lastSent = 0, timer = null, skinIndex = -1;

  // The plane's point and normal in the model's frame (mm), from the organ's box.
  function where() {
    const box = page.organBox();
    const inverse = page.organ.matrixWorld.clone().invert();
    const lo = box.min.clone().applyMatrix4(inverse), hi = box.max.clone().applyMatrix4(inverse);
    const min = lo.clone().min(hi), max = lo.clone().max(hi);
    const n = new THREE.Vector3(...AXES[axis.value]);
    const centre = min.clone().add(max).multiplyScalar(0.5);
    const half = max.clone().sub(min).multiplyScalar(0.5).dot(n);
    const point = centre.clone().add(n.clone().multiplyScalar(Number(slider.value) * half));
    return { point, normal: n, size: 1.3 * max.clone().sub(min).length() };
  }

  function drawPlane() {
    const w = where();
    if (!plane) {
      plane = new THREE.Mesh(new THREE.PlaneGeometry(1, 1),
        new THREE.MeshBasicMaterial({ color: 0x4fc06a, transparent: true, opacity: 0.3,
                                      side: THREE.DoubleSide, depthWrite: false }));
      plane.renderOrder = 2;
      page.organ.add(plane);
    }
    plane.scale.set(w.size, w.size, 1);
    plane.position.copy(w.point);
    plane.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), w.normal);
    return w;
  }

  // At most ten plans a second; the last move is always sent.
  function request() {
    if (!on) return;
    const w = drawPlane();
    const now = performance.now();
    if (pending || now - lastSent < 100) {
      clearTimeout(timer);
      timer = setTimeout(request, 100);
      return;
    }
    pending = true;
    page.stats.planPending = true;
    lastSent = now;
    page.stats.planRequests = (page.stats.planRequests || 0) + 1;
    page.send({ type: 'plan', point: w.point.toArray(), normal: w.normal.toArray() });
  }

  function uncolour() {
    const s = page.surfaces()[skinIndex];
    skinIndex = -1;
    if (!s) return;
    s.mesh.material.vertexColors = false;
    s.mesh.material.needsUpdate = true;
  }

  function colour(index, state) {
    const s = page.surfaces()[index];
    if (!s || state.length !== s.desc.vertices) return;
    const rgb = new Float32Array(3 * state.length);
    const base = s.mesh.material.color;
    for (let v = 0; v < state.length; ++v) {
      const c = STATE_COLORS[state[v]] || [base.r, base.g, base.b];
      rgb.set(c, 3 * v);
    }
    s.geometry.setAttribute('color', new THREE.BufferAttribute(rgb, 3));
    if (!s.mesh.userData.ownColor) s.mesh.userData.ownColor = base.clone();
    s.mesh.material.color.set(0xffffff);
    s.mesh.material.vertexColors = true;
    s.mesh.material.needsUpdate = true;
    skinIndex = index;
  }

  toggle.addEventListener('change', () => {
    on = toggle.checked;
    controls.hidden = !on;
    if (on) { request(); return; }
    if (plane) { page.organ.remove(plane); plane.geometry.dispose(); plane.material.dispose(); plane = null; }
    const s = page.surfaces()[skinIndex];
    if (s && s.mesh.userData.ownColor) s.mesh.material.color.copy(s.mesh.userData.ownColor);
    uncolour();
    text.textContent = '';
  });
  slider.addEventListener('input', request);
  axis.addEventListener('change', request);

  return {
    onReply(m) {
      pending = false;
      page.stats.planPending = false;
      page.stats.plan = m;
      if (!on) return;
      if (m.error) { text.textContent = m.error; return; }
      const f = m.functional;
      const lines = [
        `remnant ${m.remnant_ml.toFixed(0)} mL, resected ${m.resected_ml.toFixed(0)} mL`,
        `FLR ${m.flr_percent.toFixed(1)}%`,
      ];
      for (const t of m.tumours) lines.push(`${t.name}: ${t.side}, margin ${t.margin_mm.toFixed(1)} mm`);
      if (f) {
        lines.push(`functional FLR ${f.percent.toFixed(1)}% (${f.functional_ml.toFixed(0)} mL)`);
        lines.push(`devascularized ${f.devascularized_ml.toFixed(0)} mL, congested ${f.congested_ml.toFixed(0)} mL`);
      } else {
        lines.push('functional remnant not assessed: ' + m.functional_missing);
      }
      text.textContent = lines.join('\n');
      if (m.skin_surface >= 0 && m.skin_state) colour(m.skin_surface, m.skin_state);
    },
    // A new model (a cut, a reconnection): its surfaces are new; plan again on it.
    onModel() { skinIndex = -1; pending = false; if (on) request(); },
  };
}
