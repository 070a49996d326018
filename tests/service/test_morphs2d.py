"""``POST /v1/morphs2d``: what is checked at submission, and how a 2D job fails.

Stages run in-process (real pipeline, real job store and runner).
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

from PIL import Image

from conformorph.service.api.routes import morphs
from conformorph.worker import names
from tests.service.conftest import Api, run_job_inline

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
BAR_ANCHORS = json.loads((SHAPES / "bar_anchors.json").read_text())["anchors"]


def _shape(api: Api, name: str) -> str:
    r = api.client.post("/v1/shapes", files={"file": (name, (SHAPES / name).read_bytes())})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def _post(api: Api, **body: Any) -> Any:
    return api.client.post("/v1/morphs2d", json={"frames": 3, **body})


def test_shape_report_records_the_bounding_box(api: Api) -> None:
    sid = _shape(api, "annulus_square.json")
    report = api.client.get(f"/v1/shapes/{sid}").json()["report"]
    assert report["rings"] == 2 and report["points"] == 20
    rings = json.loads((SHAPES / "annulus_square.json").read_text())["rings"]
    xs = [p[0] for p in rings[0]]
    ys = [p[1] for p in rings[0]]
    assert report["bbox"] == [min(xs), min(ys), max(xs), max(ys)]


def test_different_hole_counts_are_accepted(api: Api) -> None:
    # a hole one shape lacks grows from a seed hole in the worker (geometry.seed_missing_holes)
    bar, ring = _shape(api, "bar_straight.json"), _shape(api, "annulus_round.json")
    r = _post(api, source=bar, target=ring, anchors=[[[0, 0], [-2, 0]], [[4, 0], [2, 0]]])
    assert r.status_code == 202, r.text
    assert len(api.tasks.submitted) == 1


def test_anchors_outside_the_bounding_box_or_coincident_are_refused(api: Api) -> None:
    src, dst = _shape(api, "bar_straight.json"), _shape(api, "bar_bent.json")
    cases = [
        # the target point of anchor 1 is far right of the bent bar: the target side is named
        ([[[0, 0], [0, 0]], [[4, 0], [9, 0]]], "anchor_outside_shape", "anchors[1][1]"),
        ([[[0, 0], [0, 0]], [[4, 0.5], [0, 2.5465]]], "anchor_outside_shape", "anchors[1][0]"),
        (
            [*BAR_ANCHORS, [[0, 0], [0.2, 0]]],
            "duplicate_anchors",
            "anchors[2][0]",
        ),
        (
            [*BAR_ANCHORS, [[2, 0], [0, 2.5465]]],
            "duplicate_anchors",
            "anchors[2][1]",
        ),
    ]
    for anchors, etype, field in cases:
        r = _post(api, source=src, target=dst, anchors=anchors)
        assert r.status_code == 422, (anchors, r.text)
        assert (r.json()["error"]["type"], r.json()["error"]["field"]) == (etype, field)
    assert api.tasks.submitted == []
    assert _post(api, source=src, target=dst, anchors=BAR_ANCHORS).status_code == 202


def test_anchor_inside_the_box_but_outside_the_shape_fails_the_job_naming_its_side(
    api: Api,
) -> None:
    # (-0.5, 0.4) lies in the square frame's hole: only the worker's exact test can tell;
    # it must name the target side (the old field guess said "anchors" for any side)
    src, dst = _shape(api, "annulus_round.json"), _shape(api, "annulus_square.json")
    anchors = json.loads((SHAPES / "anchors_annulus_round__annulus_square.json").read_text())[
        "anchors"
    ]
    bad = [*anchors, [[1.5, 0.0], [-0.5, 0.4]]]
    r = _post(api, source=src, target=dst, anchors=bad)
    assert r.status_code == 202, r.text
    outs = api.run_job(r.json()["id"])
    assert [o.status for o in outs] == ["failed"]
    err = api.client.get(f"/v1/jobs/{r.json()['id']}").json()["error"]
    assert err["type"] == "anchor_outside_shape" and err["field"] == f"anchors[{len(anchors)}][1]"
    assert "target" in err["message"]


def test_points_per_shape_are_capped_at_upload(make_api: Any) -> None:
    api: Api = make_api(max_shape_points=81)
    r = api.client.post(
        "/v1/shapes", files={"file": ("b.json", (SHAPES / "bar_straight.json").read_bytes())}
    )
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["type"] == "shape_too_large" and err["field"] == "file"
    assert "82 points; the limit is 81" in err["message"]
    deep = b'{"rings": ' + b"[" * 50_000 + b"]" * 50_000 + b"}"
    r = api.client.post("/v1/shapes", files={"file": ("d.json", deep)})
    assert r.status_code == 422 and "nested 50001 levels deep" in r.json()["error"]["message"]
    r = api.client.post("/v1/shapes", files={"file": ("p.svg", b"M0,0 L1,0 L0,1 Z 5 5")})
    assert r.status_code == 422 and r.json()["error"]["type"] == "bad_svg_path"


def test_default_limits_match_the_worker() -> None:
    from conformorph.geometry.tolerances import ANCHOR_COINCIDENT_RTOL
    from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS
    from conformorph.service.core.config import Settings

    assert morphs.ANCHOR_COINCIDENT_RTOL == ANCHOR_COINCIDENT_RTOL
    assert Settings().max_shape_points == DEFAULT_MAX_POINTS


def test_non_png_texture_is_refused_at_submission(api: Api) -> None:
    buf = io.BytesIO()
    Image.new("RGB", (4, 4), (1, 2, 3)).save(buf, "JPEG")
    t = api.client.post("/v1/textures", files={"file": ("t.jpg", buf.getvalue())})
    assert t.status_code == 201, t.text
    src, dst = _shape(api, "bar_straight.json"), _shape(api, "bar_bent.json")
    r = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, texture=t.json()["id"])
    assert r.status_code == 422 and r.json()["error"]["field"] == "texture"
    assert api.tasks.submitted == []


def test_a_morph_that_does_not_reach_the_target_fails_the_job_with_the_reason(
    api: Api,
) -> None:
    # The same parameters the API builds, plus strain solver caps that make the bar's
    # single step impossible (one Newton iteration, no continuation, no sub-steps, no
    # intermediate frames): the
    # job must fail with the reason, not succeed with a wrong last frame.
    src, dst = _shape(api, "bar_straight.json"), _shape(api, "bar_bent.json")
    r = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, frames=2)
    params = dict(api.store.get_job(r.json()["id"]).params)  # type: ignore[union-attr]
    params["solver_options"] = {
        "max_iterations": 1,
        "max_continuation": 1,
        "max_substeps": 0,
        "max_time_step": 1.0,
    }
    job, _ = api.store.create_job(
        owner=api.store.get_job(r.json()["id"]).owner, kind=names.KIND_MORPH2D, params=params
    )  # type: ignore[union-attr]
    outs = run_job_inline(api.runtime, job.id)
    assert [o.status for o in outs] == ["failed"]
    err = api.store.get_job(job.id).error  # type: ignore[union-attr]
    assert err["type"] == "morph_not_converged" and err["stage"] == "morph2d"
    assert "did not reach the target" in err["message"]
    assert "linear stopped at frame 1 of 2" in err["message"]
    # the uncapped job succeeds
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]


def test_pace_reaches_the_worker_and_is_checked(api: Api) -> None:
    src, dst = _shape(api, "bar_straight.json"), _shape(api, "bar_bent.json")
    r = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, frames=5, pace="even")
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    metrics = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/metrics.json").json()
    assert metrics["pace"] == "even" and len(metrics["frame_t"]) == 5
    assert metrics["frame_t"][0] == 0 and metrics["frame_t"][-1] == 1
    bad = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, pace="fast")
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "pace"


SQUARE = {"rings": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}
WIDE = {"rings": [[[0, 0], [2, 0], [2, 1], [0, 1]]]}
HALVES = [
    [[0, 0], [0, 0]],
    [[1, 0], [2, 0]],
    [[1, 1], [2, 1]],
    [[0, 1], [0, 1]],
    [[0.5, 0], [0.6, 0]],
    [[0.5, 1], [1.4, 1]],
]


def _upload(api: Api, name: str, doc: dict[str, Any]) -> str:
    r = api.client.post("/v1/shapes", files={"file": (name, json.dumps(doc).encode())})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def test_paths_dissect_both_shapes_into_patches_in_the_worker(api: Api) -> None:
    src, dst = _upload(api, "square.json", SQUARE), _upload(api, "wide.json", WIDE)
    r = _post(api, source=src, target=dst, anchors=HALVES, paths=[[4, 5]])
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    metrics = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/metrics.json").json()
    assert metrics["mesh"]["patches"] == 2 and metrics["reached_target"]
    assert metrics["methods"]["strain"]["total_flipped"] == 0


def test_malformed_paths_are_refused_and_bad_ones_fail_the_job_naming_the_path(api: Api) -> None:
    src, dst = _upload(api, "square.json", SQUARE), _upload(api, "wide.json", WIDE)
    for paths, k in (([[4, 6]], 0), ([[4, 5], [1]], 1)):
        r = _post(api, source=src, target=dst, anchors=HALVES, paths=paths)
        assert r.status_code == 422, r.text
        assert r.json()["error"]["type"] == "bad_path"
        assert r.json()["error"]["field"] == f"paths[{k}]"
    # well formed but crossing: only the worker's geometry can tell
    r = _post(api, source=src, target=dst, anchors=HALVES, paths=[[4, 5], [0, 2]])
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["failed"]
    err = api.client.get(f"/v1/jobs/{r.json()['id']}").json()["error"]
    assert err["type"] == "bad_path" and err["field"] == "paths[1]", err
    assert "cross" in err["message"]


def test_anchors_are_optional_and_the_chosen_ones_become_an_artifact(api: Api) -> None:
    src, dst = _upload(api, "sq.json", SQUARE), _upload(api, "wide.json", WIDE)
    r = _post(api, source=src, target=dst, point_budget=40)
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    assert [o.status for o in api.run_job(jid)] == ["ran"]
    job = api.client.get(f"/v1/jobs/{jid}").json()
    assert "anchors.json" in {x["name"] for x in job["artifacts"]}
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["correspondence"]["source"] == "automatic"
    assert metrics["working_resolution"]["point_budget"] == 40
    doc = api.client.get(f"/v1/jobs/{jid}/artifacts/anchors.json").json()
    assert len(doc["anchors"]) == metrics["correspondence"]["pairs"] >= 2
    # one pair seeds the matching and stays first
    seed = [[0.0, 0.0], [0.0, 0.0]]
    r = _post(api, source=src, target=dst, anchors=[seed])
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    doc = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/anchors.json").json()
    assert doc["anchors"][0] == seed
    bad = _post(api, source=src, target=dst, point_budget=2)
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "point_budget"


def test_loop_reaches_the_worker_and_is_checked(api: Api) -> None:
    from conformorph.pipelines.animation_loop import DEFAULT_LOOP, LOOP_MODES
    from conformorph.service.schemas import LOOP_DEFAULT, Morph2dCreate

    # the API's default and values are the pipeline's (one definition, checked here)
    assert LOOP_DEFAULT == DEFAULT_LOOP
    field = Morph2dCreate.model_fields["loop"]
    assert field.default == DEFAULT_LOOP and field.annotation.__args__ == LOOP_MODES  # type: ignore[union-attr]
    src, dst = _shape(api, "bar_straight.json"), _shape(api, "bar_bent.json")
    r = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, frames=4, loop="alternate")
    assert r.status_code == 202, r.text
    job_id = r.json()["id"]
    assert [o.status for o in api.run_job(job_id)] == ["ran"]
    metrics = api.client.get(f"/v1/jobs/{job_id}/artifacts/metrics.json").json()
    assert metrics["loop"] == "alternate"
    svg = api.client.get(f"/v1/jobs/{job_id}/artifacts/animation.svg").text
    assert 'repeatCount="indefinite"' in svg and 'fill="freeze"' in svg
    # the Lottie animation is one of the job's artifacts
    lottie = api.client.get(f"/v1/jobs/{job_id}/artifacts/animation.json")
    assert lottie.status_code == 200 and lottie.json()["op"] == 4
    listed = {a["name"]: a for a in api.client.get(f"/v1/jobs/{job_id}").json()["artifacts"]}
    assert listed["animation.json"]["content_type"] == "application/json"
    bad = _post(api, source=src, target=dst, anchors=BAR_ANCHORS, loop="bounce")
    assert bad.status_code == 422 and bad.json()["error"]["field"] == "loop"
