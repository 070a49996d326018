"""Corresponding points of the two outlines when the user gives none or only a few (issue 18).

The paper takes corresponding anchor points as given. Without an anchors file
(or with a partial one, see :class:`conformorph.pipelines.morph2d.inputs.Morph2DInputs`),
:func:`corresponding_anchors` finds them: feature points of the two outer
rings matched by cyclic DP (:func:`conformorph.geometry.outline_correspondence.match_outlines`,
the user's anchors as seeds, kept exactly and first), holes paired by
position and size (:func:`conformorph.geometry.hole_pairing.pair_holes`, reported).
:func:`working_resolution` then simplifies each shape to a point budget that
keeps its features and every anchor (:func:`conformorph.geometry.outline_simplification.simplify_rings`),
so that the compatible meshes stay at a few hundred vertices. What was chosen
goes to ``anchors.json`` (the anchors-file format: edit it and pass it back)
and to ``metrics.json`` (``correspondence``, ``working_resolution``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.hole_pairing import pair_holes
from conformorph.geometry.outline_correspondence import OutlineMatch, match_outlines
from conformorph.geometry.outline_simplification import SimplifyOptions, simplify_rings
from conformorph.geometry.shape_rings import ShapeRings, check_anchors, validate_rings
from conformorph.pipelines.morph2d.errors import tag_field
from conformorph.pipelines.morph2d.inputs import Morph2DInputs
from conformorph.pipelines.outline_anchors import anchors_document

#: Points per shape (all rings together) of the working resolution when
#: ``point_budget`` is not set (with a user's full anchor list too, unless the
#: rings have the same lengths). Horse → star with the committed anchors: 2,673
#: vertices and 10–25 s at full resolution (1,078 horse points), 1,049 vertices
#: and ~6 s at 100 points, the target reached at 12 and 60 frames. Measured (no anchors file,
#: 60 frames): flubber horse (1078 points) -> heart meshes to 595 / 652 / 678 /
#: 805 vertices at 80 / 100 / 120 / 150 points, reaching the target at all but
#: 150; 100 leaves the other shared shapes (at most 98 points) as they are.
DEFAULT_POINT_BUDGET = 100


@dataclass(frozen=True)
class Correspondence:
    """The anchors the rest of the 2D morph takes, and how they were chosen.

    Attributes
    ----------
    inputs : Morph2DInputs
        The inputs with ``anchors`` (a, 2, 2) the full list (user anchors
        first, exactly as given).
    info : dict
        The ``correspondence`` section of ``metrics.json``: ``source``
        ("user", "automatic" or "seeded"), ``pairs``, ``user_pairs``, and
        on the automatic paths ``cost``, ``rotation``, ``origin`` (per pair)
        and ``hole_pairs``.
    document : dict or None
        The anchors-file document to write as ``anchors.json`` (None on the
        user path).
    """

    inputs: Morph2DInputs
    info: dict[str, Any]
    document: dict[str, Any] | None


def corresponding_anchors(inputs: Morph2DInputs) -> Correspondence:
    """The anchors of the morph: the user's full list, or automatic matching seeded by the user's.

    Parameters
    ----------
    inputs : Morph2DInputs
        ``anchor_role`` "user": returned unchanged; "seeds": ``anchors``
        (a, 2, 2), a ≥ 0, seed :func:`conformorph.geometry.outline_correspondence.match_outlines`
        on the outer rings.

    Returns
    -------
    Correspondence
        Seed anchors first and unchanged, then the matched pairs in the
        matcher's order (its first two are the reference points A, B when
        fewer than two seeds are given).

    Raises
    ------
    ValueError
        Tagged "anchors": seeds the matcher cannot use (boundary seeds in
        different cyclic orders on the two outlines).
    """
    seeds = inputs.anchors
    if inputs.anchor_role == "user":
        info = {"source": "user", "pairs": len(seeds), "user_pairs": len(seeds)}
        return Correspondence(inputs, info, None)
    src, tgt = inputs.source, inputs.target
    try:
        match = match_outlines(src.outer, tgt.outer, seed_anchors=seeds if len(seeds) else None)
    except ValueError as exc:
        raise tag_field(exc, "anchors") from None
    match = _seeds_first(match, seeds)
    holes = pair_holes(
        list(src.holes),
        list(tgt.holes),
        source_outer=src.outer,
        target_outer=tgt.outer,
        rotation=match.rotation,
    )
    anchors = match.anchors
    check_anchors(src, tgt, anchors)
    info = {
        "source": "seeded" if len(seeds) else "automatic",
        "pairs": len(anchors),
        "user_pairs": len(seeds),
        "cost": float(match.cost),
        "rotation": float(match.rotation),
        "origin": list(match.origin),
        "hole_pairs": holes.pairs.tolist(),
        "unpaired_holes": {
            "source": holes.unpaired_source.tolist(),
            "target": holes.unpaired_target.tolist(),
        },
    }
    doc = anchors_document(match, holes)
    if inputs.paths:
        doc["paths"] = inputs.paths  # seed indices, unchanged: seeds come first
    return Correspondence(replace(inputs, anchors=anchors), info, doc)


def _seeds_first(match: OutlineMatch, seeds: NDArray[np.float64]) -> OutlineMatch:
    """``match`` reordered: each seed (in the user's order) first, then the other pairs."""
    pairs = match.anchors
    order: list[int] = []
    for s in seeds:
        hit = np.flatnonzero(np.all(np.isclose(pairs, s, rtol=0.0, atol=1e-12), axis=(1, 2)))
        free = [int(i) for i in hit if int(i) not in order]
        if not free:
            raise tag_field(ValueError("the matcher dropped a seed anchor"), "anchors")
        order.append(free[0])
    order += [i for i in range(len(pairs)) if i not in order]
    ix = np.asarray(order, dtype=np.int64)
    points = (pairs[ix, 0].copy(), pairs[ix, 1].copy())
    if len(seeds):
        points[0][: len(seeds)] = seeds[:, 0]  # exactly as given
        points[1][: len(seeds)] = seeds[:, 1]
    return replace(
        match,
        source_index=match.source_index[ix],
        target_index=match.target_index[ix],
        source_points=points[0],
        target_points=points[1],
        origin=tuple(match.origin[i] for i in order),
    )


def working_resolution(
    inputs: Morph2DInputs, point_budget: int | None
) -> tuple[Morph2DInputs, dict[str, Any]]:
    """Each shape simplified to at most ``point_budget`` points, features and anchors kept.

    Parameters
    ----------
    inputs : Morph2DInputs
        With the full anchor list (after :func:`corresponding_anchors`).
    point_budget : int or None
        Points per shape, all rings together; 0: no simplification; None:
        the anchors file's ``point_budget`` if any, else
        ``DEFAULT_POINT_BUDGET``, except for a user's full list on shapes
        whose rings have the same lengths (vertex i ↔ vertex i may be the
        user's correspondence, the "given" route of
        :func:`conformorph.pipelines.morph2d.compatible_meshes.compatible_meshes`),
        which are left as they are.

    Returns
    -------
    inputs : Morph2DInputs
        With simplified shapes (orientation fixes of the originals kept).
    info : dict
        The ``working_resolution`` section of ``metrics.json``:
        ``point_budget`` (None: not applied), ``source_points`` and
        ``target_points`` as ``[before, after]``, ``reached_budget``.

    Raises
    ------
    ValueError
        Tagged "point_budget": more protected points (anchors, features)
        than the budget.
    """
    budget = point_budget
    if budget is None:
        budget = inputs.file_point_budget
    if budget is None:
        budget = 0 if _maybe_given(inputs) else DEFAULT_POINT_BUDGET
    before = [_points(inputs.source), _points(inputs.target)]
    info: dict[str, Any]
    if budget == 0:
        info = {"point_budget": None, "source_points": [before[0]] * 2}
        info["target_points"] = [before[1]] * 2
        return inputs, info | {"reached_budget": True}
    shapes, reached = [], True
    for side, shape in enumerate((inputs.source, inputs.target)):
        try:
            out = simplify_rings(
                list(shape.rings),
                keep_points=inputs.anchors[:, side],
                options=SimplifyOptions(budget=budget),
            )
        except ValueError as exc:
            raise tag_field(exc, "point_budget") from None
        reached = reached and out.reached_budget
        shapes.append(replace(validate_rings(out.rings), fixes=shape.fixes))
    check_anchors(shapes[0], shapes[1], inputs.anchors)
    info = {
        "point_budget": budget,
        "source_points": [before[0], _points(shapes[0])],
        "target_points": [before[1], _points(shapes[1])],
        "reached_budget": reached,
    }
    return replace(inputs, source=shapes[0], target=shapes[1]), info


def _maybe_given(inputs: Morph2DInputs) -> bool:
    """A user's full anchor list on rings of the same lengths (possibly paired vertex by vertex)."""
    lengths = [[len(r) for r in shape.rings] for shape in (inputs.source, inputs.target)]
    return inputs.anchor_role == "user" and lengths[0] == lengths[1]


def _points(shape: ShapeRings) -> int:
    return sum(len(r) for r in shape.rings)
