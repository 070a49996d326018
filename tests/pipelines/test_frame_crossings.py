"""crossing_frames: self-crossing outlines and overlapping parts, counted per frame."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.pipelines.morph2d.frame_crossings import crossing_frames, crossing_reason

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
F = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])


def _frames(shifts: list[float]) -> np.ndarray:
    """Two unit squares, the second moved right by ``shift`` from x = 2."""
    return np.stack([np.vstack([SQUARE, SQUARE + [2.0 - s, 0.0]]) for s in shifts])


def test_hand_worked_overlap_and_self_crossing() -> None:
    # frame 0 apart, frame 1 touching along an edge, frame 2 half over the first square
    frames = _frames([0.0, 1.0, 1.5])
    r = crossing_frames(frames, F, np.array([0.0, 0.5, 1.0]))
    # shared 0.5 of a painted 2 (the make-valid areas of the two squares): 0.25
    assert r["overlapping_frames"] == 1 and r["first_overlap"] == 2
    assert r["worst_overlap_area"] == pytest.approx(0.25)
    assert r["self_crossing_frames"] == 0
    # a bow tie: two corners of the first square swapped in frame 1
    bow = frames.copy()
    bow[1, [1, 2]] = bow[1, [2, 1]]
    assert crossing_frames(bow, F, np.array([0.0, 0.5, 1.0]))["self_crossing_frames"] == 1


def test_one_part_never_overlaps_and_moves_change_nothing() -> None:
    one = _frames([0.0, 1.5])[:, :4]
    r = crossing_frames(one, F[:2], np.array([0.0, 1.0]))
    assert r == {
        "self_crossing_frames": 0,
        "overlapping_frames": 0,
        "first_overlap": None,
        "worst_overlap_area": 0.0,
    }
    frames = _frames([0.0, 1.0, 1.5])
    moved = crossing_frames(3.0 * frames + [10.0, -4.0], F, np.array([0.0, 0.5, 1.0]))
    assert moved["overlapping_frames"] == 1 and moved["worst_overlap_area"] == pytest.approx(0.25)


def test_crossing_reason_names_the_frames_that_cross() -> None:
    none = {"self_crossing_frames": 0, "overlapping_frames": 0}
    assert crossing_reason(none, 60) is None
    # a bow tie in frame 1 of 3 (the hand-worked frames above)
    bow = _frames([0.0, 0.0, 0.0])[:, :4]
    bow[1, [1, 2]] = bow[1, [2, 1]]
    r = crossing_frames(bow, F[:2], np.array([0.0, 0.5, 1.0]))
    assert crossing_reason(r, 3) == "the strain morph's outline crosses itself in 1 of 3 frames"
    assert "2 of 9" in str(crossing_reason({"self_crossing_frames": 1, "overlapping_frames": 2}, 9))
