"""``run_morph2d`` for shapes of several parts (:mod:`conformorph.pipelines.morph2d.part_morph`)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.morph_metrics_2d import morph_metrics_2d
from conformorph.geometry.shape_rings import ShapeRings, validate_rings
from conformorph.pipelines.glb_placement import GlbPlacement
from conformorph.pipelines.morph2d.errors import tag_field
from conformorph.pipelines.morph2d.inputs import read_texture
from conformorph.pipelines.morph2d.metrics import baseline_metrics
from conformorph.pipelines.morph2d.options import Morph2DOptions
from conformorph.pipelines.morph2d.outputs import write_metrics_json, write_morph2d_outputs
from conformorph.pipelines.morph2d.part_morph import morph_parts, with_parts_pace
from conformorph.pipelines.outline_anchors import parts_anchors_document, write_anchors_document
from conformorph.pipelines.shape_io import MAX_ANCHORS, ShapeDocument, read_anchors


def validated_parts(doc: ShapeDocument, field: str) -> list[ShapeRings]:
    """Every part of a shape document validated (orientation repaired), errors tagged."""
    try:
        return [validate_rings(rings) for rings in doc.parts]
    except ValueError as exc:
        raise tag_field(exc, field) from None


def _anchors(path: str | Path | None) -> tuple[NDArray[np.float64], NDArray[np.int64] | None]:
    """Anchors (possibly none) and their optional per-anchor ``parts`` key."""
    if path is None:
        return np.zeros((0, 2, 2)), None
    try:
        anchors = read_anchors(path, min_pairs=0)
        raw = json.loads(Path(path).read_text(encoding="utf-8")).get("parts")
        if raw is None:
            return anchors, None
        parts = np.asarray(raw)
        if (
            len(raw) > MAX_ANCHORS
            or parts.shape != (anchors.shape[0], 2)
            or parts.dtype.kind not in "iu"
        ):
            raise ValueError(
                "anchors file: 'parts' must list [source part, target part] for every anchor"
            )
        return anchors, parts.astype(np.int64)
    except ValueError as exc:
        raise tag_field(exc, "anchors") from None


def run_morph2d_parts(
    docs: tuple[ShapeDocument, ShapeDocument],
    paths: tuple[str | Path, str | Path],
    anchors_path: str | Path | None,
    outdir: str | Path,
    opts: Morph2DOptions,
    texture_path: str | Path | None,
    t_start: float,
    failures: dict[tuple[int, int], str] | None = None,
) -> dict[str, Any]:
    """Morph two shapes of which at least one has several parts; write the outputs.

    Parameters
    ----------
    docs : (ShapeDocument, ShapeDocument)
        The shapes as read.
    paths : (str or Path, str or Path)
        Their files (for ``metrics.json``).
    anchors_path : str or Path or None
        Anchors (seeds of the pair they fall in), optionally with ``"parts"``.
    outdir : str or Path
    opts : Morph2DOptions
    texture_path : str or Path or None
    t_start : float
    failures : dict, optional
        Part pairs known not to morph, with the reason (see ``morph_parts``).

    Returns
    -------
    dict
        The content of ``metrics.json``: as the one-part morph's, with
        ``parts`` (matching, per pair, crossing counts) and ``pace_used``
        "strain".
    """
    source = validated_parts(docs[0], "source")
    target = validated_parts(docs[1], "target")
    anchors, anchor_parts = _anchors(anchors_path)
    texture = read_texture(texture_path)
    try:
        morph = morph_parts(source, target, anchors, with_parts_pace(opts), anchor_parts, failures)
    except ValueError as exc:
        if getattr(exc, "conformorph_field", None) is None:
            raise tag_field(exc, "anchors") from None
        raise
    out = Path(outdir)
    outputs = write_morph2d_outputs(
        out,
        morph.frames,
        morph.F,
        morph.source_V,
        texture,
        opts.per_frame,
        morph.times,
        GlbPlacement(opts.units, opts.size),
        loop=opts.loop,
    )
    documents = [
        (int(i), int(j), p.document)
        for (i, j), p, info in zip(
            morph.matching.pairs, morph.pairs, morph.info["pairs"], strict=True
        )
        if p is not None and p.document is not None and not info["separated"]
    ]
    if documents:
        write_anchors_document(out / "anchors.json", parts_anchors_document(documents))
        outputs["anchors"] = "anchors.json"
    # a separated pair's target part grows to its full size: the last frame is the target
    reached = all(p["separated"] or p["reached_target"] for p in morph.info["pairs"])
    strain = morph_metrics_2d(morph.source_V, morph.F, morph.frames).as_dict()
    result: dict[str, Any] = {
        "source": str(paths[0]),
        "target": str(paths[1]),
        "frames": opts.frames,
        "interp": opts.interp,
        "interp_used": sorted(
            {p["interp_used"] for p in morph.info["pairs"] if "interp_used" in p}
        ),
        "pace": opts.pace,
        "pace_used": "strain",
        "frame_t": morph.times.tolist(),
        "reached_target": reached,
        "not_converged_reason": None
        if reached
        else "the strain morph did not reach the target for part pair(s) "
        + ", ".join(
            f"{p['source_part']} -> {p['target_part']}"
            for p in morph.info["pairs"]
            if not (p["reached_target"] or p["separated"])
        ),
        "parts": morph.info,
        "crossings": {
            k: morph.info[k]
            for k in (
                "self_crossing_frames",
                "overlapping_frames",
                "first_overlap",
                "worst_overlap_area",
            )
        },
        "mesh": {
            "vertices": int(morph.frames.shape[1]),
            "triangles": int(morph.F.shape[0]),
            # a kept pair is one component, a separated pair two, a lone part one
            "components": len(morph.info["pairs"])
            + sum(p["separated"] for p in morph.info["pairs"])
            + len(morph.matching.unmatched_source)
            + len(morph.matching.unmatched_target),
        },
        "methods": {
            "strain": strain,
            **baseline_metrics(morph.source_V, morph.target_V, morph.F, morph.times),
        },
        "outputs": outputs,
        "svg": {"source": list(docs[0].notes), "target": list(docs[1].notes)},
        "strokes_outlined": {"source": docs[0].stroked, "target": docs[1].stroked},
        "seconds": time.perf_counter() - t_start,
    }
    result["outputs"]["metrics"] = "metrics.json"
    write_metrics_json(out, result)
    return result
