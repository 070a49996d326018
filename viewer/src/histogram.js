// Angle distortion: per-corner differences (degrees) between the triangle angles of
// two embeddings of the same mesh, and a small canvas bar chart of a histogram.

function cornerAngles(pos, index, out) {
  // pos: Float32Array (3n), index: Uint32Array|Uint16Array (3m), out: Float32Array (3m)
  const m = index.length / 3;
  for (let t = 0; t < m; t++) {
    const ia = 3 * index[3 * t];
    const ib = 3 * index[3 * t + 1];
    const ic = 3 * index[3 * t + 2];
    const ab = Math.hypot(pos[ib] - pos[ia], pos[ib + 1] - pos[ia + 1], pos[ib + 2] - pos[ia + 2]);
    const bc = Math.hypot(pos[ic] - pos[ib], pos[ic + 1] - pos[ib + 1], pos[ic + 2] - pos[ib + 2]);
    const ca = Math.hypot(pos[ia] - pos[ic], pos[ia + 1] - pos[ic + 1], pos[ia + 2] - pos[ic + 2]);
    // law of cosines at each corner
    const ang = (x, y, opp) => {
      const c = (x * x + y * y - opp * opp) / (2 * x * y || 1);
      return Math.acos(Math.max(-1, Math.min(1, c)));
    };
    out[3 * t] = ang(ab, ca, bc);
    out[3 * t + 1] = ang(ab, bc, ca);
    out[3 * t + 2] = ang(bc, ca, ab);
  }
  return out;
}

/**
 * Histogram of |angle(current) - angle(reference)| in degrees over every triangle corner.
 * @returns {{edges: number[], counts: number[], above: number, mean: number, max: number}}
 */
export function angleDistortionHistogram(refPos, curPos, index, binWidth = 1, maxDeg = 30) {
  const a = cornerAngles(refPos, index, new Float32Array(index.length));
  const b = cornerAngles(curPos, index, new Float32Array(index.length));
  const nb = Math.ceil(maxDeg / binWidth);
  const counts = new Array(nb).fill(0);
  let above = 0;
  let sum = 0;
  let max = 0;
  for (let i = 0; i < a.length; i++) {
    const d = (Math.abs(a[i] - b[i]) * 180) / Math.PI;
    sum += d;
    if (d > max) max = d;
    const k = Math.floor(d / binWidth);
    if (k >= nb) above++;
    else counts[k]++;
  }
  const edges = Array.from({ length: nb + 1 }, (_, i) => i * binWidth);
  return { edges, counts, above, mean: a.length ? sum / a.length : 0, max };
}

/** Finds {edges, counts} histograms in a metrics document, angle ones first. */
export function findHistograms(doc, path = '') {
  const out = [];
  if (doc && typeof doc === 'object') {
    if (Array.isArray(doc.edges) && Array.isArray(doc.counts)) out.push({ path, hist: doc });
    else {
      for (const [k, v] of Object.entries(doc)) out.push(...findHistograms(v, path ? `${path}.${k}` : k));
    }
  }
  return out.sort((x, y) => (y.path.includes('angle') ? 1 : 0) - (x.path.includes('angle') ? 1 : 0));
}

export function drawHistogram(canvas, hist, title) {
  const ctx = canvas.getContext('2d');
  const W = canvas.width;
  const H = canvas.height;
  ctx.clearRect(0, 0, W, H);
  ctx.fillStyle = '#fff';
  ctx.fillRect(0, 0, W, H);
  const pad = { l: 40, r: 10, t: 22, b: 26 };
  const counts = hist.counts;
  const peak = Math.max(1, ...counts);
  const bw = (W - pad.l - pad.r) / counts.length;
  ctx.fillStyle = '#3b6ea5';
  counts.forEach((c, i) => {
    const h = ((H - pad.t - pad.b) * c) / peak;
    ctx.fillRect(pad.l + i * bw + 0.5, H - pad.b - h, Math.max(1, bw - 1), h);
  });
  ctx.strokeStyle = '#333';
  ctx.beginPath();
  ctx.moveTo(pad.l, pad.t);
  ctx.lineTo(pad.l, H - pad.b);
  ctx.lineTo(W - pad.r, H - pad.b);
  ctx.stroke();
  ctx.fillStyle = '#222';
  ctx.font = '11px sans-serif';
  ctx.fillText(title, pad.l, 14);
  ctx.fillText(String(peak), 4, pad.t + 8);
  ctx.fillText('0', 4, H - pad.b);
  const e = hist.edges;
  ctx.fillText(`${e[0]}`, pad.l, H - 8);
  ctx.fillText(`${e[e.length - 1]}°${hist.above ? ` (+${hist.above} above)` : ''}`, W - pad.r - 110, H - 8);
}
