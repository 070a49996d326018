"""The steps of conformorph.pipelines.conformal: repaired disk mesh and its vertex rows, disk map,
(H, λ), reconstruction; and the one place each of the CLI and the jobs maps onto them."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from conformorph import geometry
from conformorph.cli.main import build_parser
from conformorph.pipelines.conformal import (
    CurvatureOptions,
    DiskMapOptions,
    ReconstructionStepOptions,
    curvature_step,
    disk_map_step,
    map_histogram_pngs,
    map_quality_report,
    reconstruction_step,
    repair_disk_mesh,
    require_interior_vertex,
)
from tests.fixtures.make_service_small_face import small_face, with_hole_and_ear
from tests.meshes import bumpy_disk, eared_disk


def _repaired():
    V, F = small_face(6)
    V2, F2, ear = with_hole_and_ear(V, F)
    return repair_disk_mesh(V2, F2, fill_holes=True, remove_ears=True), ear


def test_repaired_mesh_rows_come_back_in_the_input_order():
    mesh, ear = _repaired()
    assert mesh.done["filled_holes"] == 1 and mesh.done["removed_ear_vertex_ids"] == [ear]
    n_in = mesh.V_in.shape[0]
    # the identity on V's rows gives back the input positions, the ear from `removed`
    rows = mesh.input_rows(mesh.V, mesh.V_filled)
    np.testing.assert_array_equal(rows, mesh.V_in)
    assert mesh.kept_mask().sum() == n_in - 1 and not mesh.kept_mask()[ear]
    with pytest.raises(ValueError, match="ear"):
        mesh.vertex(ear)
    other = (ear + 1) % n_in
    assert mesh.V[mesh.vertex(other)].tolist() == mesh.V_in[other].tolist()


def test_disk_map_step_on_the_input_rows_and_its_report():
    mesh, ear = _repaired()
    c = mesh.V_in.shape[0] // 2 if mesh.V_in.shape[0] // 2 != ear else 1
    res = disk_map_step(mesh, DiskMapOptions(center_vertex=c))
    assert res.uv.shape == (mesh.V.shape[0], 2) and res.uv_input.shape == (mesh.V_in.shape[0], 2)
    np.testing.assert_allclose(res.uv_input[c], 0, atol=1e-12)  # an input vertex id
    assert abs(np.hypot(*res.uv_input[ear]) - 1) < 1e-12  # the removed ear, on the circle
    assert not geometry.flipped_triangles(res.uv_input, mesh.F_in).any()
    report = map_quality_report(mesh, res, "fast")
    assert report["vertices"] == mesh.V_in.shape[0] and report["filled_holes"] == 1
    assert report["flipped"] == 0 and report["info"]["center_vertex"] == c
    names = [name for name, png in map_histogram_pngs(report) if png[:4] == b"\x89PNG"]
    assert names == ["angle_distortion_histogram.png", "beltrami_histogram.png"]
    with pytest.raises(ValueError, match="ear"):
        disk_map_step(mesh, DiskMapOptions(angle_vertex=ear))


@pytest.mark.parametrize("curvature", ["vector", "scalar"])
def test_curvature_and_reconstruction_steps(curvature):
    V, F, ears = eared_disk()
    mesh = repair_disk_mesh(V, F, fill_holes=False, remove_ears=True)
    uv = disk_map_step(mesh, DiskMapOptions(fold_policy="report", refine_angles=False)).uv
    hl = curvature_step(mesh, uv, CurvatureOptions(curvature=curvature))
    assert hl.H.ndim == (2 if curvature == "vector" else 1)
    # λ A_uv is the 3D area; removed ears are NaN on the input rows
    np.testing.assert_allclose(
        (hl.lam * geometry.vertex_areas(uv, mesh.F)).sum(),
        geometry.vertex_areas(mesh.V, mesh.F).sum(),
    )
    assert np.isnan(hl.lam_input[ears]).all() and not np.isnan(np.delete(hl.lam_input, ears)).any()
    rec = reconstruction_step(mesh, uv, hl.H, hl.lam, ReconstructionStepOptions())
    assert rec.errors["L2"] < (2e-3 if curvature == "vector" else 2e-2)
    np.testing.assert_array_equal(rec.X_input[ears], V[ears])  # ears keep their positions
    assert rec.info.mode == curvature


def test_reconstruction_step_corrects_folds_only_with_the_vector_h():
    V, F = bumpy_disk(5)
    mesh = repair_disk_mesh(V, F, fill_holes=False, remove_ears=False)
    uv = disk_map_step(mesh, DiskMapOptions(fold_policy="report", refine_angles=False)).uv
    for curvature, expect in (("vector", True), ("scalar", False)):
        hl = curvature_step(mesh, uv, CurvatureOptions(curvature=curvature))
        rec = reconstruction_step(mesh, uv, hl.H, hl.lam, ReconstructionStepOptions(True))
        assert (rec.info.fold_correction is not None) is expect


def test_require_interior_vertex():
    require_interior_vertex(bumpy_disk(3)[1], "reconstruct")
    with pytest.raises(ValueError, match="reconstruct needs interior vertices: all 4"):
        require_interior_vertex(np.array([[0, 1, 2], [0, 2, 3]]), "reconstruct")


def _args(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(list(argv))


def test_cli_flags_map_onto_options_in_one_place():
    from conformorph.cli.cmd_map import map_options_from_args

    o = map_options_from_args(_args("map", "m.obj", "-o", "x.npz", "--no-angle-refinement"))
    assert o.disk_map == DiskMapOptions(refine_angles=False)
    o = map_options_from_args(_args("reconstruct", "m.obj", "-o", "x.obj", "--fill-holes"))
    assert o.disk_map == DiskMapOptions(fold_policy="report", refine_angles=False)
    assert o.repairs.fill_holes and not o.repairs.remove_ears
    assert o.reconstruction.fold_correction and o.curvature.curvature == "vector"
    o = map_options_from_args(
        _args("reconstruct", "m.obj", "-o", "x.obj", "--curvature", "scalar", "--method", "qiem")
    )
    assert not o.reconstruction.fold_correction and o.disk_map.method == "qiem"


def test_job_params_map_onto_options_in_one_place():
    from conformorph.worker.stages.surface import surface_options_from_params

    o = surface_options_from_params({"mesh": {}})
    assert o.disk_map == DiskMapOptions() and o.curvature == CurvatureOptions()
    assert not o.reconstruction.fold_correction and not o.repairs.fill_holes
    p = {"refine_angles": False, "fold_correction": True, "center_vertex": 3, "remove_ears": 1}
    o = surface_options_from_params(p)
    assert o.reconstruction.fold_correction and o.disk_map.center_vertex == 3
    assert o.repairs.remove_ears is True
    # the fold correction needs the harmonic map: not with the angle refinement
    o = surface_options_from_params({"fold_correction": True})
    assert not o.reconstruction.fold_correction
