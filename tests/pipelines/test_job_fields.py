"""The jobs' shared ranges and defaults (conformorph.pipelines.job_fields), and the
entry points that read them: every one refuses the same values and defaults alike."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines import job_fields
from conformorph.pipelines.job_fields import (
    FieldRangeError,
    check_confidence,
    check_frame_times,
    check_key_times,
    check_morph_times,
)

#: values that passed every check before and crashed the job (issue 30, item 7)
HOSTILE_TIMES = [
    ({"times": [0, 1e308]}, "times[1]"),
    ({"times": [0, 1e-320]}, "times"),
    ({"times": [0, float("inf")]}, "times[1]"),
    ({"times": [1e8, 1e8 + 1e-2]}, "times"),
    ({"times": [0, 0.5, 0.5 + 1e-9]}, "times[2]"),
    ({"frame_times": [-1e6, 1e6]}, "frame_times[0]"),
    ({"frame_times": [0, 1e308]}, "frame_times[1]"),
    ({"frame_times": [0, 2.5]}, "frame_times[1]"),
    ({"frame_times": [0, 0.5, 0.5]}, "frame_times[2]"),
    ({"frame_times": [0, 1e-12]}, "frame_times[1]"),
]


@pytest.mark.parametrize(("fields", "where"), HOSTILE_TIMES)
def test_hostile_times_are_refused_naming_the_entry(fields: dict, where: str) -> None:
    with pytest.raises(FieldRangeError) as info:
        check_morph_times(
            fields.get("times"), fields.get("frame_times"), len(fields.get("times", [0, 1]))
        )
    assert info.value.field == where and info.value.code == "out_of_range"
    assert isinstance(info.value, ValueError)  # the CLI's exit code 2


def test_well_posed_times_pass() -> None:
    check_key_times([0.0, 1.0], 2)
    check_key_times([-5.0, 0.0, 1e-3, 7.0], 4)
    check_key_times([0.0, 1e-6], 2)  # the smallest span
    check_key_times([1e6, 1e6 + 1.0], 2)
    check_frame_times([-1.0, 0.0, 0.5, 2.0], [0.0, 1.0])  # one span out either way (Table 4)
    check_frame_times([-0.5, 1.5], [0.0, 1.0])
    check_morph_times(None, None, 3)
    check_morph_times(None, [0.0, 2.0, 4.0], 3)  # default key times 0 … 2: span 2


def test_key_count_and_empty_frame_times() -> None:
    with pytest.raises(FieldRangeError, match="needs 3 values"):
        check_key_times([0, 1], 3)
    with pytest.raises(FieldRangeError, match="at least one"):
        check_frame_times([], [0, 1])
    with pytest.raises(FieldRangeError) as info:
        check_key_times([0, True], 2)  # a JSON true is not a number
    assert info.value.field == "times[1]"


def test_confidence_shape_and_range() -> None:
    check_confidence([[0.0, 0.5, 1.0], [1, 1, 1]], [3, 3])
    cases = [
        ([[0.0, 0.5, 1.5], [1, 1, 1]], "confidence[0][2]"),
        ([[0.0, 0.5, -0.1], [1, 1, 1]], "confidence[0][2]"),
        ([[0.0, 0.5, float("nan")], [1, 1, 1]], "confidence[0][2]"),
        ([[0.0, 0.5], [1, 1, 1]], "confidence[0]"),
        ([[0.0, 0.5, 1.0]], "confidence"),
        ("high", "confidence"),
        ([[0.0, 0.5, 1.0], [1, "x", 1]], "confidence[1][1]"),
    ]
    for value, where in cases:
        with pytest.raises(FieldRangeError) as info:
            check_confidence(value, [3, 3])
        assert info.value.field == where, value


def test_landmark_documents_check_confidence_and_point_range() -> None:
    from conformorph.pipelines.landmark_document import LandmarkRangeError, parse_landmark_json

    lm = [[0, 1, 2], [0, 1, 2]]
    parse_landmark_json({"landmarks": lm, "confidence": [[1, 0.5, 0], [1, 1, 1]]}, 2)
    for conf, where in (
        ([[1, 0.5, 2], [1, 1, 1]], "confidence[0][2]"),
        ([[1, 0.5], [1, 1]], "confidence[0]"),
        ([[1, 1, 1]], "confidence"),
    ):
        with pytest.raises(LandmarkRangeError) as info:
            parse_landmark_json({"landmarks": lm, "confidence": conf}, 2)
        assert info.value.field == where and info.value.code == "out_of_range"
    # a shared list fixes no mesh count: any number of rows, each one value per landmark
    parse_landmark_json({"nearest_vertex_0based": [0, 1, 2], "confidence": [[1, 1, 1]] * 3}, 2)
    with pytest.raises(LandmarkRangeError):
        parse_landmark_json({"nearest_vertex_0based": [0, 1, 2], "confidence": [[1, 1]]}, 2)
    with pytest.raises(LandmarkRangeError) as info:
        parse_landmark_json({"landmarks": [[0, 1, [1e300, 0, 0]], [0, 1, 2]]}, 2)
    assert info.value.field == "landmarks[0][2]"


def test_shapes_with_extreme_coordinates_are_refused(tmp_path: Path) -> None:
    from conformorph.pipelines.shape_io import ShapeRangeError, parse_shape

    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    assert len(parse_shape(json.dumps({"rings": [square]}), ".json", "s")) == 1
    big = [[x * 1e300, y * 1e300] for x, y in square]
    with pytest.raises(ShapeRangeError, match="magnitude"):
        parse_shape(json.dumps({"rings": [big]}), ".json", "s")
    far = [[x + 1e11, y] for x, y in square]  # 1 wide at 1e11: 1e-11 of its magnitude
    with pytest.raises(ShapeRangeError, match="extent"):
        parse_shape(json.dumps({"rings": [far]}), ".json", "s")
    with pytest.raises(ShapeRangeError):
        parse_shape("M 0 0 L 1e300 0 L 1e300 1e300 Z", ".svg", "s")
    scaled = [[x * 1e9, y * 1e9] for x, y in square]  # large but honoured
    assert np.abs(parse_shape(json.dumps({"rings": [scaled]}), ".json", "s")[0]).max() == 1e9


def test_defaults_are_defined_once() -> None:
    """The API's models, the client's copy, the CLI's flags and the pipelines' options
    read their defaults from job_fields (issue 27: the API's morph defaulted prepare none)."""
    import argparse

    from conformorph.cli import cmd_map, cmd_morph
    from conformorph.pipelines.face_morph.options import DEFAULT_LANDMARK_FIT_CHOICE
    from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET
    from conformorph.service import schemas
    from conformorph_client import _schemas

    assert job_fields.MORPH_PREPARE_DEFAULT == "auto" and job_fields.VERTEX_BUDGET_DEFAULT == 50_000
    for mod in (schemas, _schemas):
        body = mod.MorphCreate(meshes=["0" * 32, "1" * 32], landmarks="auto")
        assert body.prepare == job_fields.MORPH_PREPARE_DEFAULT
        assert body.vertex_budget == job_fields.VERTEX_BUDGET_DEFAULT
        assert body.landmark_fit == job_fields.LANDMARK_FIT_DEFAULT
        assert mod.ConformalMapCreate(mesh="0" * 32).prepare == job_fields.MAP_PREPARE_DEFAULT
    assert DEFAULT_VERTEX_BUDGET == job_fields.VERTEX_BUDGET_DEFAULT
    assert DEFAULT_LANDMARK_FIT_CHOICE == job_fields.LANDMARK_FIT_DEFAULT
    for mod, cmd, prepare in (
        (cmd_morph, "morph", job_fields.MORPH_PREPARE_DEFAULT),
        (cmd_map, "map", job_fields.MAP_PREPARE_DEFAULT),
    ):
        parser = argparse.ArgumentParser()
        mod.register(parser.add_subparsers())
        argv = (
            [cmd, "a.obj", "b.obj", "--landmarks", "x", "-o", "o"]
            if cmd == "morph"
            else [cmd, "a.obj", "-o", "o"]
        )
        args, _ = parser.parse_known_args(argv)
        assert args.prepare == prepare and args.vertex_budget == job_fields.VERTEX_BUDGET_DEFAULT


def test_client_checks_the_same_ranges_before_sending() -> None:
    from conformorph_client import _calls

    with pytest.raises(ValueError, match=r"times"):
        _calls.create_morph(["0" * 32, "1" * 32], landmarks="auto", times=[0, 1e308])
    with pytest.raises(ValueError, match=r"frame_times\[0\]"):
        _calls.create_morph(["0" * 32, "1" * 32], landmarks="auto", frame_times=[-1e6, 1e6])
    call = _calls.create_morph(["0" * 32, "1" * 32], landmarks="auto", frame_times=[0, 0.5, 1.5])
    assert call is not None
