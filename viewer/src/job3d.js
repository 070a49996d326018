// The 3D jobs: the uploads (stopped before any byte is sent while a chosen file is known
// to be refused; an error names its file), the landmark detection (warnings grouped by
// mesh, with its file name), the morph (the CLI's defaults from /viewer/config.json, the
// landmarks' provenance) and what a job will do before it starts (the plan).

import { ApiError } from './api.js';
import { $, escapeHtml, fmtBytes, setStatus, state } from './state.js';

export function showError(e) {
  state.error = e instanceof ApiError ? { type: e.type, message: e.message, status: e.status } : { message: String(e.message || e) };
  setStatus(`Error: ${e.message || e}`, 'error');
}

// the server's reason for a failed or cancelled job, shown as soon as the state arrives
export function showJobFailure(job) {
  const err = job.error || {};
  state.error = err;
  setStatus(`job ${job.state}${err.stage ? ` in ${err.stage}` : ''}: ${err.message || ''}${err.field ? ` (${err.field})` : ''}`, 'error');
}

export function updateJob(job) {
  const tag = `${job.state} ${job.stage || '-'}`;
  if (state.seen[state.seen.length - 1] !== tag) state.seen.push(tag);
  Object.assign(state, { job, jobState: job.state, progress: job.progress, stage: job.stage });
  $('job-id').textContent = job.id;
  $('job-state').textContent = job.state;
  $('job-stage').textContent = job.stage || '–';
  $('job-progress').value = job.progress;
  $('job-progress-text').textContent = `${Math.round(job.progress * 100)}%`;
  const rows = job.stages
    .map((s) => `<tr><td>${s.name}</td><td>${s.state}</td><td>${s.seconds == null ? '' : s.seconds.toFixed(2)}</td></tr>`)
    .join('');
  $('stages').innerHTML = `<tr><th>stage</th><th>state</th><th>s</th></tr>${rows}`;
  if (job.state === 'failed' || job.state === 'cancelled') showJobFailure(job);
}

/** The first problem of the chosen files that no upload can get past, or null. */
export function blockingProblem() {
  const bad = state.checks.find((c) => c && c.problem);
  return bad ? bad.problem : null;
}

export async function uploadAll(api) {
  const blocking = blockingProblem();
  if (blocking) throw new Error(`${blocking}; nothing was uploaded`);
  const uploaded = [];
  for (const [i, f] of state.meshFiles.entries()) {
    setStatus(`uploading ${i + 1}/${state.meshFiles.length}: ${f.name} (${fmtBytes(f.size)})`);
    try {
      uploaded.push(await api.uploadMesh(f));
    } catch (e) {
      // the server names the form field ("file"); a person needs the file's name
      if (e instanceof ApiError) throw new ApiError(e.status, e.type, `${f.name}: ${e.message.replace(/ \(file\)$/, '')}`, null);
      throw e;
    }
  }
  return uploaded;
}

// the repairs the server found the uploads need (report.repairs_needed), asked for in
// the morph: the CLI's --fill-holes / --remove-ears
export function neededRepairs(meshes) {
  const repairs = {};
  for (const [i, m] of meshes.entries()) {
    for (const r of Object.keys((m.report && m.report.repairs_needed) || {})) {
      (repairs[r] = repairs[r] || []).push(i + 1);
    }
  }
  return repairs;
}

export function morphBody(meshIds, repairs = {}) {
  const body = { meshes: meshIds, frames: Number($('frames').value), method: $('method').value };
  Object.assign(body, state.config.morph_defaults || {}); // prepare, vertex_budget: as the CLI
  for (const r of Object.keys(repairs)) body[r] = true;
  const times = $('times').value.trim();
  if (times) body.times = times.split(',').map(Number);
  if (state.landmarkLists) {
    body.landmarks = state.landmarkLists;
    body.landmark_provenance = state.landmarkLists.map((l) => l.map(() => 'file'));
  } else {
    const counts = state.picks.map((p) => p.length);
    if (new Set(counts).size !== 1 || counts[0] < 3) {
      throw new Error(`pick the same number (≥ 3) of landmarks on every mesh, in the same order (now ${counts.join(', ')})`);
    }
    body.landmarks = state.picks;
    body.landmark_provenance = state.provenance.map((p) => [...p]);
  }
  return body;
}

/** What a morph of the chosen meshes will do, said before it starts. */
export function planText() {
  const checks = state.checks.filter(Boolean);
  if (!checks.length || checks.some((c) => c.problem || !c.vertices)) return '';
  const budget = (state.config.morph_defaults || {}).vertex_budget || 0;
  const frames = Math.max(2, Number($('frames').value) || 2);
  const parts = checks.map((c, i) => {
    const work = budget && c.vertices > budget ? budget : c.vertices;
    return `mesh ${i + 1}: ${c.vertices.toLocaleString('en')} vertices${work < c.vertices ? ` → about ${work.toLocaleString('en')} (the server's working resolution)` : ''}`;
  });
  // the output is the first mesh at its own resolution (output_resolution input): positions,
  // normals, indices and a position and a normal target per frame, 24 bytes a vertex each;
  // above 16 MiB the file is quantized and EXT_meshopt_compression-compressed, about 6.5
  // times smaller (68k-vertex faces x 30 frames: 52.6 MB -> 7.6 MB; ICT 7k: 5.4 -> 0.9 MB)
  const n = checks[0].vertices;
  const raw = 24 * n * (frames + 2);
  const bytes = raw > 16 * 2 ** 20 ? raw / 6.5 : raw;
  const heavy = checks.some((c) => budget && c.vertices > budget);
  return `${parts.join('; ')}. ${frames} frames: animation.glb about ${fmtBytes(bytes)}${heavy ? '; decimation keeps the job to minutes' : ''}.`;
}

export function showPlan() {
  $('plan').textContent = planText();
}

/** Detection warnings, one line per mesh, with its file name; numbers are 1-based. */
export function detectionSummary(doc) {
  return doc.confidence.map((c, i) => {
    const low = c.map((x, j) => (x < 0.5 ? j + 1 : 0)).filter(Boolean);
    const name = state.meshFiles[i] ? state.meshFiles[i].name : `mesh ${i + 1}`;
    const said = [
      low.length ? `low confidence (orange): ${low.join(', ')}` : 'no low-confidence points',
      ...(doc.warnings[i] || []),
    ];
    return `<div class="mesh-warnings"><b>mesh ${i + 1} (${escapeHtml(name)})</b>: ${said.map(escapeHtml).join('; ')}</div>`;
  }).join('');
}
