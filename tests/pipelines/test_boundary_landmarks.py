"""A landmark on a key's boundary: the DMT's fit leaves it out (its thin-plate part cannot
move the circle) instead of failing every fit and falling back to MT for all landmarks
(issue 32: the 68k benchmark pair had two such landmarks)."""

from __future__ import annotations

import numpy as np

from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.pipelines.face_morph import RegistrationOptions, prepare_mesh, register_meshes
from conformorph.pipelines.face_morph.disk_registration import boundary_polygon_radius
from conformorph.pipelines.face_morph.metrics import bijectivity_summary

from .face_fixtures import face_mesh


def _keys(extra_boundary: bool) -> tuple[list[dict], list[int]]:
    V0, F, lm = face_mesh(0.0)
    V1, _, _ = face_mesh(1.0)
    b = boundary_loop(F)
    ids = [*lm, int(b[0])] if extra_boundary else list(lm)
    keys = [prepare_mesh(V, F, ids, mesh_index=i) for i, V in enumerate((V0, V1))]
    return keys, ids


def test_boundary_polygon_radius_hand_worked() -> None:
    # a square's corners on the circle: its edges' midpoints at radius cos(45°)
    uv = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [0.0, 0.0]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    assert np.isclose(boundary_polygon_radius(uv, F), np.sqrt(0.5))


def test_a_boundary_landmark_is_left_out_of_the_dmt_fit() -> None:
    keys, ids = _keys(extra_boundary=True)
    assert np.isclose(np.hypot(*keys[0]["lm_uv"][-1]), 1.0)  # on the circle
    # the tolerant fit as well as the exact one, and through the guided refinement
    for fit, refine in (("exact", "none"), ("tolerant", "none"), ("tolerant", "guided")):
        reg = register_meshes(keys, RegistrationOptions(refine=refine, landmark_fit=fit))
        (pair,) = reg["meta"]["pairs"]
        assert pair["boundary_landmarks"] == [len(ids) - 1]
        assert pair["dmt_fallback"] != "mt", pair["dmt_attempts"]
        assert pair["folded_triangles"]["dmt"] == 0
    # the other landmarks are still met exactly: E_D only from the boundary one
    reg = register_meshes(keys, RegistrationOptions(refine="none"))
    (pair,) = reg["meta"]["pairs"]
    assert pair["E_D"]["dmt"] < pair["E_D"]["mt"]
    clean, _ = _keys(extra_boundary=False)
    (none,) = register_meshes(clean, RegistrationOptions(refine="none"))["meta"]["pairs"]
    assert none["boundary_landmarks"] == []


def test_failed_fits_are_not_called_folds() -> None:
    meta = {
        "registration": "dmt",
        "pairs": [
            {
                "pair": [0, 1],
                "dmt_fallback": "mt",
                "dmt_attempts": [{"steps": 1.0, "error": "landmarks outside"}],
            }
        ],
        "composite_folded_triangles": {"main": [0]},
    }
    inputs = [{"disk_map": {"flipped": 0, "flipped_before_repair": 0}}] * 2
    (fb,) = bijectivity_summary(inputs, meta)["fallbacks"]
    assert fb["message"].startswith("every DMT fit failed (landmarks outside)")
    meta["pairs"][0]["dmt_attempts"] = [{"steps": 1.0, "n_folded": 3.0}]
    (fb,) = bijectivity_summary(inputs, meta)["fallbacks"]
    assert fb["message"].startswith("DMT folded at every strength")
