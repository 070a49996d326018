"""The icon-pair corpus of ``benchmarks/bench_icons.py`` (issue 28): random pairs from npm icon sets.

Icon sets (pinned in ``benchmarks/package.json``; installed into a folder of the
benchmark's own, never the repository's ``node_modules``):

* ``heroicons`` 2.2.0 (MIT): ``24/solid`` (filled, holes as ``fill-rule="evenodd"``
  sub-paths) and ``24/outline`` (stroked, ``fill="none"``);
* ``simple-icons`` 16.37.0 (CC0): brand logos, one filled path of many sub-paths;
* ``lucide-static`` 1.87.0 (ISC): stroked lines, circles and rects.

Each icon is put in one category by its geometry alone (never by how any morph
does on it), read with svgelements and shapely:

* ``strokes``: drawn with a stroke and no fill (lucide, heroicons outline);
* filled icons, their sub-paths flattened to rings and nested by containment:
  ``outline`` one ring; ``holes`` one outer ring with rings inside it;
  ``parts`` two or more outer rings (with or without holes).

Filled categories draw from heroicons solid and simple-icons, ``strokes`` from
lucide and heroicons outline. A pair is two different icons of one category.

Split before tuning: the tuning pairs are drawn with :data:`TUNING_SEED`, the
report pairs with :data:`REPORT_SEED` from the icons the tuning pairs do not
use; both seeds were fixed in this file before any pair was looked at. Report
only the report split.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Seed of the tuning split (look at, tune on).
TUNING_SEED = 20_261_207
#: Seed of the report split (report only; never tune on it).
REPORT_SEED = 28_100_028
#: The categories, in report order.
CATEGORIES = ("outline", "holes", "parts", "strokes")
#: Folders (inside the npm folder's node_modules) each category draws from.
POOLS = {
    "outline": ("heroicons/24/solid", "simple-icons/icons"),
    "holes": ("heroicons/24/solid", "simple-icons/icons"),
    "parts": ("heroicons/24/solid", "simple-icons/icons"),
    "strokes": ("lucide-static/icons", "heroicons/24/outline"),
}
#: Points per curve segment when classifying (enough to nest rings correctly).
_SAMPLES = 12


@dataclass(frozen=True)
class IconPair:
    """One drawn pair: its category, the split it belongs to and the two SVG files."""

    category: str
    split: str
    source: Path
    target: Path

    @property
    def name(self) -> str:
        return f"{self.source.parent.name}/{self.source.stem} -> {self.target.parent.name}/{self.target.stem}"


def _paint_none(value: object) -> bool:
    return (
        value is None
        or str(value).lower() in ("none", "transparent")
        or getattr(value, "value", 1) is None
    )


def icon_category(svg_file: Path) -> str | None:
    """The category of one icon (see the module), or None when it cannot be read.

    Parameters
    ----------
    svg_file : Path

    Returns
    -------
    str or None
        One of :data:`CATEGORIES`.
    """
    import svgelements as se
    from shapely.geometry import Point, Polygon

    try:
        svg = se.SVG.parse(str(svg_file))
        shapes = [e for e in svg.elements() if isinstance(e, se.Shape)]
    except Exception:
        return None
    if not shapes:
        return None
    if any(_paint_none(s.fill) and not _paint_none(s.stroke) for s in shapes):
        return "strokes"
    rings = []
    for s in shapes:
        for sub in se.Path(s).as_subpaths():
            pts = []
            for seg in sub:
                if isinstance(seg, se.Move):
                    continue
                pts.extend(np.asarray(seg.npoint(np.linspace(0, 1, _SAMPLES))).tolist())
            poly = Polygon(pts) if len(pts) >= 3 else None
            if poly is not None and poly.area > 0:
                ring = poly if poly.is_valid else poly.buffer(0)
                if not ring.is_empty:  # buffer(0) of a degenerate ring can be empty
                    rings.append(ring)
    if not rings:
        return None
    depth = []
    for i, r in enumerate(rings):
        p = r.representative_point()
        depth.append(
            sum(
                1
                for j, o in enumerate(rings)
                if j != i and o.area > r.area and o.contains(Point(p.x, p.y))
            )
        )
    outer = sum(d % 2 == 0 for d in depth)
    if outer >= 2:
        return "parts"
    return "holes" if len(rings) > 1 else "outline"


def _draw(
    npm_dir: Path, seed: int, per_category: int, split: str, exclude: set[Path]
) -> list[IconPair]:
    rng = random.Random(seed)
    modules = npm_dir / "node_modules"
    pairs: list[IconPair] = []
    for cat in CATEGORIES:
        files = sorted(f for d in POOLS[cat] for f in (modules / d).glob("*.svg"))
        rng.shuffle(files)
        picked: list[Path] = []
        for f in files:
            if len(picked) == 2 * per_category:
                break
            if f not in exclude and icon_category(f) == cat:
                picked.append(f)
        if len(picked) < 2 * per_category:
            raise RuntimeError(f"only {len(picked)} {cat} icons for {per_category} pairs")
        pairs += [
            IconPair(cat, split, picked[2 * k], picked[2 * k + 1]) for k in range(per_category)
        ]
    return pairs


def icon_pairs(
    npm_dir: Path, split: str, per_category: int, tuning_per_category: int = 5
) -> list[IconPair]:
    """The pairs of one split.

    Parameters
    ----------
    npm_dir : Path
        The folder the icon sets are installed in (``node_modules`` inside it).
    split : {"tuning", "report"}
    per_category : int
        Pairs per category of the split asked for.
    tuning_per_category : int, optional
        Pairs per category of the tuning split, whose icons the report split
        never uses (default 5).

    Returns
    -------
    list of IconPair
        ``per_category`` pairs of each category in :data:`CATEGORIES` order.
    """
    if split not in ("tuning", "report"):
        raise ValueError(f"split must be 'tuning' or 'report', got {split!r}")
    tuning = _draw(
        npm_dir,
        TUNING_SEED,
        tuning_per_category if split == "report" else per_category,
        "tuning",
        set(),
    )
    if split == "tuning":
        return tuning
    used = {p.source for p in tuning} | {p.target for p in tuning}
    return _draw(npm_dir, REPORT_SEED, per_category, "report", used)
