// Play a morph GLB in three.js (the repository's node_modules, r187; in Node, no GPU) and
// write what it would draw.
//
// Usage: node tools/gltf_three_playback.mjs FILE.glb OUT.json T [T ...]
//
// The file is loaded with GLTFLoader (EXT_meshopt_compression through three's
// MeshoptDecoder, KHR_mesh_quantization natively), its first animation is played by an
// AnimationMixer (LoopOnce, clamped) and set to each time T (seconds). At each time:
// the world positions of the first mesh (base POSITION plus the influences times the
// POSITION deltas, morphTargetsRelative as GLTFLoader sets it, then the world matrix), the
// shader's normals (base NORMAL plus the influences times the NORMAL deltas, normalised,
// turned by the normal matrix) and the vertex colours (linear: base COLOR_0 plus the
// influences times the COLOR_0 deltas where the geometry has colour morphs, as three's
// morphcolor chunk adds them).
//
// OUT.json: {"version", "rest": {position, quaternion, scale} of the mesh's top-level
// node (node 0 of the file) before any animation, "mesh_rest": the same of the mesh's own
// object, "tracks": [names], "vertex_count", "frames": [{"t", "positions": [...flat],
// "normals": [...flat] | null, "colors": [...flat] | null, "color_size"}]}. Exit 2 on bad
// usage.
import { readFile, writeFile } from "node:fs/promises";
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { MeshoptDecoder } from "three/addons/libs/meshopt_decoder.module.js";

const [file, out, ...times] = process.argv.slice(2);
if (!file || !out || times.length === 0) {
  console.error("usage: node tools/gltf_three_playback.mjs FILE.glb OUT.json T [T ...]");
  process.exit(2);
}
const bytes = await readFile(file);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder);
const gltf = await new Promise((resolve, reject) => loader.parse(buffer, "", resolve, reject));
let mesh = null;
gltf.scene.traverse((o) => {
  if (!mesh && o.isMesh) mesh = o;
});
const restOf = (o) => ({
  position: o.position.toArray(),
  quaternion: o.quaternion.toArray(),
  scale: o.scale.toArray(),
});
let top = mesh;
while (top.parent && top.parent !== gltf.scene) top = top.parent;
const rest = restOf(top);
const meshRest = restOf(mesh);
const mixer = new THREE.AnimationMixer(gltf.scene);
if (gltf.animations.length) {
  const action = mixer.clipAction(gltf.animations[0]);
  action.setLoop(THREE.LoopOnce);
  action.clampWhenFinished = true;
  action.play();
}
const geo = mesh.geometry;
const pos = geo.attributes.position;
const nor = geo.attributes.normal;
const col = geo.attributes.color;
const mPos = geo.morphAttributes.position || [];
const mNor = geo.morphAttributes.normal || [];
const mCol = geo.morphAttributes.color || [];
const frames = [];
for (const ts of times) {
  const t = Number(ts);
  mixer.setTime(t);
  gltf.scene.updateMatrixWorld(true);
  const w = mesh.morphTargetInfluences || [];
  const normalMatrix = new THREE.Matrix3().getNormalMatrix(mesh.matrixWorld);
  const positions = [];
  const normals = nor ? [] : null;
  const colors = col ? [] : null;
  const v = new THREE.Vector3();
  const n = new THREE.Vector3();
  for (let i = 0; i < pos.count; i++) {
    v.fromBufferAttribute(pos, i);
    if (nor) n.fromBufferAttribute(nor, i);
    for (let k = 0; k < w.length; k++) {
      if (w[k] === 0) continue;
      v.x += w[k] * mPos[k].getX(i);
      v.y += w[k] * mPos[k].getY(i);
      v.z += w[k] * mPos[k].getZ(i);
      if (nor && mNor[k]) {
        n.x += w[k] * mNor[k].getX(i);
        n.y += w[k] * mNor[k].getY(i);
        n.z += w[k] * mNor[k].getZ(i);
      }
    }
    v.applyMatrix4(mesh.matrixWorld);
    positions.push(v.x, v.y, v.z);
    if (nor) {
      n.normalize().applyMatrix3(normalMatrix).normalize();
      normals.push(n.x, n.y, n.z);
    }
    if (col) {
      for (let j = 0; j < col.itemSize; j++) {
        let value = col.getComponent(i, j);
        for (let k = 0; k < w.length && k < mCol.length; k++) {
          if (w[k] !== 0 && j < mCol[k].itemSize) value += w[k] * mCol[k].getComponent(i, j);
        }
        colors.push(value);
      }
    }
  }
  frames.push({ t, positions, normals, colors, color_size: col ? col.itemSize : 0 });
}
const tracks = gltf.animations.length ? gltf.animations[0].tracks.map((tr) => tr.name) : [];
const result = {
  version: THREE.REVISION,
  rest,
  mesh_rest: meshRest,
  tracks,
  vertex_count: pos.count,
  frames,
};
await writeFile(out, JSON.stringify(result));
