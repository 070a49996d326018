// The job's metrics.json as a table, its angle-distortion histogram, and the units line
// under the view (metrics' per-key units when the server states them).

import { drawHistogram, findHistograms } from './histogram.js';
import { $, escapeHtml, state } from './state.js';

function fmt(v) {
  if (typeof v === 'number') return Number.isInteger(v) ? String(v) : Math.abs(v) < 1e-3 || Math.abs(v) >= 1e5 ? v.toExponential(3) : v.toFixed(4);
  return String(v);
}

export function flatten(obj, prefix, out) {
  for (const [k, v] of Object.entries(obj)) {
    const key = prefix ? `${prefix}.${k}` : k;
    if (v && typeof v === 'object' && !Array.isArray(v)) {
      if (!(Array.isArray(v.edges) && Array.isArray(v.counts))) flatten(v, key, out);
    } else if (Array.isArray(v)) {
      if (v.length <= 6 && v.every((x) => typeof x !== 'object')) out.push([key, v.map(fmt).join(', ')]);
      else if (v.length && v.every((x) => x && typeof x === 'object' && !Array.isArray(x))) {
        v.forEach((x, i) => flatten(x, `${key}[${i}]`, out));
      }
    } else out.push([key, fmt(v)]);
  }
  return out;
}

/**
 * The per-key units metrics.json states, as text, or null: its `units` entry
 * (`{working_unit, keys: [{units, metres_per_unit, source}, …]}`; the GLB is then in
 * metres), or a plain list of `{name, factor}` or of names per key.
 */
export function unitsText(metrics) {
  const u = metrics && metrics.units;
  if (!u) return null;
  const list = Array.isArray(u) ? u : Array.isArray(u.keys) ? u.keys : [];
  const said = list.map((x, i) => {
    if (x && typeof x === 'object') {
      const name = x.units || x.name || '?';
      const f = x.metres_per_unit ?? x.factor;
      const how = x.source ? `, ${x.source}` : '';
      return `key ${i + 1} ${name}${f !== undefined && name !== 'm' ? ` = ${f} m` : ''}${how}`;
    }
    return `key ${i + 1} ${x}`;
  });
  if (!said.length) return typeof u === 'string' ? u : null;
  return `${said.join('; ')}${Array.isArray(u) ? '' : ' (the animation in metres)'}`;
}

/** The line under the view: the current shape's size and, once known, the units. */
export function showUnits(size) {
  const stated = unitsText(state.metrics);
  const dims = size ? size.map((x) => (x >= 100 || x < 0.01 ? x.toPrecision(3) : x.toFixed(3))).join(' × ') : '';
  const units = stated ? `units ${stated}` : state.loaded ? 'units: as in the input files (metrics.json states none)' : 'units: as in the file';
  $('units').textContent = `${dims ? `size ${dims}; ` : ''}${units}`;
}

export async function loadMetrics(api, job) {
  try {
    const bytes = await api.artifact(job.id, 'metrics.json');
    const metrics = JSON.parse(new TextDecoder().decode(bytes));
    state.metrics = metrics;
    const rows = flatten(metrics, '', []);
    $('metrics').innerHTML =
      '<tr><th>metric</th><th>value</th></tr>' +
      rows.map(([k, v]) => `<tr><td>${escapeHtml(k)}</td><td>${escapeHtml(v)}</td></tr>`).join('');
    const server = findHistograms(metrics)[0];
    if (server) drawHistogram($('hist-server'), server.hist, server.path);
    $('hist-server').hidden = !server;
  } catch (e) {
    $('metrics').innerHTML = `<tr><td>metrics unavailable: ${escapeHtml(e.message || String(e))}</td></tr>`;
  }
}
