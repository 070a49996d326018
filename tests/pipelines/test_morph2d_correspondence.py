"""Tests of conformorph.pipelines.morph2d.correspondence: automatic anchors and the working resolution."""

from dataclasses import replace

import numpy as np
import pytest

from conformorph.geometry.shape_rings import validate_rings
from conformorph.pipelines.morph2d import (
    DEFAULT_POINT_BUDGET,
    Morph2DInputs,
    corresponding_anchors,
    working_resolution,
)

SQUARE = validate_rings([np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])])
WIDE = validate_rings([np.array([[0.0, 0], [2, 0], [2, 1], [0, 1]])])
T = np.linspace(0, 2 * np.pi, 300, endpoint=False)
CIRCLE = validate_rings([np.c_[np.cos(T), np.sin(T)]])


def _inputs(source, target, anchors, role):
    return Morph2DInputs(
        source, target, np.asarray(anchors, float).reshape(-1, 2, 2), [], None, role
    )


def test_a_users_full_list_is_kept_as_given():
    a = [[[0, 0], [0, 0]], [[1, 1], [2, 1]]]
    out = corresponding_anchors(_inputs(SQUARE, WIDE, a, "user"))
    assert out.document is None and out.info == {"source": "user", "pairs": 2, "user_pairs": 2}
    np.testing.assert_array_equal(out.inputs.anchors, a)


def test_automatic_anchors_pair_the_corners():
    out = corresponding_anchors(_inputs(SQUARE, WIDE, [], "seeds"))
    assert out.info["source"] == "automatic" and out.info["pairs"] == len(out.inputs.anchors) >= 2
    # every corner of the square goes to a corner of the rectangle, scaled by (2, 1)
    A = out.inputs.anchors
    np.testing.assert_allclose(A[:, 1], A[:, 0] * [2, 1], atol=1e-12)
    assert out.document is not None and len(out.document["anchors"]) == len(A)


def test_seeds_come_first_exactly():
    seed = [[[1.0, 0.0], [2.0, 0.0]]]
    out = corresponding_anchors(_inputs(SQUARE, WIDE, seed, "seeds"))
    assert out.info["source"] == "seeded" and out.info["origin"][0] == "seed"
    np.testing.assert_array_equal(out.inputs.anchors[0], seed[0])
    assert out.document is not None and out.document["anchors"][0] == seed[0]


def test_working_resolution_keeps_the_anchors_within_the_budget():
    a = np.array([[[1.0, 0.0], [1.0, 0.0]], [[np.cos(T[77]), np.sin(T[77])]] * 2])
    inp = _inputs(CIRCLE, CIRCLE, a, "seeds")
    out, info = working_resolution(inp, 30)
    assert info["point_budget"] == 30 and info["source_points"] == [300, len(out.source.outer)]
    assert len(out.source.outer) <= 30 and len(out.target.outer) <= 30
    for side, shape in ((0, out.source), (1, out.target)):
        for p in a[:, side]:
            assert np.min(np.linalg.norm(shape.outer - p, axis=1)) == 0.0
    # None: the default on the automatic path, and for a user's full list on rings of
    # different lengths; nothing for a user's full list on rings of equal lengths
    # (vertex i <-> vertex i may be the user's correspondence)
    assert working_resolution(inp, None)[1]["point_budget"] == DEFAULT_POINT_BUDGET
    same, info = working_resolution(replace(inp, anchor_role="user"), None)
    assert same.source is CIRCLE and info["point_budget"] is None
    oval = validate_rings([np.c_[np.cos(T[::2]), 0.5 * np.sin(T[::2])]])
    a_oval = np.array([[[1.0, 0.0], [1.0, 0.0]], [[-1.0, 0.0], [-1.0, 0.0]]])
    user = _inputs(CIRCLE, oval, a_oval, "user")
    cut, info = working_resolution(user, None)
    assert info["point_budget"] == DEFAULT_POINT_BUDGET and len(cut.source.outer) <= 100
    assert info["source_points"] == [300, len(cut.source.outer)]
    assert info["target_points"] == [150, len(cut.target.outer)]
    assert working_resolution(replace(inp, file_point_budget=40), None)[1]["point_budget"] == 40
    assert working_resolution(inp, 0)[0].source is CIRCLE


def test_a_budget_below_the_protected_points_is_tagged():
    with pytest.raises(ValueError) as e:
        working_resolution(_inputs(SQUARE, WIDE, [[[0, 0], [0, 0]], [[1, 1], [2, 1]]], "seeds"), 3)
    assert e.value.conformorph_field == "point_budget"  # type: ignore[attr-defined]


def test_point_budget_maps_from_the_flag_and_the_job_params():
    import argparse

    from conformorph.cli.cmd_morph2d import morph2d_options_from_args
    from conformorph.worker.stages.morph2d import morph2d_options_from_params

    assert morph2d_options_from_params({}).point_budget is None
    assert morph2d_options_from_params({"point_budget": "40"}).point_budget == 40
    args = argparse.Namespace(
        frames=5, interp="modified", pace="strain", per_frame=False, max_points=99,
        max_iterations=None, max_continuation=None, max_substeps=None, max_time_step=None,
        point_budget=0,
    )  # fmt: skip
    assert morph2d_options_from_args(args).point_budget == 0
    with pytest.raises(ValueError, match="--point-budget"):
        morph2d_options_from_args(argparse.Namespace(**{**vars(args), "point_budget": 1}))
