"""The landmark file written by ``conformorph landmarks``: the layout ``conformorph morph
--landmarks`` reads, plus the detector's confidence and warnings.

::

    {"landmarks": [[[x, y, z], ...68], ...],    # surface points, one list per mesh
     "layout": "multipie68_0based",
     "meshes": ["a.obj", ...],
     "vertex_ids": [[...68], ...],              # nearest corner of each landmark's triangle
     "triangles": [[...68], ...], "barycentric": [[[a, b, c], ...68], ...],
     "confidence": [[...68], ...],              # in [0, 1]
     "warnings": [["...", ...], ...],           # per mesh
     "detector": {...}}

:func:`conformorph.pipelines.landmark_document.parse_landmark_json` reads the ``landmarks``
key and ignores the others.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection.detect import DetectedLandmarks


def landmark_file_document(
    results: Sequence[DetectedLandmarks], mesh_names: Sequence[str], detector: dict[str, Any]
) -> dict[str, Any]:
    """The JSON document of detected landmarks, one entry per mesh in input order.

    Parameters
    ----------
    results : sequence of DetectedLandmarks
    mesh_names : sequence of str
    detector : dict
        Stored under ``detector`` (name, version, table, timings).
    """

    def rows(a: NDArray[Any], nd: int = 9) -> list[Any]:
        return np.round(a, nd).tolist() if a.dtype.kind == "f" else a.tolist()

    return {
        "landmarks": [rows(r.points, 12) for r in results],
        "layout": "multipie68_0based",
        "meshes": list(mesh_names),
        "vertex_ids": [rows(r.vertex) for r in results],
        "triangles": [rows(r.triangle) for r in results],
        "barycentric": [rows(r.barycentric, 12) for r in results],
        "confidence": [rows(r.confidence, 4) for r in results],
        "warnings": [list(r.warnings) for r in results],
        "detector": {**detector, "score": [round(r.score, 4) for r in results]},
    }


def write_preview(result: DetectedLandmarks, path: str | Path) -> None:
    """A PNG of the final render with the 68 landmarks: green confident, red not (< 0.5)."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(result.view.render.rgb())
    draw = ImageDraw.Draw(img)
    for (x, y), c in zip(result.pixels, result.confidence, strict=True):
        colour = (0, 200, 0) if c >= 0.5 else (230, 0, 0)
        draw.ellipse([x - 2.5, y - 2.5, x + 2.5, y + 2.5], outline=colour, width=1)
    img.save(path)
