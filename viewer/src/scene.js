// The three.js scene: renderer, camera, orbit controls, what is shown and how the camera
// frames it. A morph's camera follows the animation: each frame it frames the current
// shape's bounds (blended from every morph target's box by the weights), so a morph
// between faces of very different sizes stays in view at every time; "follow" off
// frames the union of every frame's bounds once.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { $ } from './state.js';

export const canvas = $('view');
export const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
export const scene = new THREE.Scene();
scene.background = new THREE.Color(0xeef1f5);
export const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
camera.position.set(0, 0, 5);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
sun.position.set(1, 2, 3);
scene.add(sun);
export const controls = new OrbitControls(camera, canvas);
export const markers = new THREE.Group();
scene.add(markers);

export const view = { content: null, follow: null }; // follow: () => Box3 of the current frame

export function resize() {
  const r = canvas.parentElement.getBoundingClientRect();
  const w = Math.max(200, Math.floor(r.width));
  const h = Math.max(200, Math.floor(r.height));
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);

/** Points the camera at `box` (keeping its direction) so that it fills most of the view. */
export function frameBox(box, keepDirection = true) {
  const size = box.getSize(new THREE.Vector3()).length() || 1;
  const center = box.getCenter(new THREE.Vector3());
  const dir = keepDirection
    ? camera.position.clone().sub(controls.target).normalize()
    : new THREE.Vector3(0, 0, 1);
  if (!Number.isFinite(dir.x) || dir.lengthSq() < 0.5) dir.set(0, 0, 1);
  // the bounding sphere (radius size/2) fits the smaller of the two fields of view
  const half = THREE.MathUtils.degToRad(camera.fov / 2);
  const fit = Math.min(Math.tan(half), Math.tan(half) * camera.aspect);
  const dist = (0.5 * size) / fit / 0.9;
  controls.target.copy(center);
  camera.position.copy(center).addScaledVector(dir, dist);
  camera.near = dist / 100;
  camera.far = dist * 100;
  camera.updateProjectionMatrix();
}

/** Brings the camera's and the scene's world matrices up to date. three.js does so only
 * when it renders (once a frame), so a click, or a projection, between a change of the
 * view (a mesh shown and framed, markers added, an orbit) and the next frame would
 * otherwise use the previous camera and put new markers at the origin. */
export function syncMatrices() {
  scene.updateMatrixWorld();
  camera.updateMatrixWorld();
}

export function show(object, box = null) {
  if (view.content) scene.remove(view.content);
  view.content = object;
  view.follow = null;
  scene.add(object);
  frameBox(box || new THREE.Box3().setFromObject(object), false);
  controls.update();
  markers.clear();
}

/** The larger of the width and height of `points` (world, flat xyz) on screen, as a
 * fraction of the view, and whether the box is inside the view. */
export function projectedSpan(points) {
  const v = new THREE.Vector3();
  let x0 = Infinity;
  let x1 = -Infinity;
  let y0 = Infinity;
  let y1 = -Infinity;
  for (let i = 0; i < points.length; i += 3) {
    v.set(points[i], points[i + 1], points[i + 2]).project(camera);
    x0 = Math.min(x0, v.x);
    x1 = Math.max(x1, v.x);
    y0 = Math.min(y0, v.y);
    y1 = Math.max(y1, v.y);
  }
  const width = (Math.min(x1, 1) - Math.max(x0, -1)) / 2;
  const height = (Math.min(y1, 1) - Math.max(y0, -1)) / 2;
  const inside = x0 >= -1.001 && x1 <= 1.001 && y0 >= -1.001 && y1 <= 1.001;
  return { width, height, span: Math.max(width, height), inside };
}

/** One render; the camera follows the animation when asked. */
export function render() {
  if (view.follow && $('follow').checked) frameBox(view.follow());
  controls.update();
  renderer.render(scene, camera);
}
