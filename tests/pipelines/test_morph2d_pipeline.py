"""Tests of conformorph.pipelines.morph2d (end to end on the committed bar fixtures)."""

import io
import json
import re
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pygltflib as g
import pytest
from PIL import Image

from conformorph.geometry.shape_rings import (
    AnchorOutsideShapeError,
    DuplicateAnchorError,
    SelfIntersectingRingError,
    ring_signed_area,
)
from conformorph.geometry.strain_morph import StrainMorphOptions
from conformorph.pipelines.morph2d import (
    DEFAULT_INTERP,
    Morph2DOptions,
    MorphNotConvergedError,
    TextureError,
    run_morph2d,
)
from conformorph.pipelines.shape_io import read_shape
from tests.pipelines.test_export_gltf import VALIDATOR, read_accessor

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
ROOT = Path(__file__).resolve().parents[2]
BAR_S, BAR_T, BAR_A = (
    SHAPES / "bar_straight.json",
    SHAPES / "bar_bent.json",
    SHAPES / "bar_anchors.json",
)


def test_bar_pair_outputs_and_metrics(tmp_path):
    calls = []
    res = run_morph2d(
        BAR_S,
        BAR_T,
        BAR_A,
        tmp_path,
        Morph2DOptions(frames=11, per_frame=True),
        progress=lambda c, t, s: calls.append((c, t, s)),
    )
    assert calls[-1][0] == calls[-1][1]
    assert (tmp_path / "animation.glb").stat().st_size == res["outputs"]["animation_bytes"]
    assert len(list((tmp_path / "frames").glob("*.glb"))) == 11
    assert (tmp_path / "strip.svg").read_text().startswith("<svg")
    on_disk = json.loads((tmp_path / "metrics.json").read_text())
    assert (
        on_disk["methods"]["strain"]["flipped_per_frame"]
        == res["methods"]["strain"]["flipped_per_frame"]
    )
    assert res["mesh"]["route"] == "given" and res["mesh"]["vertices"] == 82
    strain, linear, arap = (res["methods"][k] for k in ("strain", "linear", "arap"))
    assert strain["total_flipped"] == 0 and strain["no_squeezing"] and strain["converged"]
    assert 0.8 < strain["min_area_ratio"] < 0.9 and 1.1 < strain["max_area_ratio"] < 1.2
    assert not linear["no_squeezing"] and linear["min_area_ratio"] < 0.6
    assert arap["total_flipped"] == 0
    assert len(strain["newton_iterations"]) == 11


def _png(tmp_path: Path, fmt: str = "PNG", name: str = "t.png") -> Path:
    p = tmp_path / name
    buf = io.BytesIO()
    img = Image.new("RGB", (4, 2))
    img.putdata([(255, 0, 0), (0, 255, 0), (0, 0, 255), (9, 9, 9)] * 2)
    img.save(buf, fmt)
    p.write_bytes(buf.getvalue())
    return p


def _frames_of(glb: Path) -> tuple[g.GLTF2, np.ndarray]:
    """The GLB and its frames: base positions plus each morph target's deltas, (T, n, 3),
    taken back from the GLB's metres to the shapes' units (its ``extras.placement``)."""
    gltf = g.GLTF2().load(str(glb))
    prim = gltf.meshes[0].primitives[0]
    base = read_accessor(gltf, prim.attributes.POSITION).astype(np.float64)
    deltas = [read_accessor(gltf, t["POSITION"]) for t in prim.targets]
    frames = np.stack([base + d for d in deltas])
    place = gltf.nodes[0].extras["placement"]
    return gltf, frames / place["metres_per_unit"] + [*place["centre"], 0.0]


def test_glb_in_metres_centred_y_up_by_units_or_size(tmp_path):
    res = run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "px", Morph2DOptions(frames=3))
    gltf = g.GLTF2().load(str(tmp_path / "px" / "animation.glb"))
    prim = gltf.meshes[0].primitives[0]
    P = read_accessor(gltf, prim.attributes.POSITION).astype(np.float64)
    frames = np.stack([P + read_accessor(gltf, t["POSITION"]) for t in prim.targets])
    lo, hi = frames.reshape(-1, 3).min(axis=0), frames.reshape(-1, 3).max(axis=0)
    np.testing.assert_allclose((lo + hi)[:2] / 2, 0.0, atol=1e-9)  # centred
    S = read_shape(BAR_S)[0]  # the bar, 4 units long: 4 CSS px = 1.058 mm
    assert np.ptp(frames[0][:, 0]) == pytest.approx(4 * 0.0254 / 96, rel=1e-6)
    # Y up: the shapes' y (already up) keeps its sign
    i = int(np.argmax(S[:, 1]))
    assert frames[0][i, 1] == pytest.approx(frames[0][:, 1].max(), abs=1e-9)
    assert gltf.nodes[0].extras["units"] == "m"
    assert res["outputs"]["glb_placement"]["units"] == "px"
    run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "sz", Morph2DOptions(frames=3, size=0.5))
    _, fr = _frames_of(tmp_path / "sz" / "animation.glb")
    gl2 = g.GLTF2().load(str(tmp_path / "sz" / "animation.glb"))
    P2 = read_accessor(gl2, gl2.meshes[0].primitives[0].attributes.POSITION)
    T2 = [read_accessor(gl2, t["POSITION"]) for t in gl2.meshes[0].primitives[0].targets]
    ext = np.ptp(np.concatenate([P2 + d for d in T2]), axis=0)
    assert max(ext[0], ext[1]) == pytest.approx(0.5, rel=1e-6)
    np.testing.assert_allclose(fr, _frames_of(tmp_path / "px" / "animation.glb")[1], atol=1e-5)
    with pytest.raises(ValueError, match="units must be one of"):
        run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "x", Morph2DOptions(units="furlong"))


def test_texture_is_carried(tmp_path):
    png = _png(tmp_path)
    res = run_morph2d(
        BAR_S, BAR_T, BAR_A, tmp_path / "o", Morph2DOptions(frames=3), texture_path=png
    )
    gltf, frames = _frames_of(tmp_path / "o" / "animation.glb")
    # the image is the given PNG, stored in the GLB and used as base colour
    (img,) = gltf.images
    view = gltf.bufferViews[img.bufferView]
    blob = gltf.binary_blob()
    stored = blob[view.byteOffset : view.byteOffset + view.byteLength]
    assert img.mimeType == "image/png" and stored == png.read_bytes()
    prim = gltf.meshes[0].primitives[0]
    tex = gltf.materials[prim.material].pbrMetallicRoughness.baseColorTexture
    assert gltf.textures[tex.index].source == 0
    # UVs: the source's bounding box spread over the image (v down), the same for every
    # frame (static UVs = barycentric transport)
    assert tex.texCoord in (None, 0)
    uv = read_accessor(gltf, prim.attributes.TEXCOORD_0)
    S = read_shape(BAR_S)[0]  # the given route keeps the ring's vertices in order
    assert np.allclose(frames[0][:, :2], S, atol=1e-6)
    expect = np.c_[(S[:, 0] - 0.0) / 4.0, 1.0 - (S[:, 1] + 0.2) / 0.4]
    assert uv.shape == (82, 2) and np.allclose(uv, expect, atol=1e-6)
    assert res["outputs"]["animation_bytes"] == (tmp_path / "o" / "animation.glb").stat().st_size


def test_texture_is_checked_before_any_numerics(tmp_path):
    calls = []
    for bad, match in (
        (_png(tmp_path, "JPEG", "t.jpg"), "must be a PNG"),
        (tmp_path / "t.png", "not a readable PNG"),
    ):
        if bad.suffix == ".png":
            bad.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)  # signature, then garbage
        with pytest.raises(TextureError, match=match) as e:
            run_morph2d(
                BAR_S,
                BAR_T,
                BAR_A,
                tmp_path / "o",
                Morph2DOptions(frames=3),
                texture_path=bad,
                progress=lambda c, t, s: calls.append(s),
            )
        assert e.value.conformorph_field == "texture"  # type: ignore[attr-defined]
    assert calls == [] and not (tmp_path / "o").exists()  # no stage ran, nothing written


def _write(tmp_path: Path, name: str, obj: object) -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(obj))
    return p


def test_named_input_errors(tmp_path):
    sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    s = _write(tmp_path, "s.json", {"rings": [sq]})
    bow = _write(tmp_path, "b.json", {"rings": [[[0, 0], [1, 1], [1, 0], [0, 1]]]})
    good = _write(tmp_path, "a.json", {"anchors": [[[0, 0], [0, 0]], [[1, 1], [1, 1]]]})
    # one anchor pair is too few to morph by: it seeds the automatic matching (issue 18)
    one = _write(tmp_path, "a1.json", {"anchors": [[[0, 0], [0, 0]]]})
    seeded = run_morph2d(s, s, one, tmp_path / "o1", Morph2DOptions(frames=3))
    assert seeded["correspondence"]["source"] == "seeded"
    assert json.loads((tmp_path / "o1" / "anchors.json").read_text())["anchors"][0] == [
        [0, 0],
        [0, 0],
    ]
    with pytest.raises(AnchorOutsideShapeError):
        run_morph2d(
            s,
            s,
            _write(tmp_path, "a2.json", {"anchors": [[[0, 0], [0, 0]], [[5, 5], [1, 1]]]}),
            tmp_path / "o",
        )
    with pytest.raises(SelfIntersectingRingError):
        run_morph2d(bow, s, good, tmp_path / "o")
    with pytest.raises(ValueError):
        run_morph2d(s, s, good, tmp_path / "o", Morph2DOptions(frames=1))
    assert not (tmp_path / "o").exists()


def test_input_errors_name_the_input_and_side(tmp_path):
    sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    s = _write(tmp_path, "s.json", {"rings": [sq]})
    big = _write(tmp_path, "big.json", {"rings": [[[2 * x, 2 * y] for x, y in sq]]})
    bow = _write(tmp_path, "b.json", {"rings": [[[0, 0], [1, 1], [1, 0], [0, 1]]]})

    def field(src, dst, anchors):
        a = _write(tmp_path, "a.json", {"anchors": anchors})
        with pytest.raises(ValueError) as e:
            run_morph2d(src, dst, a, tmp_path / "o", Morph2DOptions(frames=3))
        return type(e.value), e.value.conformorph_field  # type: ignore[attr-defined]

    ok = [[[0, 0], [0, 0]], [[1, 1], [2, 2]]]
    # a target-side problem is labelled target (the old guess said "source")
    assert field(s, big, [*ok, [[0.5, 0.5], [3, 3]]]) == (AnchorOutsideShapeError, "anchors[2][1]")
    assert field(s, big, [*ok, [[1.5, 0.5], [1, 1]]]) == (AnchorOutsideShapeError, "anchors[2][0]")
    assert field(bow, s, ok)[1] == "source"
    assert field(s, bow, ok)[1] == "target"
    # a single pair seeds the automatic matching; its points are checked the same way
    assert field(s, big, [[[0.5, 0.5], [3, 3]]]) == (AnchorOutsideShapeError, "anchors[0][1]")


def test_duplicate_anchors_are_named_before_the_solve(tmp_path):
    # two anchors at one inner point of I made SuperLU fail ("Factor is exactly singular")
    base = json.loads((SHAPES / "anchors_dejavu_bold_I__dejavu_bold_L.json").read_text())
    inner = [[[380.5, 746.5], [380.0, 700.0]], [[380.5, 746.5], [380.0, 300.0]]]
    a = _write(tmp_path, "a.json", {"anchors": base["anchors"] + inner})
    calls = []
    with pytest.raises(
        DuplicateAnchorError, match="anchors 4 and 5 are the same source point"
    ) as e:
        run_morph2d(
            SHAPES / "dejavu_bold_I.json",
            SHAPES / "dejavu_bold_L.json",
            a,
            tmp_path / "o",
            Morph2DOptions(frames=3),
            progress=lambda c, t, s: calls.append(s),
        )
    assert e.value.conformorph_field == "anchors[5][0]"  # type: ignore[attr-defined]
    assert calls == []


def test_shifted_start_vertex_does_not_take_the_given_route(tmp_path):
    # The same unit square, its ring starting one vertex later, with identity anchors:
    # vertex i <-> vertex i would turn the square by 90 degrees against the anchors.
    sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    s = _write(tmp_path, "s.json", {"rings": [sq]})
    t = _write(tmp_path, "t.json", {"rings": [sq[1:] + sq[:1]]})
    a = _write(tmp_path, "a.json", {"anchors": [[[0, 0], [0, 0]], [[1, 1], [1, 1]]]})
    res = run_morph2d(s, t, a, tmp_path / "o", Morph2DOptions(frames=5))
    assert res["mesh"]["route"] == "constructed"
    assert "anchor 0" in res["mesh"]["given_route_refused"]
    m = res["methods"]["strain"]
    assert m["reached_target"] and m["rotation"] == pytest.approx(0.0, abs=1e-12)
    # an identity morph: every frame is the source square, vertex for vertex
    _, frames = _frames_of(tmp_path / "o" / "animation.glb")
    assert np.abs(frames - frames[:1]).max() < 1e-6
    # the same shapes with anchors that agree with the shifted pairing keep the given route
    a2 = _write(tmp_path, "a2.json", {"anchors": [[[0, 0], [1, 0]], [[1, 1], [0, 1]]]})
    res2 = run_morph2d(s, t, a2, tmp_path / "o2", Morph2DOptions(frames=3))
    assert res2["mesh"]["route"] == "given"
    assert res2["methods"]["strain"]["rotation"] == pytest.approx(np.pi / 2)


def test_identity_morph_keeps_shape(tmp_path):
    res = run_morph2d(
        BAR_S,
        BAR_S,
        _write(tmp_path, "a.json", {"anchors": [[[0, 0], [0, 0]], [[4, 0], [4, 0]]]}),
        tmp_path / "o",
        Morph2DOptions(frames=4),
    )
    m = res["methods"]["strain"]
    assert m["min_area_ratio"] == pytest.approx(1.0) and m["max_area_ratio"] == pytest.approx(1.0)
    assert np.allclose(res["methods"]["strain"]["translation"], 0.0)


def test_one_hole_pair_end_to_end(tmp_path):
    res = run_morph2d(
        SHAPES / "annulus_round.json",
        SHAPES / "annulus_square.json",
        SHAPES / "anchors_annulus_round__annulus_square.json",
        tmp_path,
        Morph2DOptions(frames=9),
    )
    mesh, strain = res["mesh"], res["methods"]["strain"]
    assert mesh["route"] == "constructed" and mesh["hole_vertices"] > 0
    assert mesh["triangles"] < mesh["overlay_triangles"]
    assert strain["total_flipped"] == 0 and strain["converged"]
    assert res["interp_fallback"] is None


def _assert_last_frame_is_target(glb: Path, target: Path) -> None:
    """The animation's last frame covers the target shape: every target ring point is a
    frame vertex, and the frame's triangles add up to the target's area."""
    gltf, frames = _frames_of(glb)
    X = frames[-1][:, :2].astype(np.float64)
    F = read_accessor(gltf, gltf.meshes[0].primitives[0].indices).reshape(-1, 3)
    rings = read_shape(target)
    diag = float(np.linalg.norm(np.ptp(rings[0], axis=0)))
    for r in rings:
        d = np.linalg.norm(r[:, None] - X[None], axis=2).min(axis=1)
        assert d.max() < 1e-5 * diag
    e1, e2 = X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert area.min() > 0
    target_area = abs(ring_signed_area(rings[0])) - sum(abs(ring_signed_area(h)) for h in rings[1:])
    assert area.sum() == pytest.approx(target_area, rel=1e-5)


def _end_to_end(tmp_path: Path, source: str, target: str, frames: int) -> dict:
    res = run_morph2d(
        SHAPES / f"{source}.json",
        SHAPES / f"{target}.json",
        SHAPES / f"anchors_{source}__{target}.json",
        tmp_path,
        Morph2DOptions(frames=frames),
    )
    strain = res["methods"]["strain"]
    assert res["reached_target"] and strain["reached_target"]
    assert strain["total_flipped"] == 0 and strain["converged"]
    used = res["interp_used"]
    assert all(f["converged"] and f["scheme"] == used for f in strain["frames"])
    assert (res["interp_fallback"] is None) == (used == DEFAULT_INTERP)
    # every scheme tried is recorded, the default first; only the last one reached the target
    assert res["attempts"][0]["scheme"] == DEFAULT_INTERP and res["attempts"][-1]["scheme"] == used
    assert [a["reached_target"] for a in res["attempts"]] == [False] * (
        len(res["attempts"]) - 1
    ) + [True]
    if res["interp_fallback"] is not None:
        assert res["interp_fallback"].startswith(f"{DEFAULT_INTERP} scheme ")
        assert res["interp_fallback"].endswith(f"; used {used}")
    assert strain["target_error"] < 1e-6
    _assert_last_frame_is_target(tmp_path / "animation.glb", SHAPES / f"{target}.json")
    return res


def test_letter_pair_end_to_end(tmp_path):
    _end_to_end(tmp_path, "dejavu_bold_I", "dejavu_bold_L", frames=9)


@pytest.mark.parametrize("source", ["dejavu_bold_S", "dejavu_bold_C"])
def test_letters_to_u_end_to_end(tmp_path, source):
    # The committed anchors pair the letters' stroke ends. The corner rule's anchors paired
    # the lower stroke end with the bottom of the U's bowl: for S -> U a 1250-vertex mesh
    # whose map distorted a triangle 493-fold, and no scheme reached the target
    # (bench_morph2d.py); C -> U 546 vertices, anisotropy 148.
    res = _end_to_end(tmp_path, source, "dejavu_bold_U", frames=9)
    assert res["mesh"]["vertices"] < 500
    assert res["mesh"]["stretch"]["max_anisotropy"] < 100


def test_stick_figure_pair_end_to_end(tmp_path):
    _end_to_end(tmp_path, "figure_stand", "figure_jump", frames=5)


def test_a_morph_that_does_not_reach_the_target_is_an_error_with_the_reason(tmp_path):
    # Newton capped at one iteration, no continuation, no inserted steps (nor
    # intermediate warm-start frames: max_time_step 1): the bar cannot
    # bend in one step under any scheme. Before, such a run returned normally (CLI exit
    # 0) with interp_fallback null; it now writes every output, then raises.
    caps = {"max_iterations": 1, "max_continuation": 1, "max_substeps": 0, "max_time_step": 1.0}
    with pytest.raises(MorphNotConvergedError) as e:
        run_morph2d(
            BAR_S,
            BAR_T,
            BAR_A,
            tmp_path,
            Morph2DOptions(frames=2, solver=StrainMorphOptions(**caps)),
        )
    exc = e.value
    assert isinstance(exc, ArithmeticError)
    msg = str(exc)
    assert "\n" not in msg and "did not reach the target" in msg
    for scheme in ("modified", "principal", "linear"):
        # the solver refuses the folding step ("flip") or runs out of iterations
        assert re.search(
            rf"{scheme} stopped at frame 1 of 2 \(t = 1\.000, (flip|max_iterations)\)", msg
        )
    m = json.loads((tmp_path / "metrics.json").read_text())  # written before the error
    assert m == exc.metrics
    # the bar of length 4 bent into a half circle (radius 4/π) stretches its outer edge
    # by 1 + 0.2π/4 and shortens its inner edge to 1 − 0.2π/4 (thickness 0.4); the
    # triangles' chords come within 1% of that, and the reason quotes the figures
    st = m["mesh"]["stretch"]
    assert st["max_stretch"] == pytest.approx(1 + 0.05 * np.pi, rel=0.01)
    assert st["min_stretch"] == pytest.approx(1 - 0.05 * np.pi, rel=0.01)
    assert f"stretch a triangle {st['max_stretch']:.3g}-fold" in msg
    assert f"distort one {st['max_anisotropy']:.3g}-fold" in msg
    assert m["reached_target"] is False and m["not_converged_reason"] == msg
    assert [a["scheme"] for a in m["attempts"]] == ["principal", "modified", "linear"]
    assert not any(a["reached_target"] for a in m["attempts"])
    strain = m["methods"]["strain"]
    assert [f["converged"] for f in strain["frames"]] == [True, False]
    assert [f["scheme"] for f in strain["frames"]] == ["principal", "principal"]
    assert strain["target_error"] > 0.1 and not strain["reached_target"]
    assert (tmp_path / "animation.glb").is_file() and (tmp_path / "strip.svg").is_file()
    # with --interp linear the other schemes are tried too
    with pytest.raises(MorphNotConvergedError) as e:
        run_morph2d(
            BAR_S,
            BAR_T,
            BAR_A,
            tmp_path / "l",
            Morph2DOptions(frames=2, interp="linear", solver=StrainMorphOptions(**caps)),
        )
    assert [a["scheme"] for a in e.value.metrics["attempts"]] == ["linear", "principal", "modified"]
    # asked not to raise: the same metrics are returned
    res = run_morph2d(
        BAR_S,
        BAR_T,
        BAR_A,
        tmp_path / "r",
        Morph2DOptions(frames=2, solver=StrainMorphOptions(**caps)),
        require_convergence=False,
    )
    assert res["reached_target"] is False and res["not_converged_reason"] == msg


def test_animation_passes_the_khronos_validator(tmp_path):
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: cannot run the Khronos glTF validator")
    if not (ROOT / "node_modules" / "gltf-validator").is_dir():
        pytest.fail("npm package gltf-validator missing: run `npm ci` at the repository root")
    run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "plain", Morph2DOptions(frames=5, per_frame=True))
    run_morph2d(
        BAR_S, BAR_T, BAR_A, tmp_path / "tex", Morph2DOptions(frames=5), texture_path=_png(tmp_path)
    )
    files = [
        tmp_path / "plain" / "animation.glb",
        tmp_path / "plain" / "frames" / "002.glb",
        tmp_path / "tex" / "animation.glb",
    ]
    proc = subprocess.run(
        [node, str(VALIDATOR), *map(str, files)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    reports = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert len(reports) == len(files), proc.stderr
    for r in reports:
        assert (r["errors"], r["warnings"]) == (0, 0), r
    assert proc.returncode == 0
    # every GLB carries static +z normals (the 2D mesh is counter-clockwise), no NORMAL targets
    for f in files:
        gltf = g.GLTF2().load(str(f))
        prim = gltf.meshes[0].primitives[0]
        N = read_accessor(gltf, prim.attributes.NORMAL)
        assert N.shape == (82, 3) and np.array_equal(N, np.tile([0.0, 0.0, 1.0], (82, 1)))
        assert all(t.get("NORMAL") is None for t in prim.targets or [])


def test_a_hole_the_source_lacks_grows_from_a_seed(tmp_path):
    corners = [[0, 0], [4, 0], [4, 4], [0, 4]]
    # four points per side, so that a hole's cut can reach the outer ring between anchors
    sq = [
        [a + (b - a) * k / 4 for a, b in zip(p, q, strict=True)]
        for p, q in zip(corners, corners[1:] + corners[:1], strict=True)
        for k in range(4)
    ]
    hole = [[2.5, 1.5], [2.5, 2.5], [3.5, 2.5], [3.5, 1.5]]
    s = _write(tmp_path, "s.json", {"rings": [sq]})
    h = _write(tmp_path, "h.json", {"rings": [sq, hole]})
    a = _write(tmp_path, "a.json", {"anchors": [[p, p] for p in corners]})
    m = run_morph2d(s, h, a, tmp_path / "o", Morph2DOptions(frames=9))
    seeds = m["mesh"]["seeded_holes"]
    assert len(seeds) == 1 and seeds[0]["side"] == "source"
    np.testing.assert_allclose(seeds[0]["centre"], [3.0, 2.0], atol=0.1)
    strain = m["methods"]["strain"]
    assert strain["reached_target"] and strain["total_flipped"] == 0
    # the other way round the seed is in the target, and the hole closes to it
    m2 = run_morph2d(h, s, a, tmp_path / "o2", Morph2DOptions(frames=9))
    assert m2["mesh"]["seeded_holes"][0]["side"] == "target"
    assert m2["methods"]["strain"]["reached_target"]


def test_letters_a_to_b_get_compatible_meshes_with_a_seeded_hole():
    from conformorph.geometry.shape_rings import validate_rings
    from conformorph.pipelines.morph2d import compatible_meshes

    shapes = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
    S, T = (
        validate_rings(json.loads((shapes / f"dejavu_bold_{c}.json").read_text())["rings"])
        for c in "AB"
    )
    anchors = np.array(
        json.loads((shapes / "anchors_dejavu_bold_A__dejavu_bold_B.json").read_text())["anchors"]
    )
    SV, TV, F, info = compatible_meshes(S, T, anchors)
    (seed,) = info["seeded_holes"]
    assert seed["side"] == "source"
    # the cheapest pairing cannot be cut consistently here: the next one is used
    assert info["hole_pairing_rank"] >= 1
    assert SV.shape == TV.shape and F.shape[1] == 3


def test_every_attempt_has_an_iteration_budget(tmp_path, monkeypatch):
    # The pipeline bounds each scheme's Newton iterations by STRAIN_ITERATIONS_PER_STEP
    # per solver step: with none allowed every attempt ends "budget" at once and the
    # morph fails with that reason; the bar's converging morph fits the default easily
    from conformorph.pipelines.morph2d import strain_interpolation as pipeline

    res = run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "ok", Morph2DOptions(frames=3))
    spent = sum(res["methods"]["strain"]["newton_iterations"])
    steps = max(3 - 1, 60)
    assert res["reached_target"] and 0 < spent < pipeline.STRAIN_ITERATIONS_PER_STEP * steps / 5
    monkeypatch.setattr(pipeline, "STRAIN_ITERATIONS_PER_STEP", 0)
    with pytest.raises(MorphNotConvergedError) as e:
        run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "none", Morph2DOptions(frames=3))
    for scheme in ("modified", "principal", "linear"):
        assert re.search(rf"{scheme} stopped at frame 1 of 3 \(t = 0\.500, budget\)", str(e.value))


def test_even_pace_removes_the_snap_of_eq_3(tmp_path):
    """S -> U: eq. (3)'s shear grows like tan(t arctan γ) and the letter snaps in the last
    frames; pace="even" plays the same path at re-timed parameters, evenly."""
    src, dst = SHAPES / "dejavu_bold_S.json", SHAPES / "dejavu_bold_U.json"
    anchors = SHAPES / "anchors_dejavu_bold_S__dejavu_bold_U.json"
    eq3 = Morph2DOptions(frames=31, interp="modified")
    plain = run_morph2d(src, dst, anchors, tmp_path / "plain", eq3)
    even = run_morph2d(src, dst, anchors, tmp_path / "even", replace(eq3, pace="even"))
    assert plain["pace_used"] == "strain" and plain["frame_t"] == list(np.linspace(0, 1, 31))
    assert even["pace_used"] == "even" and even["reached_target"]
    t = np.array(even["frame_t"])
    assert t[0] == 0 and t[-1] == 1 and np.all(np.diff(t) > 0) and t[15] > 0.6
    assert plain["methods"]["strain"]["max_step_ratio"] > 8
    assert even["methods"]["strain"]["max_step_ratio"] < 3
    assert even["methods"]["strain"]["total_flipped"] == 0
    with pytest.raises(ValueError, match="pace"):
        run_morph2d(src, dst, anchors, tmp_path / "bad", Morph2DOptions(frames=3, pace="fast"))
