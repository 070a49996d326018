// The viewer's 2D tab: choose two shapes (SVG or JSON rings), upload them (POST /v1/shapes),
// morph them (POST /v1/morphs2d), draw the corresponding points the job chose (its
// anchors.json) as numbered points on the source and the target, let a drag move a point
// to another outline vertex, resubmit the corrected points as anchors, play frames.json and
// offer the job's files for download.
//
// Coordinates: anchors.json is in shape coordinates (y up); frames.json and animation.svg
// write (x, -y). Everything drawn here is in the SVG convention, anchors are converted.

import { previewPair } from './shape_files.js';

const SVG_NS = 'http://www.w3.org/2000/svg';
const DOWNLOADS = ['animation.svg', 'frames.json', 'anchors.json', 'animation.glb', 'metrics.json'];
const SECONDS = 3; // playing time from the first frame to the last

/** Points of one `M x,y L x,y … Z` path (frames.json), in SVG coordinates. */
export function pathPoints(d) {
  const out = [];
  for (const m of d.matchAll(/(-?[0-9.eE+-]+),(-?[0-9.eE+-]+)/g)) out.push([Number(m[1]), Number(m[2])]);
  return out;
}

/** The vertex of `rings` nearest to `p` (all in one coordinate system). */
export function nearestVertex(rings, p) {
  let best = null;
  let bestD = Infinity;
  for (const ring of rings) {
    for (const q of ring) {
      const d = (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2;
      if (d < bestD) {
        bestD = d;
        best = q;
      }
    }
  }
  return best;
}

function el(name, attrs = {}, parent = null) {
  const e = document.createElementNS(SVG_NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (parent) parent.appendChild(e);
  return e;
}

function viewBoxOf(rings, pad = 0.08) {
  const pts = rings.flat();
  const xs = pts.map((p) => p[0]);
  const ys = pts.map((p) => p[1]);
  const x0 = Math.min(...xs);
  const y0 = Math.min(...ys);
  const w = Math.max(...xs) - x0 || 1;
  const h = Math.max(...ys) - y0 || 1;
  const m = pad * Math.max(w, h);
  return { x0: x0 - m, y0: y0 - m, w: w + 2 * m, h: h + 2 * m, size: Math.max(w, h) };
}

export function initShapes2d({ api, $, updateJob, onError }) {
  const s = {
    files: [],
    shapeIds: null,
    jobId: null,
    jobState: 'idle',
    loadedJob: null, // the job whose files are shown
    error: null,
    anchors: null, // [[[xs, ys], [xt, yt]], …] shape coordinates, from anchors.json or edited
    corrected: false,
    sentAnchors: null, // what the last job was given (null: automatic)
    frames: null, // [{outline: [[x, y]…], holes: [[[x, y]…]…]}] SVG coordinates
    frame: 0,
    playing: false,
    drawn: { source: 0, target: 0 },
    previewed: { source: false, target: false }, // the chosen files drawn before a job
    downloads: [],
    dragging: null,
  };
  let clock = null;

  function status(text, kind = '') {
    const e = $('status2d');
    e.textContent = text;
    e.className = `note ${kind}`;
  }

  function fail(e) {
    s.error = { message: String(e.message || e), status: e.status || null };
    status(`Error: ${e.message || e}`, 'error');
    if (onError) onError(e);
  }

  function shapesChosen() {
    s.files = Array.from($('shapes').files || []);
    s.shapeIds = null;
    s.anchors = null;
    s.corrected = false;
    const names = s.files.map((f) => f.name).join(' → ');
    $('shape-list').textContent = s.files.length === 2 ? names : `choose two shapes (now ${s.files.length})`;
    previewShapes();
  }

  async function previewShapes() {
    s.drawn = { source: 0, target: 0 };
    s.previewed = await previewPair(s.files, $, fail);
    $('anchor-info').textContent = s.files.length === 2 ? 'the numbered corresponding points come with the morph' : '';
  }

  function endRings(k) {
    // frame 0 is the source, the last frame the target (the morph reaches it)
    const f = s.frames[k === 0 ? 0 : s.frames.length - 1];
    return [f.outline, ...f.holes];
  }

  function drawCorrespondence() {
    for (const [k, side] of [[0, 'source'], [1, 'target']]) {
      const svg = $(`corr-${side}`);
      svg.replaceChildren();
      const rings = endRings(k);
      const vb = viewBoxOf(rings);
      svg.setAttribute('viewBox', `${vb.x0} ${vb.y0} ${vb.w} ${vb.h}`);
      const d = rings.map((r) => `M${r.map((p) => p.join(',')).join(' L')} Z`).join(' ');
      el('path', { d, class: 'shape2d', 'fill-rule': 'evenodd', 'stroke-width': vb.size / 300 }, svg);
      const r = vb.size / 60;
      (s.anchors || []).forEach((pair, i) => {
        const [x, y] = pair[k];
        const g = el('g', { class: 'anchor2d', 'data-index': i, 'data-side': side }, svg);
        el('circle', { cx: x, cy: -y, r }, g);
        const t = el('text', { x: x + 1.2 * r, y: -y - 1.2 * r, 'font-size': 2.2 * r }, g);
        t.textContent = String(i + 1);
        g.addEventListener('pointerdown', (ev) => startDrag(ev, svg, i, k));
      });
      s.drawn[side] = (s.anchors || []).length;
    }
    $('anchor-info').textContent = s.anchors
      ? `${s.anchors.length} corresponding points (${s.corrected ? 'corrected: Start sends them' : 'found automatically'})`
      : '';
  }

  function startDrag(ev, svg, index, k) {
    ev.preventDefault();
    s.dragging = { index, k };
    const move = (e) => {
      const pt = new DOMPoint(e.clientX, e.clientY).matrixTransform(svg.getScreenCTM().inverse());
      const q = nearestVertex(endRings(k), [pt.x, pt.y]);
      if (!q) return;
      s.anchors[index][k] = [q[0], -q[1] + 0]; // back to y up (+ 0: no -0)
      s.corrected = true;
      const g = svg.querySelector(`g[data-index="${index}"]`);
      const c = g.querySelector('circle');
      const t = g.querySelector('text');
      const r = Number(c.getAttribute('r'));
      c.setAttribute('cx', q[0]);
      c.setAttribute('cy', q[1]);
      t.setAttribute('x', q[0] + 1.2 * r);
      t.setAttribute('y', q[1] - 1.2 * r);
    };
    const up = () => {
      svg.removeEventListener('pointermove', move);
      window.removeEventListener('pointerup', up);
      s.dragging = null;
      drawCorrespondence();
    };
    svg.addEventListener('pointermove', move);
    window.addEventListener('pointerup', up);
  }

  function showFrame(k) {
    s.frame = k;
    const f = s.frames[k];
    const d = [f.outline, ...f.holes].map((r) => `M${r.map((p) => p.join(',')).join(' L')} Z`).join(' ');
    $('anim2d-path').setAttribute('d', d);
    $('scrub2d').value = String(k);
    $('frame2d').textContent = `frame ${k + 1} / ${s.frames.length}`;
  }

  function tick(now) {
    if (s.frames && s.playing) {
      if (clock === null) clock = now - (s.frame / Math.max(1, s.frames.length - 1)) * SECONDS * 1000;
      const u = (((now - clock) / 1000) % SECONDS) / SECONDS;
      const k = Math.min(s.frames.length - 1, Math.round(u * (s.frames.length - 1)));
      if (k !== s.frame) showFrame(k);
    }
    requestAnimationFrame(tick);
  }

  function setPlaying(on) {
    s.playing = on;
    clock = null;
    $('play2d').textContent = on ? 'Pause' : 'Play';
  }

  async function loadResult(job) {
    const text = (b) => new TextDecoder().decode(b);
    const [anchorsBytes, framesBytes] = await Promise.all([
      api.artifact(job.id, 'anchors.json').catch(() => null),
      api.artifact(job.id, 'frames.json'),
    ]);
    const doc = JSON.parse(text(framesBytes));
    s.frames = doc.frames.map((f) => ({ outline: pathPoints(f.outline), holes: f.holes.map(pathPoints) }));
    // anchors.json exists when the points were found automatically; else the ones sent
    s.anchors = anchorsBytes ? JSON.parse(text(anchorsBytes)).anchors : s.sentAnchors;
    s.corrected = false;
    const all = s.frames.flatMap((f) => [f.outline, ...f.holes]);
    const vb = viewBoxOf(all, 0.05);
    $('anim2d').setAttribute('viewBox', `${vb.x0} ${vb.y0} ${vb.w} ${vb.h}`);
    $('anim2d-path').setAttribute('stroke-width', vb.size / 250);
    $('scrub2d').max = String(s.frames.length - 1);
    for (const u of s.downloads) URL.revokeObjectURL(u);
    s.downloads = [];
    const links = $('downloads2d');
    links.replaceChildren();
    for (const name of DOWNLOADS) {
      const a = document.createElement('a');
      a.textContent = name;
      a.download = `morph2d-${job.id}-${name}`;
      a.dataset.name = name;
      links.appendChild(a);
      api.artifact(job.id, name).then(
        (b) => {
          a.href = URL.createObjectURL(new Blob([b]));
          s.downloads.push(a.href);
        },
        () => a.remove(),
      );
    }
    $('result2d').hidden = false;
    drawCorrespondence();
    showFrame(0);
    setPlaying(true);
    s.loadedJob = job.id;
  }

  async function start() {
    s.error = null;
    $('start2d').disabled = true;
    try {
      if (s.files.length !== 2) throw new Error('choose two shapes: the source, then the target');
      if (!s.shapeIds) {
        const ids = [];
        for (const [i, f] of s.files.entries()) {
          status(`uploading ${i + 1}/2: ${f.name}`);
          ids.push((await api.uploadShape(f)).id);
        }
        s.shapeIds = ids;
      }
      const body = { source: s.shapeIds[0], target: s.shapeIds[1], frames: Number($('frames2d').value) };
      const budget = $('budget2d').value.trim();
      if (budget) body.point_budget = Number(budget);
      s.sentAnchors = s.corrected && s.anchors ? s.anchors.map((p) => p.map((q) => [...q])) : null;
      if (s.sentAnchors) body.anchors = s.sentAnchors;
      status(s.sentAnchors ? `submitting with ${s.sentAnchors.length} corrected points` : 'submitting');
      setPlaying(false);
      const job = await api.createMorph2d(body);
      s.jobId = job.id;
      const done = await api.follow(job.id, (j) => {
        s.jobState = j.state;
        updateJob(j);
      });
      s.jobState = done.state;
      if (done.state !== 'succeeded') {
        const why = (done.error && (done.error.message || JSON.stringify(done.error))) || done.state;
        throw new Error(`job ${done.state}: ${why}`);
      }
      await loadResult(done);
      status(`done: ${done.id}`, 'ok');
    } catch (e) {
      fail(e);
    } finally {
      $('start2d').disabled = false;
    }
  }

  $('shapes').addEventListener('change', shapesChosen);
  $('start2d').addEventListener('click', start);
  $('reset2d').addEventListener('click', () => {
    s.corrected = false;
    s.anchors = null;
    if (s.frames) drawCorrespondence();
  });
  $('play2d').addEventListener('click', () => setPlaying(!s.playing));
  $('scrub2d').addEventListener('input', () => {
    if (!s.frames) return;
    setPlaying(false);
    showFrame(Number($('scrub2d').value));
  });
  requestAnimationFrame(tick);

  return () => ({
    jobId: s.jobId,
    jobState: s.jobState,
    loadedJob: s.loadedJob,
    error: s.error,
    shapes: s.files.length,
    anchors: s.anchors ? s.anchors.map((p) => p.map((q) => [...q])) : null,
    corrected: s.corrected,
    sentAnchors: s.sentAnchors,
    frames: s.frames ? s.frames.length : 0,
    frame: s.frame,
    playing: s.playing,
    drawn: { ...s.drawn },
    previewed: { ...s.previewed },
    downloads: Array.from(document.querySelectorAll('#downloads2d a[href]')).map((a) => a.dataset.name),
  });
}
