// The conformorph viewer: upload meshes and landmarks (or pick them), run a morph job,
// follow it live, then play the GLB morph animation, read its metrics and download it.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { STLLoader } from 'three/addons/loaders/STLLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Api, ApiError } from './api.js';
import { parseLandmarks, LandmarkError } from './landmarks.js';
import { angleDistortionHistogram, drawHistogram, findHistograms } from './histogram.js';
import { initShapes2d } from './shapes2d.js';

const $ = (id) => document.getElementById(id);
const api = new Api('');

const state = {
  meshFiles: [],
  landmarkLists: null, // from a file
  picks: [], // per mesh: [{point: [x,y,z]}]
  pickMesh: 0,
  detected: null, // {landmarksId, confidence, warnings} of the last detection job
  repicked: 0, // landmarks moved by a person after detection
  jobId: null,
  job: null,
  jobState: 'idle',
  progress: 0,
  stage: null,
  error: null,
  loaded: false,
  playing: false,
  time: 0,
  duration: 0,
  glbBytes: 0,
  metrics: null,
  seen: [], // "state stage" of every update, in order (deduplicated)
  repairs: {}, // repair → 1-based meshes that need it (from the uploads' reports)
};

// ------------------------------------------------------------------ three.js scene

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xeef1f5);
const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
camera.position.set(0, 0, 5);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(1, 2, 3);
scene.add(sun);
const controls = new OrbitControls(camera, canvas);
let lastFrame = performance.now();
function delta() {
  const now = performance.now();
  const dt = (now - lastFrame) / 1000;
  lastFrame = now;
  return dt;
}

let content = null; // what is shown: the result or the mesh being picked
let morphMesh = null;
let mixer = null;
let action = null;
let refPositions = null;
let markers = new THREE.Group();
scene.add(markers);

function resize() {
  const r = canvas.parentElement.getBoundingClientRect();
  const w = Math.max(200, Math.floor(r.width));
  const h = Math.max(200, Math.floor(r.height));
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);

// GLBs above 16 MiB come EXT_meshopt_compression-compressed (conformorph morph --compress)
function gltfLoader() {
  return new GLTFLoader().setMeshoptDecoder(MeshoptDecoder);
}

function show(object) {
  if (content) scene.remove(content);
  content = object;
  scene.add(object);
  const box = new THREE.Box3().setFromObject(object);
  const size = box.getSize(new THREE.Vector3()).length() || 1;
  const center = box.getCenter(new THREE.Vector3());
  controls.target.copy(center);
  camera.near = size / 100;
  camera.far = size * 100;
  camera.position.copy(center).add(new THREE.Vector3(0, 0, size * 1.4));
  camera.updateProjectionMatrix();
  controls.update();
  markers.clear();
}

function frame() {
  const dt = delta();
  if (mixer && state.playing) {
    mixer.update(dt);
    state.time = action.time;
    $('scrub').value = String(state.time);
    $('time').textContent = `${state.time.toFixed(2)} / ${state.duration.toFixed(2)} s`;
    maybeHistogram();
  }
  controls.update();
  renderer.render(scene, camera);
  requestAnimationFrame(frame);
}

// ------------------------------------------------------------------ status & helpers

function setStatus(text, kind = '') {
  const el = $('status');
  el.textContent = text;
  el.className = kind;
}

function showError(e) {
  state.error = e instanceof ApiError ? { type: e.type, message: e.message, status: e.status } : { message: String(e.message || e) };
  setStatus(`Error: ${e.message || e}`, 'error');
}

// the server's reason for a failed or cancelled job, shown as soon as the state arrives
function showJobFailure(job) {
  const err = job.error || {};
  state.error = err;
  setStatus(`job ${job.state}${err.stage ? ` in ${err.stage}` : ''}: ${err.message || ''}${err.field ? ` (${err.field})` : ''}`, 'error');
}

function updateJob(job) {
  const tag = `${job.state} ${job.stage || '-'}`;
  if (state.seen[state.seen.length - 1] !== tag) state.seen.push(tag);
  state.job = job;
  state.jobState = job.state;
  state.progress = job.progress;
  state.stage = job.stage;
  $('job-id').textContent = job.id;
  $('job-state').textContent = job.state;
  $('job-stage').textContent = job.stage || '–';
  $('job-progress').value = job.progress;
  $('job-progress-text').textContent = `${Math.round(job.progress * 100)}%`;
  const rows = job.stages
    .map((s) => `<tr><td>${s.name}</td><td>${s.state}</td><td>${s.seconds == null ? '' : s.seconds.toFixed(2)}</td></tr>`)
    .join('');
  $('stages').innerHTML = `<tr><th>stage</th><th>state</th><th>s</th></tr>${rows}`;
  if (job.state === 'failed' || job.state === 'cancelled') showJobFailure(job);
}

// ------------------------------------------------------------------ API key

function keyChanged() {
  api.key = $('api-key').value.trim();
  try {
    localStorage.setItem('conformorph-api-key', api.key);
  } catch {
    /* storage may be off */
  }
  checkServer();
}

async function checkServer() {
  try {
    const ready = await api.readyz();
    await api.listJobs(1);
    $('server').textContent = `${ready.status}${api.key ? ', key accepted' : ', open (no key needed)'}`;
    $('server').className = 'ok';
  } catch (e) {
    if (e instanceof ApiError && e.status === 401) {
      $('server').textContent = api.key ? 'unknown API key' : 'this server needs an API key';
    } else {
      $('server').textContent = `unreachable: ${e.message || e}`;
    }
    $('server').className = 'error';
  }
}

// ------------------------------------------------------------------ inputs

async function loadLocalMesh(file) {
  const ext = file.name.split('.').pop().toLowerCase();
  const buf = await file.arrayBuffer();
  let object;
  if (ext === 'obj') {
    object = new OBJLoader().parse(new TextDecoder().decode(buf));
  } else if (ext === 'ply' || ext === 'stl') {
    const geom = (ext === 'ply' ? new PLYLoader() : new STLLoader()).parse(buf);
    geom.computeVertexNormals();
    object = new THREE.Mesh(geom);
  } else if (ext === 'glb' || ext === 'gltf') {
    object = await new Promise((res, rej) => gltfLoader().parse(buf, '', (g) => res(g.scene), rej));
  } else {
    throw new Error(`${file.name}: not OBJ, PLY, STL or GLB`);
  }
  object.traverse((o) => {
    if (o.isMesh) {
      o.material = new THREE.MeshStandardMaterial({ color: 0xd9b8a0, side: THREE.DoubleSide, flatShading: false });
      if (!o.geometry.attributes.normal) o.geometry.computeVertexNormals();
    }
  });
  return object;
}

function landmarkCounts() {
  return state.picks.map((p) => p.length);
}

function refreshPickInfo() {
  const counts = landmarkCounts();
  $('pick-info').textContent = state.meshFiles.length
    ? counts.map((c, i) => `mesh ${i + 1}: ${c}`).join(' · ')
    : 'choose meshes first';
  const sel = $('pick-mesh');
  sel.innerHTML = state.meshFiles.map((f, i) => `<option value="${i}">${i + 1}: ${f.name}</option>`).join('');
  sel.value = String(state.pickMesh);
}

function markerSprite(n, size, colour = '#d22') {
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const g = c.getContext('2d');
  g.fillStyle = colour;
  g.beginPath();
  g.arc(32, 32, 30, 0, Math.PI * 2);
  g.fill();
  g.fillStyle = '#fff';
  g.font = 'bold 34px sans-serif';
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.fillText(String(n), 32, 34);
  const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false }));
  s.scale.setScalar(size);
  return s;
}

function redrawMarkers() {
  markers.clear();
  if (!content) return;
  const picks = state.picks[state.pickMesh] || [];
  const diag = new THREE.Box3().setFromObject(content).getSize(new THREE.Vector3()).length();
  const size = diag / (picks.length > 20 ? 70 : 28);
  const conf = state.detected ? state.detected.confidence[state.pickMesh] || [] : [];
  picks.forEach((p, i) => {
    // detected points below 0.5 confidence in orange: the ones to check first
    const s = markerSprite(i + 1, size, conf[i] !== undefined && conf[i] < 0.5 ? '#e80' : '#d22');
    s.position.fromArray(p);
    markers.add(s);
  });
}

async function showPickMesh(i) {
  state.pickMesh = i;
  if (!state.meshFiles[i]) return;
  try {
    const object = await loadLocalMesh(state.meshFiles[i]);
    disposeResult();
    show(object);
    redrawMarkers();
    refreshPickInfo();
  } catch (e) {
    showError(e);
  }
}

const raycaster = new THREE.Raycaster();
let downAt = null;

// dragging a numbered marker moves that landmark over the surface (a detected one, mostly)
let dragging = -1;
function rayFrom(ev) {
  const r = canvas.getBoundingClientRect();
  raycaster.setFromCamera(new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1), camera);
}
canvas.addEventListener('pointerdown', (ev) => {
  if (!$('pick-on').checked || !content || state.loaded || !markers.children.length) return;
  rayFrom(ev);
  const hit = raycaster.intersectObjects(markers.children, false)[0];
  if (!hit) return;
  dragging = markers.children.indexOf(hit.object);
  controls.enabled = false; // the drag moves the marker, not the camera
  ev.stopImmediatePropagation();
}, { capture: true });
canvas.addEventListener('pointermove', (ev) => {
  if (dragging < 0) return;
  rayFrom(ev);
  const hit = raycaster.intersectObject(content, true)[0];
  if (!hit) return;
  state.picks[state.pickMesh][dragging] = hit.point.toArray();
  markers.children[dragging].position.copy(hit.point);
});
canvas.addEventListener('pointerup', (ev) => {
  if (dragging < 0) return;
  const conf = state.detected && state.detected.confidence[state.pickMesh];
  if (conf) conf[dragging] = 1; // checked by a person
  state.repicked += 1;
  dragging = -1;
  controls.enabled = true;
  downAt = null;
  ev.stopImmediatePropagation();
  redrawMarkers();
}, { capture: true });
canvas.addEventListener('pointerdown', (ev) => {
  downAt = [ev.clientX, ev.clientY];
});
canvas.addEventListener('pointerup', (ev) => {
  if (!$('pick-on').checked || !content || state.loaded) return;
  if (!downAt || Math.hypot(ev.clientX - downAt[0], ev.clientY - downAt[1]) > 4) return; // a drag
  const r = canvas.getBoundingClientRect();
  const ndc = new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1);
  raycaster.setFromCamera(ndc, camera);
  const hit = raycaster.intersectObject(content, true)[0];
  if (!hit || !hit.face) return;
  // the nearest corner of the hit triangle: a vertex of the file, in its coordinates
  const pos = hit.object.geometry.attributes.position;
  let best = null;
  for (const idx of [hit.face.a, hit.face.b, hit.face.c]) {
    const v = new THREE.Vector3().fromBufferAttribute(pos, idx).applyMatrix4(hit.object.matrixWorld);
    const d = v.distanceTo(hit.point);
    if (!best || d < best.d) best = { v, d };
  }
  const n = Number($('repick').value);
  const picks = state.picks[state.pickMesh];
  if (n >= 1 && n <= picks.length) {
    picks[n - 1] = best.v.toArray(); // re-pick landmark n where the person clicked
    state.repicked += 1;
    if (state.detected && state.detected.confidence[state.pickMesh]) {
      state.detected.confidence[state.pickMesh][n - 1] = 1; // checked by a person
    }
  } else {
    picks.push(best.v.toArray());
  }
  redrawMarkers();
  refreshPickInfo();
});

function meshesChosen() {
  state.meshFiles = Array.from($('meshes').files);
  state.picks = state.meshFiles.map(() => []);
  state.detected = null;
  state.pickMesh = 0;
  $('mesh-list').textContent = state.meshFiles.map((f, i) => `${i + 1}. ${f.name}`).join('  ');
  refreshPickInfo();
  if (state.meshFiles.length) showPickMesh(0);
  landmarksChosen();
}

async function landmarksChosen() {
  const f = $('landmarks').files[0];
  state.landmarkLists = null;
  if (!f) {
    $('landmark-info').textContent = 'none: pick them on the meshes';
    return;
  }
  try {
    const data = JSON.parse(await f.text());
    state.landmarkLists = parseLandmarks(data, Math.max(2, state.meshFiles.length));
    $('landmark-info').textContent = `${state.landmarkLists[0].length} per mesh from ${f.name}`;
  } catch (e) {
    $('landmark-info').textContent = e instanceof LandmarkError || e instanceof SyntaxError ? e.message : String(e);
  }
}

// ------------------------------------------------------------------ the job

// the repairs the server found the uploads need (report.repairs_needed), asked for in
// the morph: the CLI's --fill-holes / --remove-ears
function neededRepairs(meshes) {
  const repairs = {};
  for (const [i, m] of meshes.entries()) {
    for (const r of Object.keys((m.report && m.report.repairs_needed) || {})) {
      (repairs[r] = repairs[r] || []).push(i + 1);
    }
  }
  return repairs;
}

function morphBody(meshIds, repairs = {}) {
  const body = { meshes: meshIds, frames: Number($('frames').value), method: $('method').value };
  for (const r of Object.keys(repairs)) body[r] = true;
  const times = $('times').value.trim();
  if (times) body.times = times.split(',').map(Number);
  if (state.landmarkLists) body.landmarks = state.landmarkLists;
  else {
    const counts = landmarkCounts();
    if (new Set(counts).size !== 1 || counts[0] < 3) {
      throw new Error(`pick the same number (≥ 3) of landmarks on every mesh, in the same order (now ${counts.join(', ')})`);
    }
    body.landmarks = state.picks;
  }
  return body;
}

async function startJob() {
  state.error = null;
  try {
    if (state.meshFiles.length < 2) throw new Error('choose two or more meshes (in time order)');
    if (state.landmarkLists && state.landmarkLists.length !== state.meshFiles.length) {
      await landmarksChosen();
      if (!state.landmarkLists) throw new Error($('landmark-info').textContent);
    }
    $('start').disabled = true;
    const uploaded = await uploadAll();
    const repairs = neededRepairs(uploaded);
    state.repairs = repairs;
    const body = morphBody(uploaded.map((m) => m.id), repairs);
    const said = Object.entries(repairs).map(([r, which]) => `${r.replace('_', ' ')} (mesh ${which.join(', ')})`);
    setStatus(said.length ? `submitting, with repairs: ${said.join('; ')}` : 'submitting');
    state.seen = [];
    const job = await api.createMorph(body);
    state.jobId = job.id;
    setStatus(`job ${job.id} ${job.state}`);
    const done = await api.follow(job.id, updateJob);
    if (done.state !== 'succeeded') {
      showJobFailure(done);
      return;
    }
    setStatus('loading the animation');
    await loadResult(done);
    setStatus(`done: ${done.id}`, 'ok');
  } catch (e) {
    showError(e);
  } finally {
    $('start').disabled = false;
  }
}

// the detect action: a landmark-detection job on the uploaded meshes; its points become the
// picks (numbered, editable by re-picking), which the morph then sends
async function uploadAll() {
  const uploaded = [];
  for (const [i, f] of state.meshFiles.entries()) {
    setStatus(`uploading ${i + 1}/${state.meshFiles.length}: ${f.name}`);
    uploaded.push(await api.uploadMesh(f));
  }
  return uploaded;
}

async function detectLandmarks() {
  state.error = null;
  try {
    if (!state.meshFiles.length) throw new Error('choose the meshes first');
    $('detect').disabled = true;
    const uploaded = await uploadAll();
    setStatus('detecting landmarks');
    state.seen = [];
    const job = await api.detectLandmarks(uploaded.map((m) => m.id));
    state.jobId = job.id;
    const done = await api.follow(job.id, updateJob);
    if (done.state !== 'succeeded') {
      showJobFailure(done);
      return;
    }
    const doc = JSON.parse(new TextDecoder().decode(await api.artifact(done.id, 'landmarks.json')));
    state.picks = doc.landmarks.map((pts) => pts.map((p) => [...p]));
    state.detected = { landmarksId: doc.landmarks_id, confidence: doc.confidence, warnings: doc.warnings };
    state.repicked = 0;
    state.landmarkLists = null; // the detected points replace a chosen file
    $('landmarks').value = '';
    $('landmark-info').textContent = `${doc.landmarks[0].length} per mesh, detected (set ${doc.landmarks_id})`;
    const low = doc.confidence.map((c) => c.filter((x) => x < 0.5).length);
    const warned = doc.warnings.flat();
    $('detect-info').textContent =
      `low confidence (orange): ${low.map((k, i) => `mesh ${i + 1}: ${k}`).join(' · ')}` +
      (warned.length ? ` — ${warned.join(' | ')}` : '');
    await showPickMesh(state.pickMesh);
    setStatus('landmarks detected: check them, re-pick wrong ones, then start the job', 'ok');
  } catch (e) {
    showError(e);
  } finally {
    $('detect').disabled = false;
  }
}

function disposeResult() {
  if (mixer) mixer.stopAllAction();
  mixer = null;
  action = null;
  morphMesh = null;
  state.loaded = false;
  state.playing = false;
}

async function loadResult(job) {
  const bytes = await api.artifact(job.id, 'animation.glb');
  state.glbBytes = bytes.byteLength;
  const gltf = await new Promise((res, rej) => gltfLoader().parse(bytes, '', res, rej));
  disposeResult();
  show(gltf.scene);
  gltf.scene.traverse((o) => {
    if (o.isMesh && o.morphTargetInfluences && !morphMesh) morphMesh = o;
    if (o.isMesh) o.material.side = THREE.DoubleSide;
  });
  mixer = new THREE.AnimationMixer(gltf.scene);
  const clip = gltf.animations[0];
  if (clip) {
    action = mixer.clipAction(clip);
    action.play();
    state.duration = clip.duration;
    $('scrub').max = String(clip.duration);
    $('scrub').step = String(clip.duration / 1000 || 0.001);
    mixer.setTime(0);
    refPositions = morphMesh ? currentPositions() : null;
  }
  const url = URL.createObjectURL(new Blob([bytes], { type: 'model/gltf-binary' }));
  const a = $('download');
  a.href = url;
  a.download = `morph-${job.id}.glb`;
  a.hidden = false;
  $('glb-size').textContent = `${(bytes.byteLength / 1024).toFixed(0)} KB`;
  state.loaded = true;
  state.playing = true;
  $('play').textContent = 'Pause';
  $('player').hidden = false;
  lastHist = -1;
  maybeHistogram(true);
  loadMetrics(job);
}

function currentPositions() {
  const g = morphMesh.geometry;
  const base = g.attributes.position.array;
  const out = Float32Array.from(base);
  const targets = g.morphAttributes.position || [];
  const w = morphMesh.morphTargetInfluences;
  targets.forEach((t, k) => {
    const wk = w[k];
    if (!wk) return;
    const d = t.array;
    if (g.morphTargetsRelative) for (let i = 0; i < out.length; i++) out[i] += wk * d[i];
    else for (let i = 0; i < out.length; i++) out[i] += wk * (d[i] - base[i]);
  });
  return out;
}

let lastHist = -1;
function maybeHistogram(force = false) {
  if (!morphMesh || !refPositions || !morphMesh.geometry.index) return;
  const now = performance.now();
  if (!force && now - lastHist < 250) return;
  lastHist = now;
  const h = angleDistortionHistogram(refPositions, currentPositions(), morphMesh.geometry.index.array);
  drawHistogram($('hist'), h, `angle change vs. first frame at t=${state.time.toFixed(2)} s (°): mean ${h.mean.toFixed(2)}, max ${h.max.toFixed(1)}`);
}

function flatten(obj, prefix, out) {
  for (const [k, v] of Object.entries(obj)) {
    const key = prefix ? `${prefix}.${k}` : k;
    if (v && typeof v === 'object' && !Array.isArray(v)) {
      if (!(Array.isArray(v.edges) && Array.isArray(v.counts))) flatten(v, key, out);
    } else if (Array.isArray(v)) {
      if (v.length <= 6 && v.every((x) => typeof x !== 'object')) out.push([key, v.map(fmt).join(', ')]);
      else if (v.length && v.every((x) => x && typeof x === 'object' && !Array.isArray(x))) {
        v.forEach((x, i) => flatten(x, `${key}[${i}]`, out));
      }
    } else out.push([key, fmt(v)]);
  }
  return out;
}

function fmt(v) {
  if (typeof v === 'number') return Number.isInteger(v) ? String(v) : Math.abs(v) < 1e-3 || Math.abs(v) >= 1e5 ? v.toExponential(3) : v.toFixed(4);
  return String(v);
}

async function loadMetrics(job) {
  try {
    const bytes = await api.artifact(job.id, 'metrics.json');
    const metrics = JSON.parse(new TextDecoder().decode(bytes));
    state.metrics = metrics;
    const rows = flatten(metrics, '', []);
    $('metrics').innerHTML =
      '<tr><th>metric</th><th>value</th></tr>' +
      rows.map(([k, v]) => `<tr><td>${escapeHtml(k)}</td><td>${escapeHtml(v)}</td></tr>`).join('');
    const server = findHistograms(metrics)[0];
    if (server) drawHistogram($('hist-server'), server.hist, server.path);
    $('hist-server').hidden = !server;
  } catch (e) {
    $('metrics').innerHTML = `<tr><td>metrics unavailable: ${escapeHtml(e.message || String(e))}</td></tr>`;
  }
}

function escapeHtml(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' })[c]);
}

// ------------------------------------------------------------------ player

function togglePlay() {
  if (!action) return;
  state.playing = !state.playing;
  $('play').textContent = state.playing ? 'Pause' : 'Play';
  delta();
}

function scrub() {
  if (!mixer) return;
  state.playing = false;
  $('play').textContent = 'Play';
  // the clip loops: its very end would wrap to 0, so stop just short of it
  const t = Math.min(Number($('scrub').value), state.duration * (1 - 1e-6));
  mixer.setTime(t);
  state.time = t;
  $('time').textContent = `${t.toFixed(2)} / ${state.duration.toFixed(2)} s`;
  maybeHistogram(true);
}

// ------------------------------------------------------------------ wiring

$('api-key').addEventListener('change', keyChanged);
$('meshes').addEventListener('change', meshesChosen);
$('landmarks').addEventListener('change', landmarksChosen);
$('pick-mesh').addEventListener('change', () => showPickMesh(Number($('pick-mesh').value)));
$('undo').addEventListener('click', () => {
  (state.picks[state.pickMesh] || []).pop();
  redrawMarkers();
  refreshPickInfo();
});
$('clear-picks').addEventListener('click', () => {
  state.picks[state.pickMesh] = [];
  redrawMarkers();
  refreshPickInfo();
});
$('start').addEventListener('click', startJob);
$('detect').addEventListener('click', detectLandmarks);
$('play').addEventListener('click', togglePlay);
$('scrub').addEventListener('input', scrub);

try {
  $('api-key').value = localStorage.getItem('conformorph-api-key') || '';
} catch {
  /* storage may be off */
}
api.key = $('api-key').value.trim();
resize();
refreshPickInfo();
checkServer();
requestAnimationFrame(frame);

// the 2D tab (shapes2d.js) and the tabs
const state2d = initShapes2d({ api, $, updateJob });
function showTab(name) {
  const is2d = name === '2d';
  $('panel3d').hidden = is2d;
  $('stage-area').hidden = is2d;
  $('panel2d').hidden = !is2d;
  $('stage2d').hidden = !is2d;
  $('tab-3d').classList.toggle('active', !is2d);
  $('tab-2d').classList.toggle('active', is2d);
  if (!is2d) resize();
}
$('tab-3d').addEventListener('click', () => showTab('3d'));
$('tab-2d').addEventListener('click', () => showTab('2d'));

// for tests and scripting: a read-only view of the viewer's state
window.conformorphViewer = {
  state: () => ({
    jobId: state.jobId,
    jobState: state.jobState,
    stage: state.stage,
    progress: state.progress,
    error: state.error,
    loaded: state.loaded,
    playing: state.playing,
    time: state.time,
    duration: state.duration,
    glbBytes: state.glbBytes,
    weights: morphMesh ? Array.from(morphMesh.morphTargetInfluences) : [],
    picks: state.picks.map((p) => p.length),
    landmarks: state.landmarkLists ? state.landmarkLists[0].length : 0,
    metricsRows: document.querySelectorAll('#metrics tr').length - 1,
    seen: [...state.seen],
    repairs: { ...state.repairs },
    detected: state.detected ? state.detected.landmarksId : null,
    repicked: state.repicked,
  }),
  /** landmark i of mesh k as picked, detected or re-picked ([x, y, z]) */
  pick: (k, i) => (state.picks[k] && state.picks[k][i] ? [...state.picks[k][i]] : null),
  /** where landmark i of the mesh shown is drawn, in page pixels */
  screenOf: (i) => {
    const v = new THREE.Vector3().fromArray(state.picks[state.pickMesh][i]).project(camera);
    const r = canvas.getBoundingClientRect();
    return [r.left + ((v.x + 1) / 2) * r.width, r.top + ((1 - v.y) / 2) * r.height];
  },
  state2d,
};
