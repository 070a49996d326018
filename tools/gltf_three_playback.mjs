// Play a morph GLB in three.js (r187, in Node, no GPU) and print what it would draw.
//
// Usage: node tools/gltf_three_playback.mjs FILE.glb T [T ...]
// Prints one JSON object: {"rest": {"position", "quaternion", "scale"} of the first mesh's
// node before any animation, "rootRest": the same of that node's top-level ancestor (the
// node itself unless it is a quantized file's dequantization child), "frames": [{"t", "positions": [[x, y, z], ...],
// "normals": [[x, y, z], ...]}, ...]} with the world positions and the shader's normals
// (base NORMAL plus the influences times the NORMAL deltas, normalised, turned by the
// node) at each time T (seconds) of the file's first animation, as an AnimationMixer
// sets them. Compressed files (EXT_meshopt_compression) are decoded with three's
// MeshoptDecoder. Exit code 2 on bad usage.
import { readFile } from "node:fs/promises";
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { MeshoptDecoder } from "three/addons/libs/meshopt_decoder.module.js";

const [file, ...times] = process.argv.slice(2);
if (!file || times.length === 0) {
  console.error("usage: node tools/gltf_three_playback.mjs FILE.glb T [T ...]");
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
const rest = restOf(mesh);
let root = mesh;
while (root.parent && root.parent !== gltf.scene && !root.parent.isScene) root = root.parent;
const rootRest = restOf(root);
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
const mPos = geo.morphAttributes.position || [];
const mNor = geo.morphAttributes.normal || [];
const frames = [];
for (const ts of times) {
  const t = Number(ts);
  mixer.setTime(t);
  gltf.scene.updateMatrixWorld(true);
  const w = mesh.morphTargetInfluences || [];
  const normalMatrix = new THREE.Matrix3().getNormalMatrix(mesh.matrixWorld);
  const positions = [];
  const normals = [];
  const v = new THREE.Vector3();
  const n = new THREE.Vector3();
  for (let i = 0; i < pos.count; i++) {
    v.fromBufferAttribute(pos, i);
    if (nor) n.fromBufferAttribute(nor, i);
    for (let k = 0; k < w.length; k++) {
      if (w[k] === 0) continue;
      // glTF morph targets are relative (GLTFLoader sets morphTargetsRelative)
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
    positions.push([v.x, v.y, v.z]);
    if (nor) {
      n.normalize().applyMatrix3(normalMatrix).normalize();
      normals.push([n.x, n.y, n.z]);
    }
  }
  frames.push({ t, positions, normals });
}
console.log(JSON.stringify({ rest, rootRest, morphTargetsRelative: geo.morphTargetsRelative, frames }));
