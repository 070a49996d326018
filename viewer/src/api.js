// The REST API from the browser: fetch with the API key, JSON errors, server-sent
// events read from a fetch stream (EventSource cannot send an Authorization header).

export class ApiError extends Error {
  constructor(status, type, message, field) {
    super(`${message}${field ? ` (${field})` : ''}`);
    this.status = status;
    this.type = type;
    this.field = field;
  }
}

export class Api {
  constructor(base = '') {
    this.base = base;
    this.key = '';
  }

  headers(extra = {}) {
    const h = { ...extra };
    if (this.key) h.Authorization = `Bearer ${this.key}`;
    return h;
  }

  async error(r) {
    let type = `http_${r.status}`;
    let message = r.statusText || 'request failed';
    let field = null;
    try {
      const body = await r.json();
      if (body && body.error) {
        type = body.error.type || type;
        message = body.error.message || message;
        field = body.error.field || null;
      } else if (body && (body.detail || body.title)) message = body.detail || body.title;
    } catch {
      /* not JSON */
    }
    return new ApiError(r.status, type, message, field);
  }

  async request(method, path, { json, form, accept = 'application/json', raw = false } = {}) {
    const init = { method, headers: this.headers({ Accept: accept }) };
    if (json !== undefined) {
      init.headers['Content-Type'] = 'application/json';
      init.body = JSON.stringify(json);
    } else if (form !== undefined) {
      init.body = form;
    }
    const r = await fetch(this.base + path, init);
    if (!r.ok) throw await this.error(r);
    if (raw) return r;
    return r.status === 204 ? null : r.json();
  }

  readyz() {
    return fetch(`${this.base}/readyz`).then((r) => r.json());
  }

  listJobs(limit = 1) {
    return this.request('GET', `/v1/jobs?limit=${limit}`);
  }

  uploadMesh(file) {
    const form = new FormData();
    form.append('file', file, file.name);
    return this.request('POST', '/v1/meshes', { form });
  }

  detectLandmarks(meshIds) {
    return this.request('POST', '/v1/landmark-detections', { json: { meshes: meshIds } });
  }

  uploadShape(file) {
    const form = new FormData();
    form.append('file', file, file.name);
    return this.request('POST', '/v1/shapes', { form });
  }

  createMorph2d(body) {
    return this.request('POST', '/v1/morphs2d', { json: body });
  }

  createMorph(body) {
    return this.request('POST', '/v1/morphs', { json: body });
  }

  getJob(id) {
    return this.request('GET', `/v1/jobs/${encodeURIComponent(id)}`);
  }

  async artifact(id, name) {
    const r = await this.request('GET', `/v1/jobs/${encodeURIComponent(id)}/artifacts/${name}`, {
      accept: '*/*',
      raw: true,
    });
    return r.arrayBuffer();
  }

  /** Yields the job record of every `state` event until the `end` event. */
  async *events(id, signal) {
    const r = await fetch(`${this.base}/v1/jobs/${encodeURIComponent(id)}/events`, {
      headers: this.headers({ Accept: 'text/event-stream' }),
      signal,
    });
    if (!r.ok) throw await this.error(r);
    const reader = r.body.pipeThrough(new TextDecoderStream()).getReader();
    let buf = '';
    let event = '';
    let data = [];
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return;
      buf += value;
      let i;
      while ((i = buf.indexOf('\n')) >= 0) {
        const line = buf.slice(0, i).replace(/\r$/, '');
        buf = buf.slice(i + 1);
        if (line === '') {
          if (event === 'end') return;
          if (event === 'state' && data.length) yield JSON.parse(data.join('\n'));
          event = '';
          data = [];
        } else if (!line.startsWith(':')) {
          const k = line.split(':', 1)[0];
          let v = line.slice(k.length + 1);
          if (v.startsWith(' ')) v = v.slice(1);
          if (k === 'event') event = v;
          else if (k === 'data') data.push(v);
        }
      }
    }
  }

  /** Follows a job (events, then polling if the stream breaks) until it ends. */
  async follow(id, onUpdate) {
    const terminal = new Set(['succeeded', 'failed', 'cancelled']);
    let job = await this.getJob(id);
    onUpdate(job);
    if (!terminal.has(job.state)) {
      try {
        for await (const j of this.events(id)) {
          job = j;
          onUpdate(job);
        }
      } catch (e) {
        if (e instanceof ApiError) throw e;
      }
      job = await this.getJob(id);
      onUpdate(job);
    }
    while (!terminal.has(job.state)) {
      await new Promise((res) => setTimeout(res, 1000));
      job = await this.getJob(id);
      onUpdate(job);
    }
    return job;
  }
}
