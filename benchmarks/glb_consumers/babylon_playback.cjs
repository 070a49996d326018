// Play a morph GLB in Babylon.js (NullEngine in Node, no GPU) and write what it would draw.
//
// Usage: node babylon_playback.cjs NPM_DIR FILE.glb OUT.json T [T ...]
//
// NPM_DIR holds node_modules/{babylonjs,babylonjs-loaders,meshoptimizer} (installed by
// benchmarks/bench_glb_consumers.py from benchmarks/glb_consumers/package.json). The file
// is loaded with Babylon's own glTF loader (default options, a default left-handed scene),
// its first animation group is sought to each time T (seconds), and at each time the
// morphed vertex data is computed on the CPU the way Babylon's morph-target shader does:
// base + sum(influence_k * (target_k - base)) for positions, and for normals and colours
// only where the morph-target manager says the shader morphs them (supportsNormals,
// supportsColors; colours as RGBA, an RGB attribute read with alpha 1 as the shader's
// vec4 attribute is); normals are then normalised and turned by the mesh's world matrix.
// Positions and normals are written in glTF coordinates: the loader's "__root__" node
// (the right-to-left-handed flip) is undone, nothing else.
//
// EXT_meshopt_compression: Babylon fetches meshoptimizer's decoder from its CDN
// (MeshoptCompression.Configuration.decoder.url) with a <script> tag; in Node the same
// library comes from the npm package, without web workers (MeshoptDecoder.useWorkers
// is a no-op here, the decode itself is the library's). KHR_mesh_quantization is read
// by the loader natively.
//
// OUT.json: {"versions", "vertex_count", "rest": {"node": {position, quaternion,
// scaling} of the mesh, "top": the same of its top-level node (node 0 of the file, the
// mesh itself unless a quantized file dequantizes it on a child), "root": the loader's
// __root__}, "animated": [paths], "supports": {normals, colors},
// "frames": [{"t", "influences", "positions": [...flat], "normals": [...flat] | null,
// "colors": [...flat RGBA] | null}]}. Exit 2 on bad usage, 1 when loading fails.
"use strict";
const fs = require("node:fs");
const path = require("node:path");
const { createRequire } = require("node:module");

const [npmDir, file, out, ...times] = process.argv.slice(2);
if (!npmDir || !file || !out || times.length === 0) {
  console.error("usage: node babylon_playback.cjs NPM_DIR FILE.glb OUT.json T [T ...]");
  process.exit(2);
}
const req = createRequire(path.join(path.resolve(npmDir), "package.json"));
const BABYLON = req("babylonjs");
const LOADERS = req("babylonjs-loaders");
const MeshoptDecoder = req("meshoptimizer/decoder.cjs");

// the decoder Babylon would load from its CDN, as a global, without workers
globalThis.MeshoptDecoder = {
  ready: MeshoptDecoder.ready,
  supported: MeshoptDecoder.supported,
  useWorkers() {},
  decodeGltfBufferAsync(count, stride, source, mode, filter) {
    return MeshoptDecoder.ready.then(() => {
      const target = new Uint8Array(count * stride);
      MeshoptDecoder.decodeGltfBuffer(target, count, stride, source, mode, filter);
      return target;
    });
  },
};
const loadScript = BABYLON.Tools.LoadBabylonScriptAsync;
BABYLON.Tools.LoadBabylonScriptAsync = (url, ...rest) =>
  String(url).includes("meshopt_decoder") ? Promise.resolve() : loadScript(url, ...rest);

function trs(node) {
  const q = node.rotationQuaternion || BABYLON.Quaternion.FromEulerVector(node.rotation);
  return {
    position: node.position.asArray(),
    quaternion: q.asArray(),
    scaling: node.scaling.asArray(),
  };
}

function morphed(base, targets, influences, get) {
  const v = Float64Array.from(base);
  targets.forEach((target, k) => {
    const w = influences[k];
    if (w === 0) return;
    const data = get(target);
    for (let i = 0; i < v.length; i++) v[i] += w * (data[i] - base[i]);
  });
  return v;
}

function toRgba(data, n) {
  const out = new Float32Array(4 * n);
  for (let i = 0; i < n; i++) {
    out[4 * i] = data[3 * i];
    out[4 * i + 1] = data[3 * i + 1];
    out[4 * i + 2] = data[3 * i + 2];
    out[4 * i + 3] = 1;
  }
  return out;
}

function frameAt(scene, mesh, root, group, fps, t) {
  if (group) group.goToFrame(t * fps);
  scene.incrementRenderId();
  root.computeWorldMatrix(true);
  const world = mesh.computeWorldMatrix(true);
  const toGltf = world.multiply(BABYLON.Matrix.Invert(root.getWorldMatrix()));
  const manager = mesh.morphTargetManager;
  const targets = [];
  const influences = [];
  for (let k = 0; manager && k < manager.numTargets; k++) {
    targets.push(manager.getTarget(k));
    influences.push(manager.getTarget(k).influence);
  }
  const K = BABYLON.VertexBuffer;
  const P = morphed(mesh.getVerticesData(K.PositionKind), targets, influences, (x) => x.getPositions());
  const n = P.length / 3;
  const positions = new Array(3 * n);
  const p = new BABYLON.Vector3();
  for (let i = 0; i < n; i++) {
    BABYLON.Vector3.TransformCoordinatesFromFloatsToRef(P[3 * i], P[3 * i + 1], P[3 * i + 2], toGltf, p);
    positions[3 * i] = p.x;
    positions[3 * i + 1] = p.y;
    positions[3 * i + 2] = p.z;
  }
  let normals = null;
  const baseN = mesh.getVerticesData(K.NormalKind);
  if (baseN) {
    const useN = manager && manager.supportsNormals;
    const N = useN ? morphed(baseN, targets, influences, (x) => x.getNormals()) : Float64Array.from(baseN);
    normals = new Array(3 * n);
    for (let i = 0; i < n; i++) {
      BABYLON.Vector3.TransformNormalFromFloatsToRef(N[3 * i], N[3 * i + 1], N[3 * i + 2], toGltf, p);
      p.normalize();
      normals[3 * i] = p.x;
      normals[3 * i + 1] = p.y;
      normals[3 * i + 2] = p.z;
    }
  }
  let colors = null;
  const baseC = mesh.getVerticesData(K.ColorKind);
  if (baseC) {
    // the shader reads both as vec4: an RGB base attribute gets alpha 1, and the loader
    // stores RGB colour targets as RGBA with alpha 1
    const rgba = (data) => (data.length === 4 * n ? data : toRgba(data, n));
    const useC = manager && manager.supportsColors;
    const C = rgba(baseC);
    colors = Array.from(useC ? morphed(C, targets, influences, (x) => rgba(x.getColors())) : C);
  }
  return { t, influences, positions, normals, colors };
}

async function main() {
  const engine = new BABYLON.NullEngine();
  const scene = new BABYLON.Scene(engine);
  const bytes = fs.readFileSync(file);
  const data = new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  // the file's own rest transform: no animation started by the loader before it is read
  const pluginOptions = { gltf: { animationStartMode: LOADERS.GLTFLoaderAnimationStartMode.NONE } };
  await BABYLON.AppendSceneAsync(data, scene, { pluginExtension: ".glb", pluginOptions });
  const mesh = scene.meshes.find((m) => m.getTotalVertices() > 0);
  const root = scene.getNodeByName("__root__") || new BABYLON.TransformNode("identity", scene);
  let top = mesh;
  while (top.parent && top.parent !== root) top = top.parent;
  const rest = { node: trs(mesh), top: trs(top), root: trs(root) };
  const group = scene.animationGroups[0] || null;
  const animated = [];
  let fps = 60;
  if (group) {
    group.stop();
    group.start(false, 1.0);
    group.pause();
    for (const ta of group.targetedAnimations) {
      animated.push(`${ta.target.name || ta.target.constructor.name}.${ta.animation.targetProperty}`);
      fps = ta.animation.framePerSecond;
    }
  }
  const frames = times.map((ts) => frameAt(scene, mesh, root, group, fps, Number(ts)));
  const manager = mesh.morphTargetManager;
  const result = {
    versions: { babylonjs: BABYLON.Engine.Version },
    vertex_count: mesh.getTotalVertices(),
    indices: Array.from(mesh.getIndices()),
    rest,
    animated: [...new Set(animated)],
    morph_targets: manager ? manager.numTargets : 0,
    supports: manager
      ? { normals: manager.supportsNormals, colors: manager.supportsColors }
      : { normals: false, colors: false },
    frames,
  };
  fs.writeFileSync(out, JSON.stringify(result));
  engine.dispose();
}

main().catch((err) => {
  console.error(err && err.stack ? err.stack : String(err));
  process.exit(1);
});
