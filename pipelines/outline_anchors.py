"""Automatic correspondences of two outlines as an anchors file a person can correct.

:func:`anchors_document` turns an :class:`conformorph.geometry.outline_correspondence.OutlineMatch`
(and optionally the hole pairs) into the structure that
:func:`conformorph.pipelines.shape_io.read_anchors` reads, ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``,
with a ``"note"`` saying how each pair was chosen; :func:`write_anchors_document`
writes it. Passing the file back (edited or not) makes the pairs user anchors,
which always win.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from conformorph.geometry.hole_pairing import HolePairs
from conformorph.geometry.outline_correspondence import OutlineMatch


def anchors_document(match: OutlineMatch, hole_pairs: HolePairs | None = None) -> dict[str, Any]:
    """The anchors-file structure of an automatic outline match.

    Parameters
    ----------
    match : OutlineMatch
        Pairs of boundary points (first two: the reference points A, B).
    hole_pairs : HolePairs, optional
        Hole pairs, recorded under ``"hole_pairs"`` as ``[[source hole,
        target hole], ...]`` (indices among the holes, i.e. ring index - 1);
        informational: :func:`conformorph.pipelines.shape_io.read_anchors` ignores the key.

    Returns
    -------
    dict
        ``{"note": str, "anchors": [[[xs, ys], [xt, yt]], ...]}`` (and
        ``"hole_pairs"``), JSON-ready.
    """
    parts = [
        f"{k}: {o} (source vertex {int(i)}, target vertex {int(j)})"
        for k, (o, i, j) in enumerate(
            zip(match.origin, match.source_index, match.target_index, strict=True)
        )
    ]
    note = (
        "chosen automatically by conformorph.geometry.outline_correspondence.match_outlines "
        f"(rotation {match.rotation:.4f} rad, reflected {match.reflected}, cost {match.cost:.4g}); "
        "vertex -1: a given point not at a vertex. Edit and pass back as the anchors file: "
        + "; ".join(parts)
    )
    doc: dict[str, Any] = {
        "note": note,
        "anchors": [
            [[float(a[0]), float(a[1])], [float(b[0]), float(b[1])]]
            for a, b in zip(match.source_points, match.target_points, strict=True)
        ],
    }
    if hole_pairs is not None:
        doc["hole_pairs"] = hole_pairs.pairs.tolist()
    return doc


def parts_anchors_document(documents: list[tuple[int, int, dict[str, Any]]]) -> dict[str, Any]:
    """One anchors document for a shape of several parts: each pair's anchors with its part pair.

    Parameters
    ----------
    documents : list of (int, int, dict)
        ``(source part, target part, document)`` per matched pair, each
        document as :func:`anchors_document` returns.

    Returns
    -------
    dict
        ``{"note", "anchors", "parts": [[source part, target part], ...]}``: the
        optional ``"parts"`` key gives each anchor's part pair (files without it
        keep working: each anchor then belongs to the parts that contain it).
        ``"partial": true``: passed back, the anchors seed each pair's matching.
    """
    anchors: list[Any] = []
    parts: list[list[int]] = []
    notes = []
    for i, j, doc in documents:
        anchors += doc["anchors"]
        parts += [[int(i), int(j)]] * len(doc["anchors"])
        notes.append(f"part {i} -> {j}: {doc['note']}")
    return {"note": " | ".join(notes), "anchors": anchors, "parts": parts, "partial": True}


def write_anchors_document(path: str | Path, document: dict[str, Any]) -> Path:
    """Write an anchors document as JSON.

    Parameters
    ----------
    path : str or Path
    document : dict
        As :func:`anchors_document` returns.

    Returns
    -------
    Path
        The file written.
    """
    out = Path(path)
    out.write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")
    return out
