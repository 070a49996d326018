// The server as the viewer sees it: the API key (kept in the browser's storage), whether
// the server is ready and accepts the key, and what it tells the viewer before a job
// (GET /viewer/config.json: the upload limit, the CLI's morph defaults).

import { $, state } from './state.js';

export function keyChanged(api) {
  api.key = $('api-key').value.trim();
  try {
    localStorage.setItem('conformorph-api-key', api.key);
  } catch {
    /* storage may be off */
  }
  checkServer(api);
}

export async function checkServer(api) {
  try {
    const ready = await api.readyz();
    await api.listJobs(1);
    $('server').textContent = `${ready.status}${api.key ? ', key accepted' : ', open (no key needed)'}`;
    $('server').className = 'ok';
  } catch (e) {
    const unauthorised = e && e.status === 401;
    $('server').textContent = unauthorised
      ? api.key ? 'unknown API key' : 'this server needs an API key'
      : `unreachable: ${e.message || e}`;
    $('server').className = 'error';
  }
}

export async function loadConfig() {
  try {
    const r = await fetch('/viewer/config.json');
    if (r.ok) state.config = await r.json();
  } catch {
    /* an older server: no limit known, the API's own defaults */
  }
}
