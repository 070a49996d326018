"""Units of the face keys (pipelines/face_morph/units.py) and frame times on every key."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conformorph.pipelines.face_morph.homotopy import frame_times_for
from conformorph.pipelines.face_morph.units import (
    DEFAULT_UNITS,
    UNIT_CHOICES,
    UnitsMismatchError,
    key_units,
    keys_to_one_scale,
    nearest_unit,
    rescale_key,
)

from .face_fixtures import write_obj
from .face_morph_inputs import face_inputs, morph


def _key(V: np.ndarray, n_landmarks: int, eye: tuple[int, int] = (36, 45)) -> dict:
    """A stage-1-like key: landmarks on vertices, ``eye`` the vertices of 36 and 45."""
    F = np.array([[0, 1, 2]] * n_landmarks)
    lm_tri = np.arange(n_landmarks)
    bary = np.zeros((n_landmarks, 3))
    bary[:, 0] = 1.0
    tri_of = np.zeros((n_landmarks, 3), dtype=np.int64)
    tri_of[:, 0] = 2  # every landmark at vertex 2 unless it is an eye corner
    tri_of[36 if n_landmarks > 45 else 0, 0] = eye[0]
    tri_of[45 if n_landmarks > 45 else 0, 0] = eye[1]
    return {
        "V": V,
        "F": tri_of,
        "lm_tri": lm_tri,
        "lm_bary": bary,
        "norm_translation": V.mean(axis=0),
        "norm_scale": np.array(1.0),
        "lm_snap": np.zeros(n_landmarks),
        "meta": {"diameter": float(np.ptp(V, axis=0).max()), "landmark_snap_distance_max": 0.0},
        "unused": F,
    }


def test_nearest_unit_by_ratio():
    assert nearest_unit(9.0, 0.0925) == "cm"  # 9 cm between the eye corners
    assert nearest_unit(90.0, 0.0925) == "mm"
    assert nearest_unit(0.09, 0.0925) == "m"
    assert nearest_unit(205.0, 0.2) == "mm" and nearest_unit(20.5, 0.2) == "cm"
    with pytest.raises(ValueError, match="positive"):
        nearest_unit(0.0, 0.2)


@pytest.mark.parametrize(("scale", "unit"), [(1.0, "cm"), (10.0, "mm"), (0.01, "m")])
def test_units_inferred_from_the_eye_corners(scale, unit):
    # eye corners 9 cm apart on a face 30 cm across (the size alone would also say cm)
    V = np.array([[0.0, 0, 0], [9.0, 0, 0], [4.5, 30.0, 0]]) * scale
    ku = key_units(_key(V, 68, eye=(0, 1)))
    assert (ku.units, ku.source) == (unit, "landmarks")
    assert ku.measured == pytest.approx(9.0 * scale)


def test_units_from_the_size_without_68_landmarks_and_declared_units_win():
    V = np.array([[0.0, 0, 0], [150.0, 0, 0], [75.0, 200.0, 0]])  # a face in mm
    ku = key_units(_key(V, 5))
    assert (ku.units, ku.source, ku.metres_per_unit) == ("mm", "size", 1e-3)
    ku = key_units(_key(V, 5), "cm")
    assert (ku.units, ku.source, ku.metres_per_unit) == ("cm", "declared", 1e-2)
    with pytest.raises(ValueError, match="units must be one of auto, mm, cm, m"):
        key_units(_key(V, 5), "inch")
    assert DEFAULT_UNITS == "auto" and UNIT_CHOICES == ("auto", "mm", "cm", "m")


def test_rescale_key_scales_lengths_only_and_copies():
    V = np.array([[0.0, 0, 0], [9.0, 0, 0], [4.5, 30.0, 0]])
    p = _key(V, 68, eye=(0, 1))
    q = rescale_key(p, 0.1)
    np.testing.assert_allclose(q["V"], V * 0.1)
    np.testing.assert_allclose(q["norm_translation"], V.mean(axis=0) * 0.1)
    assert float(q["norm_scale"]) == pytest.approx(0.1)
    assert q["meta"]["diameter"] == pytest.approx(3.0)
    assert q["lm_tri"] is p["lm_tri"] and q["unused"] is p["unused"]
    np.testing.assert_array_equal(p["V"], V)  # the input is not changed
    assert p["meta"]["diameter"] == pytest.approx(30.0)
    assert rescale_key(p, 1.0) is p


def test_keys_to_one_scale_reports_and_refuses_sizes_apart():
    V = np.array([[0.0, 0, 0], [9.0, 0, 0], [4.5, 30.0, 0]])
    keys, report = keys_to_one_scale([_key(V, 68, (0, 1)), _key(V * 10, 68, (0, 1))])
    assert report["working_unit"] == "cm" and report["metres_per_working_unit"] == 0.01
    assert [r["units"] for r in report["keys"]] == ["cm", "mm"]
    assert [r["factor_to_working_unit"] for r in report["keys"]] == [1.0, 0.1]
    np.testing.assert_allclose(keys[1]["V"], V)  # the mm key brought to cm
    assert keys[1]["meta"]["units"]["source"] == "landmarks"
    # declared cm for both: the second is 10x the first
    with pytest.raises(UnitsMismatchError, match=r"mesh 1 is 300 cm across .*10× apart"):
        keys_to_one_scale([_key(V, 68, (0, 1)), _key(V * 10, 68, (0, 1))], "cm")


def test_mixed_units_morph_brought_to_one_scale_and_mismatch_refused(tmp_path):
    paths, L = face_inputs(tmp_path)
    # key 1 written 10 times larger
    from conformorph.pipelines.mesh_io import read_mesh

    V1, F1 = read_mesh(paths[1])
    mm = write_obj(tmp_path / "m1_mm.obj", V1 * 10.0, F1)
    m = morph([paths[0], mm], L, tmp_path / "o", frames=3, key_metrics=False, write_glb=False)
    rows = m["units"]["keys"]
    # 2.1 units across: centimetres by its size (nearer 20 cm than 2.1 m, just); key 1,
    # 21 units across, alone would be centimetres too (21 cm) and is matched to key 0
    assert [(r["units"], r["source"]) for r in rows] == [
        ("cm", "size"),
        ("mm", "size, matched to mesh 0"),
    ]
    assert rows[1]["factor_to_working_unit"] == pytest.approx(0.1)
    assert m["inputs"][1]["units"]["units"] == "mm"
    ref = morph(paths, L, tmp_path / "r", frames=3, key_metrics=False, write_glb=False)
    assert m["inputs"][1]["diameter"] == pytest.approx(ref["inputs"][1]["diameter"], rel=1e-9)
    with pytest.raises(UnitsMismatchError, match="sizes disagree"):
        morph([paths[0], mm], L, tmp_path / "x", frames=3, write_glb=False, units="cm")
    saved = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert saved["units"]["declared"] == "auto"


def test_frame_times_hold_every_key_time():
    ft = frame_times_for(np.array([0.0, 1.0, 2.0]), 30)
    assert ft.size == 30 and 1.0 in ft and ft[0] == 0.0 and ft[-1] == 2.0
    assert np.all(np.diff(ft) > 0)
    np.testing.assert_allclose(frame_times_for(np.array([0.0, 2.0]), 7), np.linspace(0, 2, 7))
    ft = frame_times_for(np.array([0.0, 1.0, 5.0]), 10)  # spacing as even as the keys allow
    assert ft.size == 10 and 1.0 in ft
    assert np.diff(ft).max() / np.diff(ft).min() < 1.2
    np.testing.assert_array_equal(frame_times_for(np.array([0.0, 1, 2, 3]), 2), [0, 1, 2, 3])
