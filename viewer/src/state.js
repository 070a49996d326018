// What the 3D side of the viewer knows, shared by its modules (one object, no copies).

export const $ = (id) => document.getElementById(id);

export const state = {
  meshFiles: [],
  checks: [], // per chosen mesh: {name, bytes, vertices, faces, problem} (meshfiles.js)
  config: { max_upload_bytes: null, morph_defaults: {} }, // GET /viewer/config.json
  landmarkLists: null, // from a file
  picks: [], // per mesh: [[x, y, z], …]
  provenance: [], // per mesh, per pick: 'detected' | 'moved' | 'picked'
  pickMesh: 0,
  shownMesh: -1, // the mesh in the view, once loaded (-1 while one loads)
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

export function setStatus(text, kind = '') {
  const el = $('status');
  el.textContent = text;
  el.className = `note ${kind}`;
}

/** Bytes as a person reads them: MB with one decimal (KB below 0.1 MB). */
export function fmtBytes(n) {
  if (n < 100_000) return `${(n / 1000).toFixed(0)} KB`;
  return `${(n / 1e6).toFixed(1)} MB`;
}

export function escapeHtml(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' })[c]);
}
