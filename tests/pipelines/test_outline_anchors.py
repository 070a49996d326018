"""conformorph.pipelines.outline_anchors: an automatic match written as an anchors file read_anchors reads."""

import json
from pathlib import Path

import numpy as np

from conformorph.geometry.hole_pairing import pair_holes
from conformorph.geometry.outline_correspondence import match_outlines
from conformorph.pipelines.outline_anchors import anchors_document, write_anchors_document
from conformorph.pipelines.shape_io import read_anchors, read_shape

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


def test_round_trip_through_read_anchors(tmp_path):
    src = read_shape(SHAPES / "annulus_round.json")
    tgt = read_shape(SHAPES / "annulus_square.json")
    m = match_outlines(src[0], tgt[0])
    holes = pair_holes(src[1:], tgt[1:], source_outer=src[0], target_outer=tgt[0])
    doc = anchors_document(m, holes)
    path = write_anchors_document(tmp_path / "anchors.json", doc)
    np.testing.assert_array_equal(read_anchors(path), m.anchors)
    data = json.loads(path.read_text())
    assert data["hole_pairs"] == [[0, 0]]
    assert "match_outlines" in data["note"] and data["note"].count("source vertex") == len(m.origin)


def test_passed_back_as_seeds_it_is_kept():
    src = read_shape(SHAPES / "dejavu_bold_C.json")[0]
    tgt = read_shape(SHAPES / "dejavu_bold_U.json")[0]
    m = match_outlines(src, tgt)
    again = match_outlines(src, tgt, seed_anchors=anchors_document(m)["anchors"])
    np.testing.assert_array_equal(again.anchors[: len(m.origin)], m.anchors)
    assert set(again.origin[: len(m.origin)]) == {"seed"}
