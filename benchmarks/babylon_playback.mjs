// Play a morph GLB in Babylon.js (NullEngine in Node, no GPU) and print what it would draw:
// the consumer check of issue 29's compact files for Babylon (too heavy a dependency for
// the tests; three.js is checked there by tools/gltf_three_playback.mjs).
//
// Babylon is not a dependency of the repository: install it into a folder of its own,
// core pinned to the loaders' version, and name that folder's node_modules:
//   npm install --prefix /tmp/babylon babylonjs@9.28.0 babylonjs-loaders@9.28.0
//   BABYLON_MODULES=/tmp/babylon/node_modules node benchmarks/babylon_playback.mjs FILE.glb T [T ...]
//
// Babylon fetches its meshopt decoder from its CDN at run time; offline (these machines)
// the decoder three.js ships (the same meshoptimizer decoder, from the repository's
// node_modules) is handed to Babylon's MeshoptCompression instead.
//
// Prints one JSON object: {"root": name of the top node under Babylon's __root__, "frames":
// [{"t", "positions": [[x, y, z], ...]}]} with the world positions of the first morphing
// mesh at each time T (seconds) of the first animation group, x negated back from
// Babylon's left-handed scene (its __root__ node mirrors glTF's right-handed x). Exit code
// 2 on bad usage, 3 when the file does not load.
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";
import { MeshoptDecoder } from "three/examples/jsm/libs/meshopt_decoder.module.js";

const [file, ...times] = process.argv.slice(2);
const modules = process.env.BABYLON_MODULES;
if (!file || times.length === 0 || !modules) {
  console.error(
    "usage: BABYLON_MODULES=<folder>/node_modules node benchmarks/babylon_playback.mjs FILE.glb T [T ...]",
  );
  process.exit(2);
}
const require = createRequire(path.join(path.resolve(modules), "..", "index.js"));
const BABYLON = require("babylonjs");
require("babylonjs-loaders");
await MeshoptDecoder.ready;
BABYLON.MeshoptCompression._Default = {
  decodeGltfBufferAsync: async (source, count, stride, mode, filter) => {
    const out = new Uint8Array(count * stride);
    MeshoptDecoder.decodeGltfBuffer(out, count, stride, source, mode, filter);
    return out;
  },
};
const engine = new BABYLON.NullEngine();
const scene = new BABYLON.Scene(engine);
new BABYLON.FreeCamera("camera", new BABYLON.Vector3(0, 0, -1), scene);
const bytes = await readFile(file);
let loaded;
try {
  const url = "data:model/gltf-binary;base64," + bytes.toString("base64");
  loaded = await BABYLON.SceneLoader.ImportMeshAsync("", "", url, scene, null, ".glb");
} catch (e) {
  console.error(`${file}: Babylon could not load it: ${String(e.message || e).slice(0, 300)}`);
  process.exit(3);
}
const mesh = loaded.meshes.find((m) => m.morphTargetManager) || loaded.meshes.find((m) => m.getTotalVertices() > 0);
const manager = mesh.morphTargetManager;
const group = loaded.animationGroups[0];
const base = mesh.getVerticesData(BABYLON.VertexBuffer.PositionKind, false, true);
const targets = [];
for (let k = 0; manager && k < manager.numTargets; k++) targets.push(manager.getTarget(k).getPositions());
const frames = [];
for (const ts of times) {
  const t = Number(ts);
  if (group) {
    group.start(false);
    group.goToFrame(t * group.targetedAnimations[0].animation.framePerSecond);
    group.pause();
  }
  scene.render();
  const world = mesh.computeWorldMatrix(true);
  const P = Float32Array.from(base);
  targets.forEach((d, k) => {
    const w = manager.getTarget(k).influence;
    if (w) for (let i = 0; i < P.length; i++) P[i] += w * (d[i] - base[i]); // absolute targets
  });
  const v = new BABYLON.Vector3();
  const positions = [];
  for (let i = 0; i < P.length; i += 3) {
    BABYLON.Vector3.TransformCoordinatesFromFloatsToRef(P[i], P[i + 1], P[i + 2], world, v);
    positions.push([-v.x, v.y, v.z]);
  }
  frames.push({ t, positions });
}
let root = mesh;
while (root.parent && root.parent.name !== "__root__") root = root.parent;
console.log(JSON.stringify({ root: root.name, frames }));
