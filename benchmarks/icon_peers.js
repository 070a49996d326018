// The peers of benchmarks/bench_icons.py, run in headless Chromium (a real DOM: GSAP's
// MorphSVGPlugin measures and converts SVG elements). The page loads, before this file,
// flubber (build/flubber.min.js), gsap + MorphSVGPlugin (dist/*.min.js) and polymorph-js
// (dist/polymorph.min.js) from the benchmark's npm folder (benchmarks/package.json).
//
// iconPeers.pathData(svgText): the icon's whole geometry as one path `d` (every <path>,
//   <circle>, <rect>, <ellipse>, <line>, <polyline>, <polygon> converted by
//   MorphSVGPlugin.convertToPath, their `d` joined), as a user hands a shape to these tools.
// iconPeers.size(svgText): the larger side of the icon's viewBox (or width/height).
// iconPeers.run(a, b, count, size): each peer from path data `a` to `b`, with its defaults
//   except the two that depend on the drawing's size, set relative to `size` as their
//   defaults are to a drawing of a few hundred units: flubber's maxSegmentLength size / 48
//   (its default 10 would cut a 24-unit icon's curves into 2 or 3 chords) and polymorph's
//   precision 3 decimals (its default 0 rounds a 24-unit icon to whole units);
//   per peer {ok, error, seconds, frames: [d at t = k / (count - 1)]}.

/* global flubber, gsap, MorphSVGPlugin, polymorph */
(function () {
  gsap.registerPlugin(MorphSVGPlugin);
  const NS = 'http://www.w3.org/2000/svg';

  function pathData(svgText) {
    const box = document.createElement('div');
    box.innerHTML = svgText;
    document.body.appendChild(box);
    try {
      const svg = box.querySelector('svg');
      const shapes = svg.querySelectorAll('circle, rect, ellipse, line, polyline, polygon');
      shapes.forEach((el) => MorphSVGPlugin.convertToPath(el));
      return Array.from(svg.querySelectorAll('path'))
        .map((p) => p.getAttribute('d') || '')
        .filter((d) => d.trim())
        .join(' ');
    } finally {
      box.remove();
    }
  }

  function size(svgText) {
    const box = document.createElement('div');
    box.innerHTML = svgText;
    const svg = box.querySelector('svg');
    const vb = svg.viewBox && svg.viewBox.baseVal;
    if (vb && vb.width > 0 && vb.height > 0) return Math.max(vb.width, vb.height);
    return Math.max(Number(svg.getAttribute('width')) || 0, Number(svg.getAttribute('height')) || 0) || 24;
  }

  function timed(make, count) {
    const t0 = performance.now();
    try {
      const at = make();
      const frames = [];
      for (let k = 0; k < count; k++) frames.push(String(at(k / (count - 1))));
      return { ok: true, error: null, seconds: (performance.now() - t0) / 1000, frames };
    } catch (e) {
      return { ok: false, error: String((e && e.message) || e), seconds: (performance.now() - t0) / 1000, frames: [] };
    }
  }

  function gsapMorph(a, b) {
    const svg = document.createElementNS(NS, 'svg');
    const path = document.createElementNS(NS, 'path');
    path.setAttribute('d', a);
    svg.appendChild(path);
    document.body.appendChild(svg);
    const tween = gsap.to(path, { morphSVG: b, duration: 1, ease: 'none', paused: true });
    return (t) => {
      tween.progress(t);
      return path.getAttribute('d');
    };
  }

  function run(a, b, count, size) {
    const out = {
      flubber: timed(() => flubber.interpolate(a, b, { maxSegmentLength: size / 48 }), count),
      gsap: timed(() => gsapMorph(a, b), count),
      polymorph: timed(() => polymorph.interpolate([a, b], { precision: 3 }), count),
    };
    document.querySelectorAll('body > svg').forEach((s) => s.remove());
    return out;
  }

  window.iconPeers = { pathData, size, run };
})();
