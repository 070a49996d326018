"""Reading and pairing the inputs of the 2D morph: two shapes, anchors, dissection paths, texture.

Every input is checked before any numerics; an error carries the input it
concerns as ``conformorph_field`` ("source", "target", "anchors",
"anchors[i][side]", "paths[k]", "texture").
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import PathError, ShapeRings, check_anchors, validate_rings
from conformorph.pipelines.morph2d.errors import TextureError, tag_field
from conformorph.pipelines.shape_io import (
    DEFAULT_MAX_POINTS,
    ShapeDocument,
    parse_anchor_paths,
    read_anchor_paths,
    read_anchors,
    read_shape_parts,
)

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@dataclass(frozen=True)
class Morph2DInputs:
    """The checked inputs of one 2D morph.

    Attributes
    ----------
    source, target : ShapeRings
        Validated shapes (orientation fixed, see ``ShapeRings.fixes``).
    anchors : (a, 2, 2) float64
        Anchor pairs ``[source point, target point]``; the first two are the
        reference points A, B of the rigid-motion removal.
    paths : list of list of int
        Dissection paths (anchor indices), possibly empty.
    texture : bytes or None
        The PNG texture, checked.
    anchor_role : {"user", "seeds"}
        ``"user"``: ``anchors`` are the user's full list, used as they are;
        ``"seeds"``: no anchors file, or one with fewer than two pairs or
        ``"partial": true``: ``anchors`` (possibly none) seed the automatic
        matching (:mod:`conformorph.pipelines.morph2d.correspondence`).
    file_point_budget : int or None
        The anchors file's ``"point_budget"`` (written by the automatic
        matching so that passing the file back gives the same meshes).
    """

    source: ShapeRings
    target: ShapeRings
    anchors: NDArray[np.float64]
    paths: list[list[int]]
    texture: bytes | None
    anchor_role: str = "user"
    file_point_budget: int | None = None


def read_texture_png(path: str | Path) -> bytes:
    """The bytes of a PNG texture, checked (signature and a full decode) before any numerics.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bytes

    Raises
    ------
    TextureError
        If the file is not a PNG image Pillow can decode.
    OSError
        If the file cannot be read.
    """
    from PIL import Image, UnidentifiedImageError

    data = Path(path).read_bytes()
    name = Path(path).name
    if not data.startswith(_PNG_SIGNATURE):
        raise TextureError(f"{name}: the texture must be a PNG image (no PNG signature)")
    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise TextureError(f"{name}: not a readable PNG image ({exc})") from exc
    return data


def read_texture(path: str | Path | None) -> bytes | None:
    """:func:`read_texture_png` of ``path`` (None without one), its errors tagged "texture"."""
    try:
        return read_texture_png(path) if path is not None else None
    except (ValueError, OSError) as exc:
        raise tag_field(exc, "texture") from None


def read_morph2d_inputs(
    source_path: str | Path,
    target_path: str | Path,
    anchors_path: str | Path | None,
    texture_path: str | Path | None = None,
    max_points: int = DEFAULT_MAX_POINTS,
    docs: tuple[ShapeDocument, ShapeDocument] | None = None,
) -> Morph2DInputs:
    """Read both shapes, the anchors (paired: each inside its shape) and the texture.

    Parameters
    ----------
    source_path, target_path : str or Path
        Shape files (JSON rings or SVG path data), see :mod:`conformorph.pipelines.shape_io`.
    anchors_path : str or Path or None
        Anchors JSON, optionally with dissection ``paths``; None (or a file
        with fewer than two pairs, or ``"partial": true``): the anchors seed
        the automatic matching (``anchor_role`` "seeds").
    texture_path : str or Path, optional
        A PNG image.
    max_points : int, optional
        Most points per shape.
    docs : (ShapeDocument, ShapeDocument), optional
        The shapes already read (:func:`read_shape_documents`), one part each.

    Returns
    -------
    Morph2DInputs

    Raises
    ------
    ShapeError (and subclasses), ValueError, OSError
        Tagged with the input they concern.
    """
    if docs is None:
        docs = read_shape_documents(source_path, target_path, max_points)
    shapes = []
    for field, doc in zip(("source", "target"), docs, strict=True):
        try:
            if len(doc.parts) != 1:
                raise ValueError(f"the {field} shape has {len(doc.parts)} parts; one is read here")
            shapes.append(validate_rings(doc.parts[0]))
        except ValueError as exc:
            raise tag_field(exc, field) from None
    source, target = shapes
    role, budget = "seeds", None
    try:
        if anchors_path is None:
            anchors, paths = np.zeros((0, 2, 2)), []
        else:
            anchors = read_anchors(anchors_path, min_pairs=0)
            role, budget, raw_paths = _anchor_role(anchors_path, len(anchors))
            check_anchors(source, target, anchors)
            if role == "user":
                paths = read_anchor_paths(anchors_path)
            else:
                where = f"{Path(anchors_path).name}: paths"
                paths = parse_anchor_paths(raw_paths, len(anchors), where)
    except PathError as exc:
        raise tag_field(exc, f"paths[{exc.index}]") from None
    except ValueError as exc:
        index, side = getattr(exc, "index", None), getattr(exc, "side", None)
        raise tag_field(
            exc, "anchors" if index is None or side is None else f"anchors[{index}][{side}]"
        ) from None
    texture = read_texture(texture_path)
    return Morph2DInputs(source, target, anchors, paths, texture, role, budget)


def read_shape_documents(
    source_path: str | Path, target_path: str | Path, max_points: int = DEFAULT_MAX_POINTS
) -> tuple[ShapeDocument, ShapeDocument]:
    """Both shape files read as parts (:func:`conformorph.pipelines.shape_io.read_shape_parts`).

    Parameters
    ----------
    source_path, target_path : str or Path
    max_points : int, optional

    Returns
    -------
    (ShapeDocument, ShapeDocument)

    Raises
    ------
    ShapeError, ValueError, OSError
        Tagged "source" or "target".
    """
    docs = []
    for field, path in (("source", source_path), ("target", target_path)):
        try:
            docs.append(read_shape_parts(path, max_points=max_points))
        except ValueError as exc:
            raise tag_field(exc, field) from None
    return docs[0], docs[1]


def _anchor_role(path: str | Path, pairs: int) -> tuple[str, int | None, object]:
    """``("user" or "seeds", the file's point_budget, its "paths")`` of an anchors file
    already read (and so of bounded size)."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    budget = data.get("point_budget")
    if budget is not None and (
        not isinstance(budget, int) or isinstance(budget, bool) or budget < 0
    ):
        raise ValueError(f"point_budget must be a non-negative integer, got {budget!r}")
    partial = data.get("partial") is True or pairs < 2
    return ("seeds" if partial else "user"), budget, data.get("paths")
