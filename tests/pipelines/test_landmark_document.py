"""Landmark documents in pure Python: layouts, counts, and every entry checked with its place."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from conformorph.pipelines.landmark_document import (
    LandmarkCountMismatchError,
    LandmarkFormatError,
    LandmarkIndexError,
    TooFewLandmarksError,
    check_landmark_entry,
    document_mesh_count,
    parse_landmark_json,
    read_landmark_file,
)

CHOI = {
    "face1": {
        "interior_landmarks_0based": [1, 2, 3],
        "boundary_landmarks_0based_per_loop": [[7, 8, 9], [10, 11]],
    },
    "face2": {
        "interior_landmarks_0based": [4, 5, 6],
        "boundary_landmarks_0based_per_loop": [[1, 1, 1], [12, 13]],
    },
}


def test_layouts_and_mesh_counts() -> None:
    per_mesh = {"landmarks": [[0, 1, [0.5, 1, 2]], [3, 4, 5]]}
    assert document_mesh_count(per_mesh) == 2
    assert parse_landmark_json(per_mesh, 2) == [[0, 1, [0.5, 1.0, 2.0]], [3, 4, 5]]
    shared = {"nearest_vertex_0based": [1, 2, 3, 4], "note": "any other key is kept out"}
    assert document_mesh_count(shared) is None
    assert parse_landmark_json(shared, 3) == [[1, 2, 3, 4]] * 3
    # the interior landmarks and the inner loops' (not the outer loop's), faces in key order
    assert document_mesh_count(CHOI) == 2
    assert parse_landmark_json(CHOI, 2) == [[1, 2, 3, 10, 11], [4, 5, 6, 12, 13]]


def test_entries_are_normalised() -> None:
    assert check_landmark_entry(4, "x") == 4
    # JSON has one number type: 4.0 is the vertex 4
    got = check_landmark_entry(4.0, "x")
    assert got == 4 and isinstance(got, int)
    point = check_landmark_entry([1, 2.5, -3], "x")
    assert point == [1.0, 2.5, -3.0] and all(isinstance(c, float) for c in point)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("doc", "field", "error"),
    [
        # the three documents that made the morph route answer 500 (issue audit)
        ({"landmarks": [[1.5, 2, 3], [1, 2, 3]]}, "landmarks[0][0]", LandmarkFormatError),
        ({"landmarks": [[1, "x", 3], [1, 2, 3]]}, "landmarks[0][1]", LandmarkFormatError),
        (
            {"nearest_vertex_0based": [1, 2, None, 4]},
            "nearest_vertex_0based[2]",
            LandmarkFormatError,
        ),
        ({"landmarks": [[1, 2, 3], [1, 2, -3]]}, "landmarks[1][2]", LandmarkIndexError),
        ({"landmarks": [[1, 2, True], [1, 2, 3]]}, "landmarks[0][2]", LandmarkFormatError),
        ({"landmarks": [[1, 2, [0, 0]], [1, 2, 3]]}, "landmarks[0][2]", LandmarkFormatError),
        ({"landmarks": [[1, 2, [0, 0, "1"]], [1, 2, 3]]}, "landmarks[0][2]", LandmarkFormatError),
        (
            {"landmarks": [[1, 2, [0, 0, float("nan")]], [1, 2, 3]]},
            "landmarks[0][2]",
            LandmarkFormatError,
        ),
        ({"landmarks": [[1, 2, float("inf")], [1, 2, 3]]}, "landmarks[0][2]", LandmarkFormatError),
        ({"landmarks": [[1, 2, 3], 7]}, "landmarks[1]", LandmarkFormatError),
        ({"landmarks": {"a": 1}}, "landmarks", LandmarkFormatError),
        ({"nearest_vertex_0based": "123"}, "nearest_vertex_0based", LandmarkFormatError),
        (
            {**CHOI, "face2": {"interior_landmarks_0based": [4, 5, {}]}},
            "face2.interior_landmarks_0based[2]",
            LandmarkFormatError,
        ),
        (
            {
                **CHOI,
                "face1": {
                    "interior_landmarks_0based": [1, 2, 3],
                    "boundary_landmarks_0based_per_loop": [[7], [10, "a"]],
                },
            },
            "face1.boundary_landmarks_0based_per_loop[1][1]",
            LandmarkFormatError,
        ),
        ({"face1": {"other": [1, 2, 3]}}, "face1", LandmarkFormatError),
    ],
)
def test_a_bad_entry_is_named(doc: object, field: str, error: type[Exception]) -> None:
    with pytest.raises(error) as info:
        parse_landmark_json(doc, 2)
    assert info.value.field == field  # type: ignore[attr-defined]
    assert str(info.value).startswith(field)


def test_counts() -> None:
    with pytest.raises(LandmarkCountMismatchError, match="3 lists but 2 meshes"):
        parse_landmark_json({"landmarks": [[0, 1, 2]] * 3}, 2)
    with pytest.raises(LandmarkCountMismatchError, match="same number"):
        parse_landmark_json({"landmarks": [[0, 1, 2], [0, 1, 2, 3]]}, 2)
    with pytest.raises(LandmarkCountMismatchError, match="no lists"):
        parse_landmark_json({"landmarks": []}, 0)
    with pytest.raises(TooFewLandmarksError):
        parse_landmark_json({"nearest_vertex_0based": [0, 1]}, 2)
    for doc in ([1, 2], "x", {"something": 1}):
        with pytest.raises(LandmarkFormatError):
            parse_landmark_json(doc, 2)
        with pytest.raises(LandmarkFormatError):
            document_mesh_count(doc)


def test_input_is_not_mutated() -> None:
    doc = {"landmarks": [[0, 1.0, [1, 2, 3]], [3, 4, 5]]}
    before = json.dumps(doc)
    parse_landmark_json(doc, 2)
    assert json.dumps(doc) == before


def test_read_landmark_file(tmp_path: Path) -> None:
    good = tmp_path / "l.json"
    good.write_text(json.dumps({"landmarks": [[1, 2, 3], [4, 5, 6]]}))
    assert read_landmark_file(good, 2) == [[1, 2, 3], [4, 5, 6]]
    for content in (b"{not json", b"\xff\xfe\x00"):
        bad = tmp_path / "bad.json"
        bad.write_bytes(content)
        with pytest.raises(LandmarkFormatError, match="not valid JSON"):
            read_landmark_file(bad, 2)


def test_the_module_needs_no_numpy() -> None:
    code = (
        "import sys, conformorph.pipelines.landmark_document;"
        "bad = [m for m in ('numpy', 'scipy', 'geometry', 'conformorph.geometry') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=Path(__file__).parents[2]
    )
    assert out.returncode == 0, out.stdout + out.stderr


# --------------------------------------------------------------------- ibug subsets (issue 27)


def _doc(n_points, **extra):
    return {"landmarks": [list(range(n_points)), list(range(10, 10 + n_points))], **extra}


def test_indices_name_a_subset_of_the_68_and_old_files_need_none():
    from conformorph.pipelines.landmark_document import landmark_fill, landmark_indices

    inner = list(range(17, 68))
    assert landmark_indices(_doc(51, indices=inner), 51) == inner
    assert parse_landmark_json(_doc(51, indices=inner), 2)[0][:3] == [0, 1, 2]
    five = [39, 42, 30, 48, 54]  # any order
    assert parse_landmark_json(_doc(5, indices=five, fill="auto"), 2)[1] == [10, 11, 12, 13, 14]
    assert landmark_fill(_doc(5, indices=five, fill="auto")) == "auto"
    assert landmark_indices(_doc(5), 5) is None and landmark_fill(_doc(5)) is None


@pytest.mark.parametrize(
    ("extra", "match", "field"),
    [
        ({"indices": [0, 1, 68]}, r"indices\[2\]: 68 is not an ibug index \(0-based", "indices[2]"),
        ({"indices": [0, 1, -1]}, r"indices\[2\]", "indices[2]"),
        ({"indices": [4, 4, 5]}, "ibug index 4 appears twice", "indices"),
        ({"indices": [1, 2]}, "names 2 points but every mesh has 3", "indices"),
        ({"indices": "inner51"}, "must be a list of 0-based ibug indices", "indices"),
        ({"indices": [0, 1, 2], "fill": "detect"}, "fill: must be one of auto", "fill"),
        ({"fill": "auto"}, 'fill: needs "indices"', "fill"),
    ],
)
def test_bad_indices_and_fill_are_named_where_they_are(extra, match, field):
    from conformorph.pipelines.landmark_document import LandmarkError

    with pytest.raises(LandmarkError, match=match) as exc:
        parse_landmark_json(_doc(3, **extra), 2)
    assert exc.value.field == field


def test_requests_fill_reads_the_file(tmp_path):
    from conformorph.pipelines.landmark_document import requests_fill

    f = tmp_path / "l.json"
    f.write_text(json.dumps(_doc(5, indices=[39, 42, 30, 48, 54], fill="auto")))
    assert requests_fill(f)
    f.write_text(json.dumps(_doc(5)))
    assert not requests_fill(f)
    f.write_text("{not json")
    assert not requests_fill(f) and not requests_fill(tmp_path / "missing.json")


def test_given_points_replace_the_detected_ones_at_their_indices():
    from conformorph.pipelines.face_morph.auto_landmarks import fill_landmark_document

    detected = {
        "landmarks": [[[float(k), 0.0, 0.0] for k in range(68)] for _ in range(2)],
        "confidence": [[0.5] * 68, [0.7] * 68],
        "names": ["a", "b"],
    }
    given = [[100, 101, [1.0, 2.0, 3.0]], [200, 201, 202]]
    doc = fill_landmark_document(given, [30, 39, 42], detected)
    assert doc["landmarks"][0][30] == 100 and doc["landmarks"][0][42] == [1.0, 2.0, 3.0]
    assert doc["landmarks"][1][39] == 201 and doc["landmarks"][1][0] == [0.0, 0.0, 0.0]
    assert doc["confidence"][1][39] == 1.0 and doc["confidence"][1][40] == 0.7
    assert doc["filled"]["given_indices"] == [30, 39, 42]
    assert (
        len(doc["filled"]["detected_indices"]) == 65 and 30 not in doc["filled"]["detected_indices"]
    )
    assert detected["confidence"][0][30] == 0.5  # the input is not modified
    assert len(parse_landmark_json(doc, 2)[0]) == 68
