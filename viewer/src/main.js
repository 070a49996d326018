// The conformorph viewer: choose meshes (checked at once) and landmarks (from a file,
// picked, or detected and corrected), see what the job will do, run it, follow it
// live, then play the GLB morph animation, read its metrics and download it. The 2D tab
// is shapes2d.js. This module wires the others together.

import { Api } from './api.js';
import {
  blockingProblem, detectionSummary, morphBody, neededRepairs, showError, showJobFailure,
  showPlan, updateJob, uploadAll,
} from './job3d.js';
import { LandmarkError, parseLandmarks } from './landmarks.js';
import { checkMeshFile, loadLocalMesh } from './meshfiles.js';
import { showUnits, unitsText } from './metrics.js';
import { installPicking, pageOf, redrawMarkers } from './picking.js';
import { advance, currentPositions, disposeResult, followChanged, loadResult, result, scrub, togglePlay } from './playback.js';
import { camera, markers, projectedSpan, render, resize, show, view } from './scene.js';
import { checkServer, keyChanged, loadConfig } from './server.js';
import { initShapes2d } from './shapes2d.js';
import { $, fmtBytes, setStatus, state } from './state.js';

const api = new Api('');

let lastFrame = performance.now();
function frame() {
  const now = performance.now();
  advance((now - lastFrame) / 1000);
  lastFrame = now;
  render();
  requestAnimationFrame(frame);
}

// ------------------------------------------------------------------ meshes and landmarks

function refreshPickInfo() {
  $('pick-info').textContent = state.meshFiles.length
    ? state.picks.map((p, i) => `mesh ${i + 1}: ${p.length}`).join(' · ')
    : 'choose meshes first';
  const sel = $('pick-mesh');
  sel.innerHTML = state.meshFiles.map((f, i) => `<option value="${i}">${i + 1}: ${f.name}</option>`).join('');
  sel.value = String(state.pickMesh);
}

async function showPickMesh(i) {
  state.pickMesh = i;
  state.shownMesh = -1; // no picking on the previous mesh's markers while this one loads
  markers.clear();
  const f = state.meshFiles[i];
  if (!f || (state.checks[i] && state.checks[i].problem)) return;
  try {
    const object = await loadLocalMesh(f);
    if (state.pickMesh !== i) return; // another mesh was chosen meanwhile
    disposeResult();
    show(object);
    redrawMarkers();
    refreshPickInfo();
    showUnits(null);
    state.shownMesh = i;
  } catch (e) {
    showError(e);
  }
}

function listMeshes() {
  $('mesh-list').innerHTML = '';
  state.meshFiles.forEach((f, i) => {
    const c = state.checks[i];
    const row = document.createElement('div');
    const counts = c && c.vertices ? `, ${c.vertices.toLocaleString('en')} vertices` : '';
    row.textContent = c && c.problem ? c.problem : `${i + 1}. ${f.name} (${fmtBytes(f.size)}${counts})`;
    row.className = c && c.problem ? 'error' : '';
    $('mesh-list').appendChild(row);
  });
}

async function meshesChosen() {
  state.meshFiles = Array.from($('meshes').files);
  state.picks = state.meshFiles.map(() => []);
  state.provenance = state.meshFiles.map(() => []);
  state.checks = state.meshFiles.map(() => null);
  state.detected = null;
  state.pickMesh = 0;
  state.error = null;
  listMeshes();
  refreshPickInfo();
  landmarksChosen();
  const limit = state.config.max_upload_bytes;
  state.checks = await Promise.all(state.meshFiles.map((f) => checkMeshFile(f, limit)));
  listMeshes();
  showPlan();
  const problem = blockingProblem();
  if (problem) {
    state.error = { message: problem };
    setStatus(problem, 'error');
  } else setStatus('');
  const first = state.checks.findIndex((c) => !c.problem);
  if (first >= 0) await showPickMesh(first);
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
    $('landmark-info').textContent = `${f.name}: ${e instanceof LandmarkError || e instanceof SyntaxError ? e.message : String(e)}`;
  }
}

// ------------------------------------------------------------------ jobs

async function startJob() {
  state.error = null;
  try {
    if (state.meshFiles.length < 2) throw new Error('choose two or more meshes (in time order)');
    if (state.landmarkLists && state.landmarkLists.length !== state.meshFiles.length) {
      await landmarksChosen();
      if (!state.landmarkLists) throw new Error($('landmark-info').textContent);
    }
    if (!state.landmarkLists) morphBody([]); // the picks' check, before anything uploads
    $('start').disabled = true;
    const uploaded = await uploadAll(api);
    const repairs = neededRepairs(uploaded);
    state.repairs = repairs;
    const body = morphBody(uploaded.map((m) => m.id), repairs);
    const said = Object.entries(repairs).map(([r, which]) => `${r.replace('_', ' ')} (mesh ${which.join(', ')})`);
    setStatus(said.length ? `submitting, with repairs: ${said.join('; ')}` : 'submitting');
    state.seen = [];
    const job = await api.createMorph(body);
    state.jobId = job.id;
    setStatus(`job ${job.id} ${job.state}: ${$('plan').textContent}`);
    const done = await api.follow(job.id, updateJob);
    if (done.state !== 'succeeded') return showJobFailure(done);
    setStatus('loading the animation');
    await loadResult(api, done);
    setStatus(`done: ${done.id}`, 'ok');
  } catch (e) {
    showError(e);
  } finally {
    $('start').disabled = false;
  }
}

// the detect action: a landmark-detection job on the uploaded meshes; its points become the
// picks (numbered, editable), which the morph then sends
async function detectLandmarks() {
  state.error = null;
  try {
    if (!state.meshFiles.length) throw new Error('choose the meshes first');
    $('detect').disabled = true;
    const uploaded = await uploadAll(api);
    setStatus('detecting landmarks');
    state.seen = [];
    const job = await api.detectLandmarks(uploaded.map((m) => m.id));
    state.jobId = job.id;
    const done = await api.follow(job.id, updateJob);
    if (done.state !== 'succeeded') return showJobFailure(done);
    const doc = JSON.parse(new TextDecoder().decode(await api.artifact(done.id, 'landmarks.json')));
    state.picks = doc.landmarks.map((pts) => pts.map((p) => [...p]));
    state.provenance = doc.landmarks.map((pts) => pts.map(() => 'detected'));
    state.detected = { landmarksId: doc.landmarks_id, confidence: doc.confidence, warnings: doc.warnings };
    state.repicked = 0;
    state.landmarkLists = null; // the detected points replace a chosen file
    $('landmarks').value = '';
    $('landmark-info').textContent = `${doc.landmarks[0].length} per mesh, detected (set ${doc.landmarks_id})`;
    $('detect-info').innerHTML = detectionSummary(doc);
    await showPickMesh(state.pickMesh);
    setStatus('landmarks detected: check them, re-pick wrong ones, then start the job', 'ok');
  } catch (e) {
    showError(e);
  } finally {
    $('detect').disabled = false;
  }
}

// ------------------------------------------------------------------ wiring

$('api-key').addEventListener('change', () => keyChanged(api));
$('meshes').addEventListener('change', meshesChosen);
$('landmarks').addEventListener('change', landmarksChosen);
$('pick-mesh').addEventListener('change', () => showPickMesh(Number($('pick-mesh').value)));
$('frames').addEventListener('input', showPlan);
$('undo').addEventListener('click', () => {
  (state.picks[state.pickMesh] || []).pop();
  (state.provenance[state.pickMesh] || []).pop();
  redrawMarkers();
  refreshPickInfo();
});
$('clear-picks').addEventListener('click', () => {
  state.picks[state.pickMesh] = [];
  state.provenance[state.pickMesh] = [];
  redrawMarkers();
  refreshPickInfo();
});
$('start').addEventListener('click', startJob);
$('detect').addEventListener('click', detectLandmarks);
$('play').addEventListener('click', togglePlay);
$('scrub').addEventListener('input', scrub);
$('follow').addEventListener('change', followChanged);
installPicking(refreshPickInfo);

try {
  $('api-key').value = localStorage.getItem('conformorph-api-key') || '';
} catch {
  /* storage may be off */
}
api.key = $('api-key').value.trim();
resize();
refreshPickInfo();
loadConfig();
checkServer(api);
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
    weights: result.morphMesh ? Array.from(result.morphMesh.morphTargetInfluences) : [],
    picks: state.picks.map((p) => p.length),
    shownMesh: state.shownMesh,
    provenance: state.provenance.map((p) => [...p]),
    checks: state.checks.map((c) => (c ? { ...c } : null)),
    landmarks: state.landmarkLists ? state.landmarkLists[0].length : 0,
    metricsRows: document.querySelectorAll('#metrics tr').length - 1,
    seen: [...state.seen],
    repairs: { ...state.repairs },
    detected: state.detected ? state.detected.landmarksId : null,
    repicked: state.repicked,
    config: state.config,
  }),
  /** landmark i of mesh k as picked, detected or re-picked ([x, y, z]) */
  pick: (k, i) => (state.picks[k] && state.picks[k][i] ? [...state.picks[k][i]] : null),
  /** where landmark i of the mesh shown is drawn, in page pixels */
  screenOf: pageOf,
  /** the morph's current shape on screen: {span, width, height, inside} (fractions of the view) */
  projected: () => (result.morphMesh ? projectedSpan(currentPositions(true)) : null),
  /** the camera's world position, and the box it frames when following the morph */
  cameraAt: () => camera.position.toArray(),
  followed: () => (view.follow ? [view.follow().min.toArray(), view.follow().max.toArray()] : null),
  /** the units line's text for a metrics.json (its per-key `units` entry) */
  unitsText,
  state2d,
};
