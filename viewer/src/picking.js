// Landmarks on the mesh being picked: numbered markers sized to the face and the screen,
// a label for the point under the pointer and for the selected one (the "re-pick no."),
// click to add a point, drag a marker to move it, or type a number and click where it
// belongs (the number clears after that click). Numbers are 1-based, as in warnings;
// each point remembers where it came from (detected, moved, picked) for the job.

import * as THREE from 'three';
import { $, state } from './state.js';
import { camera, canvas, controls, markers, syncMatrices, view } from './scene.js';

const raycaster = new THREE.Raycaster();
let downAt = null;
let dragging = -1;
let hover = -1;

function markerSprite(n, px, colour, numbered) {
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const g = c.getContext('2d');
  g.fillStyle = colour;
  g.strokeStyle = '#fff';
  g.lineWidth = 5;
  g.beginPath();
  g.arc(32, 32, 28, 0, Math.PI * 2);
  g.fill();
  g.stroke();
  if (numbered) {
    g.fillStyle = '#fff';
    g.font = `bold ${n >= 10 ? 30 : 36}px sans-serif`;
    g.textAlign = 'center';
    g.textBaseline = 'middle';
    g.fillText(String(n), 32, 34);
  }
  const material = new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false, sizeAttenuation: false });
  const s = new THREE.Sprite(material);
  // without size attenuation a sprite's scale is in clip units: px pixels on screen
  s.scale.setScalar((px * 2 * Math.tan(THREE.MathUtils.degToRad(camera.fov / 2))) / canvas.clientHeight);
  s.renderOrder = 2;
  return s;
}

/** On-screen marker diameter: half the median gap between neighbouring points, 10-30 px. */
function markerPixels(picks) {
  if (picks.length < 2) return 24;
  syncMatrices();
  const h = canvas.clientHeight;
  const w = canvas.clientWidth;
  const scr = picks.map((p) => {
    const v = new THREE.Vector3().fromArray(p).project(camera);
    return [((v.x + 1) / 2) * w, ((1 - v.y) / 2) * h];
  });
  const gaps = scr.map((a, i) => Math.min(...scr.filter((_, j) => j !== i).map((b) => Math.hypot(a[0] - b[0], a[1] - b[1]))));
  gaps.sort((a, b) => a - b);
  return Math.max(10, Math.min(30, 0.6 * gaps[Math.floor(gaps.length / 2)]));
}

export function selectedIndex() {
  const n = Number($('repick').value);
  const picks = state.picks[state.pickMesh] || [];
  return n >= 1 && n <= picks.length ? n - 1 : -1;
}

export function redrawMarkers() {
  markers.clear();
  if (!view.content) return;
  const picks = state.picks[state.pickMesh] || [];
  const px = markerPixels(picks);
  const conf = state.detected ? state.detected.confidence[state.pickMesh] || [] : [];
  const sel = selectedIndex();
  picks.forEach((p, i) => {
    // selected in blue; detected points below 0.5 confidence in orange: the ones to check first
    const colour = i === sel ? '#1f63d6' : conf[i] !== undefined && conf[i] < 0.5 ? '#e80' : '#d22';
    const s = markerSprite(i + 1, i === sel ? Math.max(px, 22) : px, colour, px >= 16 || i === sel);
    s.position.fromArray(p);
    markers.add(s);
  });
  updateLabel();
}

function screenOf(p) {
  syncMatrices();
  const v = new THREE.Vector3().fromArray(p).project(camera);
  return [((v.x + 1) / 2) * canvas.clientWidth, ((1 - v.y) / 2) * canvas.clientHeight];
}

/** The label of the hovered marker, else of the selected one. */
export function updateLabel() {
  const label = $('marker-label');
  const picks = state.picks[state.pickMesh] || [];
  const i = hover >= 0 && hover < picks.length ? hover : selectedIndex();
  if (i < 0 || !view.content || state.loaded) {
    label.hidden = true;
    return;
  }
  const conf = state.detected ? (state.detected.confidence[state.pickMesh] || [])[i] : undefined;
  const prov = (state.provenance[state.pickMesh] || [])[i] || 'picked';
  const [x, y] = screenOf(picks[i]);
  label.textContent = `landmark ${i + 1} · ${prov}${conf !== undefined ? ` · confidence ${conf.toFixed(2)}` : ''}`;
  label.style.left = `${Math.round(x + 14)}px`;
  label.style.top = `${Math.round(y - 28)}px`;
  label.hidden = false;
}

function rayFrom(ev) {
  syncMatrices(); // the view as it is now, not as last drawn
  const r = canvas.getBoundingClientRect();
  raycaster.setFromCamera(new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1), camera);
}

function markerAt(ev) {
  rayFrom(ev);
  const hit = raycaster.intersectObjects(markers.children, false)[0];
  return hit ? markers.children.indexOf(hit.object) : -1;
}

/** A person placed landmark i of the mesh shown: detected ones become 'moved'. */
function touched(i) {
  const prov = state.provenance[state.pickMesh];
  prov[i] = prov[i] === 'detected' || prov[i] === 'moved' ? 'moved' : 'picked';
  const conf = state.detected && state.detected.confidence[state.pickMesh];
  if (conf && i < conf.length) conf[i] = 1; // checked by a person
  state.repicked += 1;
}

const picking = () => $('pick-on').checked && view.content && !state.loaded && state.shownMesh === state.pickMesh;

export function installPicking(onChange) {
  canvas.addEventListener('pointerdown', (ev) => {
    if (!picking() || !markers.children.length) return;
    const i = markerAt(ev);
    if (i < 0) return;
    dragging = i;
    controls.enabled = false; // the drag moves the marker, not the camera
    ev.stopImmediatePropagation();
  }, { capture: true });
  canvas.addEventListener('pointermove', (ev) => {
    if (dragging < 0) {
      const h = picking() ? markerAt(ev) : -1;
      if (h !== hover) {
        hover = h;
        updateLabel();
      }
      return;
    }
    rayFrom(ev);
    const hit = raycaster.intersectObject(view.content, true)[0];
    if (!hit) return;
    state.picks[state.pickMesh][dragging] = hit.point.toArray();
    markers.children[dragging].position.copy(hit.point);
    updateLabel();
  });
  canvas.addEventListener('pointerup', (ev) => {
    if (dragging < 0) return;
    touched(dragging);
    dragging = -1;
    controls.enabled = true;
    downAt = null;
    ev.stopImmediatePropagation();
    redrawMarkers();
    onChange();
  }, { capture: true });
  canvas.addEventListener('pointerdown', (ev) => {
    downAt = [ev.clientX, ev.clientY];
  });
  canvas.addEventListener('pointerup', (ev) => {
    if (!picking()) return;
    if (!downAt || Math.hypot(ev.clientX - downAt[0], ev.clientY - downAt[1]) > 4) return; // a drag
    rayFrom(ev);
    const hit = raycaster.intersectObject(view.content, true)[0];
    if (!hit || !hit.face) return;
    // the nearest corner of the hit triangle: a vertex of the file, in its coordinates
    const pos = hit.object.geometry.attributes.position;
    let best = null;
    for (const idx of [hit.face.a, hit.face.b, hit.face.c]) {
      const v = new THREE.Vector3().fromBufferAttribute(pos, idx).applyMatrix4(hit.object.matrixWorld);
      const d = v.distanceTo(hit.point);
      if (!best || d < best.d) best = { v, d };
    }
    const picks = state.picks[state.pickMesh];
    const sel = selectedIndex();
    if (sel >= 0) {
      picks[sel] = best.v.toArray(); // re-pick landmark n where the person clicked
      touched(sel);
      $('repick').value = ''; // used: the next click adds a point, it does not move this one again
    } else {
      picks.push(best.v.toArray());
      state.provenance[state.pickMesh].push('picked');
    }
    redrawMarkers();
    onChange();
  });
  $('repick').addEventListener('input', redrawMarkers);
  controls.addEventListener('change', () => {
    if (markers.children.length) updateLabel();
  });
}

/** Where landmark i of the mesh shown is drawn, in page pixels (for tests and scripts). */
export function pageOf(i) {
  const [x, y] = screenOf(state.picks[state.pickMesh][i]);
  const r = canvas.getBoundingClientRect();
  return [r.left + x, r.top + y];
}
