// coloc view: the map in 3-D (three.js), live frames from the event stream, keyframe panels.
// Poses arrive as [qx, qy, qz, qw, tx, ty, tz] = world_from_cam (camera x right, y down,
// z forward), metres, in the map's frame.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { showKeyframe, showLive, showRegistration, setCounts } from './panels.js';

const canvas = document.getElementById('canvas');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15171a);
const camera = new THREE.PerspectiveCamera(60, 1, 0.01, 1000);
const controls = new OrbitControls(camera, canvas);
const layers = {};  // name -> THREE.Object3D
const state = { scene: null, version: -1, fetching: false, scanPoints: 0, live: null, liveTrail: [],
                framed: false, selected: null, registration: null };

function poseMatrix(p) {
  const m = new THREE.Matrix4();
  m.compose(new THREE.Vector3(p[4], p[5], p[6]), new THREE.Quaternion(p[0], p[1], p[2], p[3]),
            new THREE.Vector3(1, 1, 1));
  return m;
}

// A camera frustum's 8 segments (apex to the 4 image corners, and the image rectangle).
function frustumSegments(pose, cam, size, out) {
  const m = poseMatrix(pose);
  const w = cam ? cam.width : 640, h = cam ? cam.height : 480;
  const fx = cam ? cam.fx : 525, fy = cam ? cam.fy : 525, cx = cam ? cam.cx : w / 2, cy = cam ? cam.cy : h / 2;
  const corner = (u, v) => new THREE.Vector3((u - cx) / fx * size, (v - cy) / fy * size, size).applyMatrix4(m);
  const o = new THREE.Vector3(0, 0, 0).applyMatrix4(m);
  const c = [corner(0, 0), corner(w, 0), corner(w, h), corner(0, h)];
  for (let i = 0; i < 4; ++i) {
    out.push(o.x, o.y, o.z, c[i].x, c[i].y, c[i].z);
    const n = c[(i + 1) % 4];
    out.push(c[i].x, c[i].y, c[i].z, n.x, n.y, n.z);
  }
}

function lines(positions, colour, name) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  const obj = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: colour }));
  obj.name = name;
  return obj;
}

function replaceLayer(name, obj) {
  if (layers[name]) {
    scene.remove(layers[name]);
    layers[name].traverse((o) => { if (o.geometry) o.geometry.dispose(); });
  }
  layers[name] = obj;
  const box = document.querySelector(`input[data-layer="${name}"]`);
  obj.visible = box ? box.checked : true;
  scene.add(obj);
}

// The map frame's up axis: the scan's frame is z up; a SLAM frame is the first camera's (y down).
function upAxis() {
  return state.scene && state.scene.frame !== 'slam' ? new THREE.Vector3(0, 0, 1) : new THREE.Vector3(0, -1, 0);
}

function ramp(t) {  // blue (few) -> green -> orange (many), bright on the dark background
  t = Math.min(1, Math.max(0, t));
  const c = new THREE.Color().setHSL(0.62 - 0.55 * t, 0.85, 0.6);
  return [c.r, c.g, c.b];
}

// The region worth framing: keyframe centres and the 5-95 % range of the points on each axis
// (a few far points must not shrink the map to a dot).
function sceneBox(s) {
  const box = new THREE.Box3();
  for (const k of s.keyframes) box.expandByPoint(new THREE.Vector3(k.pose[4], k.pose[5], k.pose[6]));
  const xyz = s.points.xyz, n = xyz.length / 3;
  if (n >= 20) {
    const lo = [], hi = [];
    for (let a = 0; a < 3; ++a) {
      const v = Array.from({ length: n }, (_, i) => xyz[3 * i + a]).sort((x, y) => x - y);
      lo.push(v[Math.floor(0.05 * n)]); hi.push(v[Math.floor(0.95 * n)]);
    }
    box.expandByPoint(new THREE.Vector3(...lo)); box.expandByPoint(new THREE.Vector3(...hi));
  }
  return box;
}

// Looks at the map from behind the keyframes' mean viewing direction and above.
function frameView(s, box) {
  const c = box.getCenter(new THREE.Vector3());
  const extent = Math.max(0.5, box.getSize(new THREE.Vector3()).length());
  const dir = new THREE.Vector3();
  for (const k of s.keyframes) dir.add(new THREE.Vector3(0, 0, 1).applyQuaternion(new THREE.Quaternion(k.pose[0], k.pose[1], k.pose[2], k.pose[3])));
  if (dir.lengthSq() < 1e-9) dir.set(1, 0, 0);
  dir.normalize();
  const up = upAxis();
  dir.sub(up.clone().multiplyScalar(dir.dot(up))).normalize();
  camera.up.copy(up);
  camera.position.copy(c).addScaledVector(dir, -0.9 * extent).addScaledVector(up, 0.6 * extent);
  controls.target.copy(c);
  controls.update();
}

function pointsLayer(s) {
  const xyz = s.points.xyz, obs = s.points.observations, n = obs.length;
  const colours = new Float32Array(3 * n);
  const byHeight = document.getElementById('point-colour').value === 'height';
  const up = upAxis();
  let lo = Infinity, hi = -Infinity;
  const heights = new Float32Array(n);
  for (let i = 0; i < n; ++i) {
    heights[i] = xyz[3 * i] * up.x + xyz[3 * i + 1] * up.y + xyz[3 * i + 2] * up.z;
    lo = Math.min(lo, heights[i]); hi = Math.max(hi, heights[i]);
  }
  for (let i = 0; i < n; ++i) {
    const t = byHeight ? (heights[i] - lo) / Math.max(1e-6, hi - lo) : (obs[i] - 2) / 10;
    colours.set(ramp(t), 3 * i);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(xyz, 3));
  g.setAttribute('color', new THREE.BufferAttribute(colours, 3));
  return new THREE.Points(g, new THREE.PointsMaterial({ size: 2, sizeAttenuation: false, vertexColors: true }));
}

function markerLayer(markers, colour) {
  const out = [];
  for (const m of markers) {
    const c = m.corners;
    for (let i = 0; i < 4; ++i) {
      const j = (i + 1) % 4;
      out.push(c[3 * i], c[3 * i + 1], c[3 * i + 2], c[3 * j], c[3 * j + 1], c[3 * j + 2]);
    }
    // The first edge (top-left to top-right) again from the centre: which way the marker faces.
    const cx = (c[0] + c[3] + c[6] + c[9]) / 4, cy = (c[1] + c[4] + c[7] + c[10]) / 4, cz = (c[2] + c[5] + c[8] + c[11]) / 4;
    out.push(cx, cy, cz, (c[0] + c[3]) / 2, (c[1] + c[4]) / 2, (c[2] + c[5]) / 2);
  }
  return lines(out, colour);
}

function buildScene(s) {
  const kfs = s.keyframes, byId = new Map(kfs.map((k) => [k.id, k]));
  const box = sceneBox(s);
  const extent = box.isEmpty() ? 1 : Math.max(0.5, box.getSize(new THREE.Vector3()).length());
  state.frustumSize = Math.max(0.03, 0.025 * extent);
  const fr = [];
  for (const k of kfs) frustumSegments(k.pose, s.camera, state.frustumSize, fr);
  replaceLayer('frusta', lines(fr, 0x4da3ff, 'frusta'));
  const centre = (k) => [k.pose[4], k.pose[5], k.pose[6]];
  const traj = [];
  const byTime = [...kfs].sort((a, b) => a.t - b.t);
  for (let i = 1; i < byTime.length; ++i) traj.push(...centre(byTime[i - 1]), ...centre(byTime[i]));
  replaceLayer('trajectory', lines(traj, 0xffffff, 'trajectory'));
  const cov = [];
  for (const [a, b] of s.covisibility) if (byId.has(a) && byId.has(b)) cov.push(...centre(byId.get(a)), ...centre(byId.get(b)));
  replaceLayer('covisibility', lines(cov, 0x3c9a4c, 'covisibility'));
  const loops = [];
  for (const [a, b] of s.loop_edges) if (byId.has(a) && byId.has(b)) loops.push(...centre(byId.get(a)), ...centre(byId.get(b)));
  replaceLayer('loops', lines(loops, 0xff3b3b, 'loops'));
  replaceLayer('points', pointsLayer(s));
  replaceLayer('slamMarkers', markerLayer(s.slam_markers, 0xff9d2e));
  replaceLayer('scanMarkers', markerLayer(s.scan_markers, 0x2ee6ff));
  if (!state.framed && kfs.length > 0) {
    state.framed = true;
    frameView(s, box);
  }
  setCounts({ keyframes: kfs.length, points: s.points.observations.length, slamMarkers: s.slam_markers.length,
              scanMarkers: s.scan_markers.length, loops: s.loop_edges.length, frame: s.frame });
}

async function fetchScene() {
  if (state.fetching) return;
  state.fetching = true;
  try {
    const r = await fetch('/api/map');
    if (r.ok) {
      const s = await r.json();
      if (s.keyframes && s.version !== state.version) {
        state.scene = s; state.version = s.version;
        buildScene(s);
      }
    }
  } finally { state.fetching = false; }
}

async function fetchScan() {
  const r = await fetch('/api/scan.bin');
  if (!r.ok) return;
  const buf = await r.arrayBuffer();
  const n = new DataView(buf).getUint32(0, true);
  const xyz = new Float32Array(buf, 4, 3 * n);
  const rgb = new Uint8Array(buf, 4 + 12 * n, 3 * n);
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(xyz, 3));
  g.setAttribute('color', new THREE.BufferAttribute(rgb, 3, true));
  replaceLayer('scan', new THREE.Points(g, new THREE.PointsMaterial({ size: 1.5, sizeAttenuation: false, vertexColors: true })));
  state.scanPoints = n;
  setCounts({ scanPoints: n });
}

// The live camera: a larger frustum coloured by the tracking state, and the path of its poses.
function showLiveFrame(f) {
  state.live = f;
  showLive(f);
  if (!f.pose) return;
  state.liveTrail.push(f.pose[4], f.pose[5], f.pose[6]);
  const fr = [];
  frustumSegments(f.pose, state.scene ? state.scene.camera : null, 2 * (state.frustumSize || 0.05), fr);
  const colour = f.state === 'lost' ? 0xff3333 : 0x33ff66;
  const group = new THREE.Group();
  group.add(lines(fr, colour));
  if (state.liveTrail.length >= 6) {
    const t = state.liveTrail, seg = [];
    for (let i = 3; i < t.length; i += 3) seg.push(t[i - 3], t[i - 2], t[i - 1], t[i], t[i + 1], t[i + 2]);
    group.add(lines(seg, 0x33ff66));
  }
  replaceLayer('live', group);
  if (document.querySelector('input[data-layer="follow"]').checked) {
    const p = new THREE.Vector3(f.pose[4], f.pose[5], f.pose[6]);
    camera.position.add(p.clone().sub(controls.target));
    controls.target.copy(p);
  }
}

function connect() {
  const events = new EventSource('/api/events');
  const status = document.getElementById('connection');
  events.addEventListener('hello', () => { status.textContent = 'connected'; status.className = 'ok'; fetchScene(); });
  events.addEventListener('map', (e) => { if (JSON.parse(e.data).version !== state.version) fetchScene(); });
  events.addEventListener('frame', (e) => showLiveFrame(JSON.parse(e.data)));
  events.onerror = () => { status.textContent = 'disconnected (retrying)'; status.className = 'bad'; };
}

// Screen position (CSS pixels in the canvas) of a keyframe's camera centre, or null.
function keyframeScreenPosition(id) {
  const k = state.scene && state.scene.keyframes.find((x) => x.id === id);
  if (!k) return null;
  const p = new THREE.Vector3(k.pose[4], k.pose[5], k.pose[6]).project(camera);
  const rect = canvas.getBoundingClientRect();
  return { x: rect.left + (p.x + 1) / 2 * rect.width, y: rect.top + (1 - p.y) / 2 * rect.height, visible: Math.abs(p.z) < 1 };
}

// A click selects the keyframe whose camera centre is nearest on screen (within 15 pixels).
function pick(event) {
  if (!state.scene) return;
  let best = null, bestDist = 15;
  for (const k of state.scene.keyframes) {
    const s = keyframeScreenPosition(k.id);
    const d = Math.hypot(s.x - event.clientX, s.y - event.clientY);
    if (s.visible && d < bestDist) { best = k; bestDist = d; }
  }
  if (!best) return;
  state.selected = best.id;
  const fr = [];
  frustumSegments(best.pose, state.scene.camera, 1.3 * state.frustumSize, fr);
  replaceLayer('selected', lines(fr, 0xffe14d));
  showKeyframe(best.id, state.registration, best);
}

let down = null;
canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
canvas.addEventListener('pointerup', (e) => {
  if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) pick(e);
  down = null;
});
for (const box of document.querySelectorAll('input[data-layer]')) {
  box.addEventListener('change', () => { if (layers[box.dataset.layer]) layers[box.dataset.layer].visible = box.checked; });
}
document.getElementById('point-colour').addEventListener('change', () => { if (state.scene) replaceLayer('points', pointsLayer(state.scene)); });

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.floor(w * window.devicePixelRatio) || canvas.height !== Math.floor(h * window.devicePixelRatio)) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
  }
}
renderer.setAnimationLoop(() => { resize(); controls.update(); renderer.render(scene, camera); });

window.colocView = { state, keyframeScreenPosition, layers };
(async () => {
  const info = await (await fetch('/api/info')).json();
  document.getElementById('mode').textContent = info.mode || '';
  document.getElementById('source').textContent = info.map || '';
  if (info.live) document.getElementById('live').hidden = false;
  await fetchScene();
  await fetchScan();
  state.registration = await showRegistration();
  connect();
})();
