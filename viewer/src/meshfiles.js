// Mesh files in the browser: each file is checked when chosen (its format sniffed before
// any loader sees it, its size against the server's upload limit, its vertices counted),
// so a non-mesh file gets a message naming it instead of a blank view, and nothing
// uploads while a chosen file is known to be refused.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
// large GLBs come EXT_meshopt_compression-compressed (the output's --compress)
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { OBJLoader } from 'three/addons/loaders/OBJLoader.js';
import { PLYLoader } from 'three/addons/loaders/PLYLoader.js';
import { STLLoader } from 'three/addons/loaders/STLLoader.js';
import { floatValues } from './attributes.js';
import { fmtBytes } from './state.js';

export const MESH_EXTENSIONS = ['obj', 'ply', 'off', 'stl', 'glb', 'gltf'];

export class MeshFileError extends Error {}

const extOf = (file) => file.name.split('.').pop().toLowerCase();

/** Why `bytes` (the start of a file) is not the format its extension says, or null. */
export function formatProblem(name, ext, head) {
  const text = new TextDecoder('utf-8', { fatal: false }).decode(head);
  if (!MESH_EXTENSIONS.includes(ext)) return `${name}: not a mesh file (OBJ, PLY, OFF, STL or GLB)`;
  if (ext === 'glb' && text.slice(0, 4) !== 'glTF') return `${name}: not a binary glTF (GLB) file`;
  if (ext === 'ply' && !text.startsWith('ply')) return `${name}: not a PLY file (no "ply" header)`;
  if (ext === 'off' && !/^\s*[ONC]*OFF/.test(text)) return `${name}: not an OFF file (no "OFF" header)`;
  if (ext === 'obj' && !/^v\s+[-+.\deE]+\s+[-+.\deE]+\s+[-+.\deE]+/m.test(text)) {
    return `${name}: not an OBJ mesh (no "v x y z" vertex lines)`;
  }
  return null;
}

function parseOff(text) {
  const tokens = text.replace(/#[^\n]*/g, ' ').trim().split(/\s+/);
  let k = 0;
  if (/OFF$/.test(tokens[0])) k = 1;
  const [nv, nf] = [Number(tokens[k]), Number(tokens[k + 1])];
  k += 3;
  const pos = new Float32Array(nv * 3);
  for (let i = 0; i < nv * 3; i++) pos[i] = Number(tokens[k++]);
  const index = [];
  for (let f = 0; f < nf; f++) {
    const n = Number(tokens[k++]);
    const poly = tokens.slice(k, k + n).map(Number);
    k += n;
    for (let j = 1; j + 1 < n; j++) index.push(poly[0], poly[j], poly[j + 1]);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  g.setIndex(index);
  return g;
}

/** The file's own vertex count where the loader splits vertices per triangle (OBJ: its
 * "v" lines; STL: its distinct corners), else null (the geometry's count is the file's). */
function fileVertices(ext, buf, object) {
  if (ext === 'obj') return (new TextDecoder().decode(buf).match(/^v\s/gm) || []).length;
  if (ext !== 'stl') return null;
  const seen = new Set();
  object.traverse((o) => {
    if (!o.isMesh) return;
    const p = floatValues(o.geometry.attributes.position);
    for (let i = 0; i < p.length; i += 3) seen.add(`${p[i]},${p[i + 1]},${p[i + 2]}`);
  });
  return seen.size;
}

/** The file as a three.js object (skin-coloured, both sides), or a MeshFileError naming it. */
export async function loadLocalMesh(file) {
  const ext = extOf(file);
  const buf = await file.arrayBuffer();
  const problem = formatProblem(file.name, ext, buf.slice(0, 4096));
  if (problem) throw new MeshFileError(problem);
  let object;
  try {
    if (ext === 'obj') {
      object = new OBJLoader().parse(new TextDecoder().decode(buf));
    } else if (ext === 'ply' || ext === 'stl' || ext === 'off') {
      const geom = ext === 'off' ? parseOff(new TextDecoder().decode(buf))
        : (ext === 'ply' ? new PLYLoader() : new STLLoader()).parse(buf);
      geom.computeVertexNormals();
      object = new THREE.Mesh(geom);
    } else {
      object = await new Promise((res, rej) => new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parse(buf, '', (g) => res(g.scene), rej));
    }
  } catch (e) {
    throw new MeshFileError(`${file.name}: unreadable ${ext.toUpperCase()} file (${e.message || e})`);
  }
  let vertices = 0;
  let faces = 0;
  object.traverse((o) => {
    if (!o.isMesh) return;
    o.material = new THREE.MeshStandardMaterial({ color: 0xd9b8a0, side: THREE.DoubleSide });
    if (!o.geometry.attributes.normal) o.geometry.computeVertexNormals();
    vertices += o.geometry.attributes.position.count;
    faces += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
  });
  if (!vertices || !faces) throw new MeshFileError(`${file.name}: no triangles in the file`);
  object.userData.counts = { vertices: fileVertices(ext, buf, object) ?? vertices, faces: Math.round(faces) };
  return object;
}

/**
 * Checks a chosen file: its size against `limit` (bytes, or null), its format, its counts.
 * @returns {Promise<{name, bytes, vertices, faces, problem, tooLarge}>}
 */
export async function checkMeshFile(file, limit) {
  const out = { name: file.name, bytes: file.size, vertices: 0, faces: 0, problem: null, tooLarge: false };
  if (limit && file.size > limit) {
    out.tooLarge = true;
    out.problem = `${file.name} is ${fmtBytes(file.size)}: over the server's upload limit of ${fmtBytes(limit)}`;
    return out;
  }
  try {
    const object = await loadLocalMesh(file);
    Object.assign(out, object.userData.counts);
  } catch (e) {
    out.problem = e.message || String(e);
  }
  return out;
}
