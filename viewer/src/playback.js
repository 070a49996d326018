// The result: the GLB morph animation played, scrubbed and downloaded, the camera
// following it (scene.js), the angle-distortion histogram against the first frame.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
// large GLBs come EXT_meshopt_compression-compressed (the output's --compress)
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { angleDistortionHistogram, drawHistogram } from './histogram.js';
import { loadMetrics, showUnits } from './metrics.js';
import { frameBox, show, view } from './scene.js';
import { floatValues } from './attributes.js';
import { $, fmtBytes, state } from './state.js';

export const result = { mixer: null, action: null, morphMesh: null, refPositions: null, boxes: [], base: null, union: null };
let lastHist = -1;

export function disposeResult() {
  if (result.mixer) result.mixer.stopAllAction();
  Object.assign(result, { mixer: null, action: null, morphMesh: null, refPositions: null, boxes: [], base: null, union: null });
  state.loaded = false;
  state.playing = false;
}

/** Every current vertex of the morph mesh, world coordinates, flat xyz. */
export function currentPositions(world = false) {
  const m = result.morphMesh;
  const g = m.geometry;
  const base = floatValues(g.attributes.position);
  const out = Float32Array.from(base);
  const w = m.morphTargetInfluences;
  (g.morphAttributes.position || []).forEach((t, k) => {
    const wk = w[k];
    if (!wk) return;
    const d = floatValues(t);
    if (g.morphTargetsRelative) for (let i = 0; i < out.length; i++) out[i] += wk * d[i];
    else for (let i = 0; i < out.length; i++) out[i] += wk * (d[i] - base[i]);
  });
  if (world) {
    const v = new THREE.Vector3();
    for (let i = 0; i < out.length; i += 3) {
      v.set(out[i], out[i + 1], out[i + 2]).applyMatrix4(m.matrixWorld);
      out[i] = v.x;
      out[i + 1] = v.y;
      out[i + 2] = v.z;
    }
  }
  return out;
}

/** Boxes of the base shape and of every morph target (each a frame of the morph), in
 * the mesh's own coordinates: its node may be animated too (scale, translation). */
function frameBoxes(mesh) {
  const g = mesh.geometry;
  const base = g.attributes.position;
  const baseBox = new THREE.Box3().setFromBufferAttribute(base);
  const b = floatValues(base);
  const boxes = (g.morphAttributes.position || []).map((t) => {
    if (!g.morphTargetsRelative) return new THREE.Box3().setFromBufferAttribute(t);
    const box = new THREE.Box3();
    const v = new THREE.Vector3();
    const d = floatValues(t);
    for (let i = 0; i < b.length; i += 3) box.expandByPoint(v.set(b[i] + d[i], b[i + 1] + d[i + 1], b[i + 2] + d[i + 2]));
    return box;
  });
  return { baseBox, boxes };
}

/** The current frame's world box: the targets' boxes blended by the weights (a morph's
 * frame k is the base plus target k at weight 1; between frames two weights share 1),
 * then placed by the mesh's current (possibly animated) world matrix. */
function currentBox() {
  const m = result.morphMesh;
  const w = m.morphTargetInfluences;
  const total = w.reduce((a, b) => a + b, 0);
  const rest = Math.max(0, 1 - total);
  const min = result.base.min.clone().multiplyScalar(rest);
  const max = result.base.max.clone().multiplyScalar(rest);
  result.boxes.forEach((b, k) => {
    if (!w[k]) return;
    min.addScaledVector(b.min, w[k]);
    max.addScaledVector(b.max, w[k]);
  });
  m.updateWorldMatrix(true, false);
  return new THREE.Box3(min, max).applyMatrix4(m.matrixWorld);
}

/** The union of the current boxes at `samples` times across the clip (then back to 0). */
function unionOverTime(duration, samples) {
  const union = new THREE.Box3();
  for (let k = 0; k <= samples; k++) {
    result.mixer.setTime(Math.min(duration * (k / samples), duration * (1 - 1e-6)));
    union.union(currentBox());
  }
  result.mixer.setTime(0);
  return union;
}

export function maybeHistogram(force = false) {
  const m = result.morphMesh;
  if (!m || !result.refPositions || !m.geometry.index) return;
  const now = performance.now();
  if (!force && now - lastHist < 250) return;
  lastHist = now;
  const h = angleDistortionHistogram(result.refPositions, currentPositions(), m.geometry.index.array);
  drawHistogram($('hist'), h, `angle change vs. first frame at t=${state.time.toFixed(2)} s (°): mean ${h.mean.toFixed(2)}, max ${h.max.toFixed(1)}`);
  showUnits(currentBox().getSize(new THREE.Vector3()).toArray());
}

export async function loadResult(api, job) {
  const bytes = await api.artifact(job.id, 'animation.glb');
  state.glbBytes = bytes.byteLength;
  const gltf = await new Promise((res, rej) => new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parse(bytes, '', res, rej));
  disposeResult();
  gltf.scene.traverse((o) => {
    if (o.isMesh && o.morphTargetInfluences && !result.morphMesh) result.morphMesh = o;
    if (o.isMesh) o.material.side = THREE.DoubleSide;
  });
  if (result.morphMesh) Object.assign(result, (({ baseBox, boxes }) => ({ base: baseBox, boxes }))(frameBoxes(result.morphMesh)));
  show(gltf.scene);
  result.mixer = new THREE.AnimationMixer(gltf.scene);
  const clip = gltf.animations[0];
  if (clip) {
    result.action = result.mixer.clipAction(clip);
    result.action.play();
    state.duration = clip.duration;
    $('scrub').max = String(clip.duration);
    $('scrub').step = String(clip.duration / 1000 || 0.001);
    result.mixer.setTime(0);
  }
  if (result.morphMesh) {
    // framed on every frame's bounds (what "follow" off keeps); then it follows the frame
    if (clip) result.union = unionOverTime(clip.duration, 4 * result.boxes.length + 4);
    if (result.union) frameBox(result.union, false);
    result.refPositions = currentPositions();
    view.follow = currentBox;
  }
  const a = $('download');
  a.href = URL.createObjectURL(new Blob([bytes], { type: 'model/gltf-binary' }));
  a.download = `morph-${job.id}.glb`;
  a.hidden = false;
  $('glb-size').textContent = fmtBytes(bytes.byteLength);
  state.loaded = true;
  state.playing = true;
  $('play').textContent = 'Pause';
  $('player').hidden = false;
  lastHist = -1;
  await loadMetrics(api, job);
  maybeHistogram(true);
}

/** One animation step of `dt` seconds (when playing). */
export function advance(dt) {
  if (!result.mixer || !state.playing) return;
  result.mixer.update(dt);
  state.time = result.action.time;
  $('scrub').value = String(state.time);
  $('time').textContent = `${state.time.toFixed(2)} / ${state.duration.toFixed(2)} s`;
  maybeHistogram();
}

/** "camera follows the morph" turned off: frame the union of every frame's bounds. */
export function followChanged() {
  if (!$('follow').checked && result.union) frameBox(result.union);
}

export function togglePlay() {
  if (!result.action) return;
  state.playing = !state.playing;
  $('play').textContent = state.playing ? 'Pause' : 'Play';
}

export function scrub() {
  if (!result.mixer) return;
  state.playing = false;
  $('play').textContent = 'Play';
  // the clip loops: its very end would wrap to 0, so stop just short of it
  const t = Math.min(Number($('scrub').value), state.duration * (1 - 1e-6));
  result.mixer.setTime(t);
  state.time = t;
  $('time').textContent = `${t.toFixed(2)} / ${state.duration.toFixed(2)} s`;
  maybeHistogram(true);
}
