// 2D shape files read in the browser, to draw the chosen shapes before any job runs:
// JSON rings ({"rings": [outer, hole, …]}, y up, or parts of them) and SVG files (every
// <path d>, drawn as the file draws it: SVG coordinates, y down).

const SVG_NS = 'http://www.w3.org/2000/svg';

/** Every ring under `data` ("rings" lists, also inside "parts"), as [[x, y], …] y up. */
function ringsOf(data, out = []) {
  if (Array.isArray(data)) {
    for (const x of data) ringsOf(x, out);
  } else if (data && typeof data === 'object') {
    if (Array.isArray(data.rings)) {
      for (const r of data.rings) if (Array.isArray(r) && r.length >= 3 && Array.isArray(r[0])) out.push(r);
    }
    if (data.parts) ringsOf(data.parts, out);
  }
  return out;
}

/**
 * The path data to draw a chosen shape file, in SVG coordinates.
 * @returns {Promise<{d: string, rings: number}>}
 */
export async function shapePathData(file) {
  const text = await file.text();
  if (file.name.toLowerCase().endsWith('.json') || text.trimStart().startsWith('{')) {
    let data;
    try {
      data = JSON.parse(text);
    } catch (e) {
      throw new Error(`${file.name}: not JSON (${e.message})`);
    }
    const rings = ringsOf(data);
    if (!rings.length) throw new Error(`${file.name}: no "rings" (lists of [x, y] points) in the file`);
    const d = rings.map((r) => `M${r.map((p) => `${p[0]},${-p[1]}`).join(' L')} Z`).join(' ');
    return { d, rings: rings.length };
  }
  const doc = new DOMParser().parseFromString(text, 'image/svg+xml');
  const paths = Array.from(doc.getElementsByTagNameNS(SVG_NS, 'path')).map((p) => p.getAttribute('d')).filter(Boolean);
  if (!paths.length && /^[\s]*[Mm]/.test(text)) paths.push(text.trim()); // bare path data
  if (!paths.length) throw new Error(`${file.name}: no <path d="…"> in the file`);
  return { d: paths.join(' '), rings: paths.length };
}

/** Draws path data `d` into the svg element, fitted to it. */
export function drawShape(svg, d) {
  svg.replaceChildren();
  const path = document.createElementNS(SVG_NS, 'path');
  path.setAttribute('d', d);
  path.setAttribute('class', 'shape2d');
  path.setAttribute('fill-rule', 'evenodd');
  svg.appendChild(path);
  const b = path.getBBox();
  const size = Math.max(b.width, b.height) || 1;
  const m = 0.08 * size;
  svg.setAttribute('viewBox', `${b.x - m} ${b.y - m} ${b.width + 2 * m} ${b.height + 2 * m}`);
  path.setAttribute('stroke-width', String(size / 300));
}

/** Draws the chosen source and target files (before any job); which ones were drawn. */
export async function previewPair(files, $, onError) {
  const previewed = { source: false, target: false };
  for (const [k, side] of [[0, 'source'], [1, 'target']]) {
    const svg = $(`corr-${side}`);
    svg.replaceChildren();
    if (!files[k]) continue;
    try {
      drawShape(svg, (await shapePathData(files[k])).d);
      previewed[side] = true;
    } catch (e) {
      onError(e);
    }
  }
  return previewed;
}
