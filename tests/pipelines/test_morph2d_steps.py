"""Tests of the steps of conformorph.pipelines.morph2d, each on its own (the bar pair, small cases)."""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.strain_morph import StrainMorphOptions
from conformorph.pipelines.morph2d import (
    ANCHORLESS_FALLBACKS,
    DEFAULT_POINT_BUDGET,
    FALLBACKS,
    Morph2DOptions,
    baseline_metrics,
    check_morph2d_options,
    even_paced_frames,
    iteration_budget,
    morph2d_meshes,
    morph2d_metrics,
    read_morph2d_inputs,
    reference_points,
    scale_separated_strain_morph,
    solver_steps,
    strain_frames,
    strain_interpolation,
    strip_svg,
    texture_uv,
    write_morph2d_outputs,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
BAR = (SHAPES / "bar_straight.json", SHAPES / "bar_bent.json", SHAPES / "bar_anchors.json")


@pytest.mark.parametrize(
    ("bad", "field"),
    [({"frames": 1}, "frames"), ({"interp": "cubic"}, "interp"), ({"pace": "x"}, "pace")],
)
def test_options_out_of_range_are_tagged(bad, field):
    check_morph2d_options(Morph2DOptions())
    with pytest.raises(ValueError) as e:
        check_morph2d_options(Morph2DOptions(**bad))
    assert e.value.conformorph_field == field  # type: ignore[attr-defined]


def test_solver_steps_and_budget():
    assert solver_steps(5, StrainMorphOptions()) == 60
    assert solver_steps(121, StrainMorphOptions()) == 120
    assert solver_steps(3, StrainMorphOptions(max_time_step=0.5)) == 2
    assert iteration_budget(60) == strain_interpolation.STRAIN_ITERATIONS_PER_STEP * 60


def test_reference_points_are_the_first_two_source_anchors():
    anchors = np.arange(12.0).reshape(3, 2, 2)
    np.testing.assert_array_equal(reference_points(anchors), [[0, 1], [4, 5]])


def test_texture_uv_spans_the_box_v_down():
    uv = texture_uv(np.array([[1.0, 2.0], [3.0, 2.0], [3.0, 6.0]]))
    np.testing.assert_allclose(uv, [[0, 1], [1, 1], [1, 0]])


def test_strip_svg_draws_count_frames():
    frames = np.stack([np.array([[0, 0], [1, 0], [0, 1]], float) * (1 + k) for k in range(10)])
    svg = strip_svg(frames, np.array([[0, 1, 2]]), count=4)
    assert svg.startswith("<svg") and svg.count("<path") == 4 and "t=1.00" in svg


def test_inputs_meshes_frames_metrics_of_the_bar(tmp_path):
    inputs = read_morph2d_inputs(*BAR)
    assert inputs.anchors.shape[1:] == (2, 2) and inputs.paths == [] and inputs.texture is None
    meshes = morph2d_meshes(inputs)
    assert meshes.info["route"] == "given" and meshes.info["patches"] == 1
    assert set(meshes.info["orientation_fixes"]) == {"source", "target"}
    ref = reference_points(inputs.anchors)
    run = strain_frames(meshes, ref, 5, "modified", StrainMorphOptions())
    assert run.interp_used == "modified" and run.fallback is None and len(run.attempts) == 1
    assert run.used["reached_target"] and run.frames.shape == (5, meshes.source_V.shape[0], 2)
    assert run.solver.max_total_iterations == iteration_budget(60)
    np.testing.assert_allclose(run.frames[-1], meshes.target_V, atol=1e-9)
    paced = even_paced_frames(meshes, ref, run)
    assert paced.pace_used == "even" and paced.times[0] == 0 and paced.times[-1] == 1
    assert np.all(np.diff(paced.times) > 0)
    base = baseline_metrics(meshes.source_V, meshes.target_V, meshes.F, run.times)
    assert list(base) == ["linear", "arap"]
    outputs = write_morph2d_outputs(tmp_path, run.frames, meshes.F, meshes.source_V)
    assert (tmp_path / "animation.glb").stat().st_size == outputs["animation_bytes"]
    m = morph2d_metrics(BAR[:2], Morph2DOptions(frames=5), meshes, run, base, outputs, 0.0)
    assert list(m["methods"]) == ["strain", "linear", "arap"] and m["reached_target"]
    assert m["outputs"]["metrics"] == "metrics.json" and m["not_converged_reason"] is None
    json.dumps(m)


def test_fallbacks_try_every_other_scheme():
    for interp, others in FALLBACKS.items():
        assert interp not in others and len(set(others)) == 2
    # without anchors, eq. (3) in the x/y frame is never a fallback
    assert ANCHORLESS_FALLBACKS == {
        "principal": ("linear",),
        "modified": ("principal", "linear"),
        "linear": ("principal",),
    }


def test_strain_frames_tries_the_fallbacks_it_is_given():
    inputs = read_morph2d_inputs(*BAR)
    meshes = morph2d_meshes(inputs)
    ref = reference_points(inputs.anchors)
    starved = StrainMorphOptions(max_total_iterations=1)  # no scheme can reach the target
    run = strain_frames(meshes, ref, 5, "principal", starved)
    assert [a["scheme"] for a in run.attempts] == ["principal", "modified", "linear"]
    run = strain_frames(meshes, ref, 5, "principal", starved, ANCHORLESS_FALLBACKS["principal"])
    assert [a["scheme"] for a in run.attempts] == ["principal", "linear"]
    assert not run.used["reached_target"] and run.interp_used == "principal"


def test_cli_flags_map_onto_options():
    from conformorph.cli.cmd_morph2d import morph2d_options_from_args

    args = argparse.Namespace(
        frames=7,
        interp="linear",
        pace="even",
        per_frame=True,
        max_points=99,
        max_iterations=4,
        max_continuation=None,
        max_substeps=0,
        max_time_step=0.5,
    )
    o = morph2d_options_from_args(args)
    assert (o.frames, o.interp, o.pace, o.per_frame, o.max_points) == (
        7,
        "linear",
        "even",
        True,
        99,
    )
    assert o.solver == StrainMorphOptions(max_iterations=4, max_substeps=0, max_time_step=0.5)
    with pytest.raises(ValueError, match="max-time-step"):
        morph2d_options_from_args(argparse.Namespace(**{**vars(args), "max_time_step": 2.0}))
    with pytest.raises(ValueError, match="max-iterations"):
        morph2d_options_from_args(argparse.Namespace(**{**vars(args), "max_iterations": 0}))


def test_glb_units_and_size_map_from_flags_and_job_params():
    from conformorph.cli.cmd_morph2d import morph2d_options_from_args
    from conformorph.cli.main import build_parser
    from conformorph.worker.stages.morph2d import morph2d_options_from_params

    args = build_parser().parse_args(["morph2d", "a.svg", "b.svg", "-o", "o"])
    o = morph2d_options_from_args(args)
    assert (o.units, o.size) == ("px", None)
    args = build_parser().parse_args(["morph2d", "a.svg", "b.svg", "-o", "o", "--units", "mm"])
    assert morph2d_options_from_args(args).units == "mm"
    args = build_parser().parse_args(["morph2d", "a.svg", "b.svg", "-o", "o", "--size", "2"])
    assert morph2d_options_from_args(args).size == 2.0
    p = morph2d_options_from_params({"units": "in", "size": 0.25})
    assert (p.units, p.size) == ("in", 0.25)
    assert morph2d_options_from_params({}).units == "px"


def test_job_params_map_onto_options():
    from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS
    from conformorph.worker.stages.morph2d import morph2d_options_from_params

    assert morph2d_options_from_params({}) == Morph2DOptions()
    o = morph2d_options_from_params(
        {"frames": "9", "interp": "linear", "per_frame": 1, "solver_options": {"max_iterations": 3}}
    )
    assert o == Morph2DOptions(
        frames=9,
        interp="linear",
        per_frame=True,
        max_points=DEFAULT_MAX_POINTS,
        solver=StrainMorphOptions(max_iterations=3),
    )


def test_constructed_meshes_keep_to_the_vertex_budget(monkeypatch):
    # the annulus pair's constructed mesh (144 vertices) cut to a budget of 100:
    # no flips, the anchors and the boundary kept, the collapses reported
    import importlib

    cm = importlib.import_module("conformorph.pipelines.morph2d.compatible_meshes")
    paths = [SHAPES / f"{n}.json" for n in ("annulus_round", "annulus_square")]
    anchors = SHAPES / "anchors_annulus_round__annulus_square.json"
    inputs = read_morph2d_inputs(*paths, anchors, None, 100_000)
    full = morph2d_meshes(inputs)
    assert full.info["budget_collapses"] == 0 and full.info["vertices"] > 100
    monkeypatch.setattr(cm, "MESH_VERTEX_BUDGET", 100)
    # a boundary above the share of the budget leaves the mesh as built
    monkeypatch.setattr(cm, "MESH_BUDGET_MAX_BOUNDARY_SHARE", 0.5)
    assert full.info["boundary_vertices"] > 50
    kept = morph2d_meshes(inputs)
    assert kept.info["vertex_budget"] is None and kept.info["budget_collapses"] == 0
    assert kept.info["vertices"] == full.info["vertices"]
    monkeypatch.setattr(cm, "MESH_BUDGET_MAX_BOUNDARY_SHARE", 1.0)
    cut = morph2d_meshes(inputs)
    assert cut.info["vertex_budget"] == 100
    assert cut.info["vertices"] == 100 == cut.source_V.shape[0]
    assert cut.info["budget_collapses"] == full.info["vertices"] - 100
    for X in (cut.source_V, cut.target_V):
        P = X[cut.F]
        area = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]) / 2
        assert area.min() > 0
    for A, X in ((inputs.anchors[:, 0], cut.source_V), (inputs.anchors[:, 1], cut.target_V)):
        assert np.linalg.norm(A[:, None] - X[None], axis=2).min(axis=1).max() < 1e-9


def test_scale_separated_morph_of_a_scaled_copy_only_scales():
    # a fan square and its copy at half the size, shifted: every frame is the square scaled
    # by 2^(-t) about the reference point A carried linearly; frame 0 the source, the last
    # the target; equal areas (k = 1) give strain_morph's frames unchanged
    from conformorph.geometry.strain_morph import strain_morph

    S = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2], [1, 1], [1.5, 0.4]])
    F = np.array([[0, 1, 5], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 5, 4], [5, 1, 4]])
    T = 0.5 * S + np.array([3.0, 1.0])
    ref = np.array([[1.0, 1.0], [1.8, 1.8]])
    times = np.linspace(0.0, 1.0, 7)
    seq, info = scale_separated_strain_morph(S, T, F, times, "linear", ref, StrainMorphOptions())
    assert info.converged
    assert np.allclose(seq[0], S) and np.allclose(seq[-1], T, atol=1e-9)
    for t, X in zip(times, seq, strict=True):
        A = (1 - t) * ref[0] + t * (0.5 * ref[0] + np.array([3.0, 1.0]))
        assert np.allclose(X, A + 2.0 ** (-t) * (S - ref[0]), atol=1e-9)
    same, _ = scale_separated_strain_morph(
        S, S + 1.0, F, times, "linear", ref, StrainMorphOptions()
    )
    plain, _ = strain_morph(S, S + 1.0, F, times, scheme="linear", reference_points=ref)
    assert np.array_equal(same, plain)


def test_constructed_meshes_relax_the_target_map():
    # the annulus pair's constructed mesh: the target's free vertices moved to a lower
    # symmetric Dirichlet energy of the map; the source, the boundary and the anchors kept
    from conformorph.geometry.map_stretch import map_stretch
    from conformorph.geometry.mesh_edges import mesh_boundary_vertices

    paths = [SHAPES / f"{n}.json" for n in ("annulus_round", "annulus_square")]
    anchors = SHAPES / "anchors_annulus_round__annulus_square.json"
    inputs = read_morph2d_inputs(*paths, anchors, None, 100_000)
    m = morph2d_meshes(inputs)
    relax = m.info["target_relaxation"]
    assert relax["stop_reason"] == "converged" and relax["iterations"] >= 1
    assert relax["energy"][-1] < relax["energy"][0]
    assert m.info["stretch"] == map_stretch(m.source_V, m.target_V, m.F).as_dict()
    from shapely.geometry import LinearRing, Point

    on = mesh_boundary_vertices(m.F, m.source_V.shape[0])
    rings = [LinearRing(r) for r in inputs.target.rings]
    gap = max(min(r.distance(Point(p)) for r in rings) for p in m.target_V[on])
    assert gap < 1e-9
    for A, X in ((inputs.anchors[:, 0], m.source_V), (inputs.anchors[:, 1], m.target_V)):
        assert np.linalg.norm(A[:, None] - X[None], axis=2).min(axis=1).max() < 1e-9


@pytest.mark.parametrize("frames", [12, 60])
def test_horse_to_star_with_the_committed_anchors_reaches_the_target(tmp_path, frames):
    # the working resolution applies to a user's anchors too (rings of different
    # lengths): the horse is simplified to 100 points keeping every anchor, the mesh
    # is ~1,000 vertices instead of 2,673; with the stall rule on progress in t the
    # target is reached at 12 frames as at 60 (the count of 4 halvings stalled at 12);
    # 0 flips
    from conformorph.cli.main import main

    out = tmp_path / "hs"
    pair = [str(SHAPES / f"flubber_{n}.json") for n in ("horse", "star")]
    anchors = str(SHAPES / "anchors_flubber_horse__flubber_star.json")
    args = ["morph2d", *pair, "--anchors", anchors, "--frames", str(frames), "-o", str(out), "-q"]
    rc = main(args)
    m = json.loads((out / "metrics.json").read_text())
    assert rc == 0 and m["reached_target"] is True
    res = m["working_resolution"]
    assert res["point_budget"] == DEFAULT_POINT_BUDGET and res["source_points"] == [1078, 100]
    assert m["correspondence"]["source"] == "user" and m["mesh"]["vertices"] < 1500
    assert max(m["methods"]["strain"]["flipped_per_frame"]) == 0
