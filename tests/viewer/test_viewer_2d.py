"""The viewer's 2D tab end to end (issue 18): chromium + Playwright against a live server.

Choose two shapes, start (``POST /v1/shapes`` twice, ``POST /v1/morphs2d``), see
the job's corresponding points (``anchors.json``) drawn as numbered points on
the source and the target, play ``frames.json``, download the job's files;
drag a point to another outline vertex and start again: the corrected points
are the new job's anchors.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

from tests.live_server import LiveServer, serve_fixture

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
STATE2D = "window.conformorphViewer.state2d()"

pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory, built: Path) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("viewer-2d"))


def _open_2d(page: Any, url: str) -> None:
    page.goto(url + "/")
    page.wait_for_function("window.conformorphViewer !== undefined")
    assert page.is_hidden("#panel2d") and page.is_visible("#panel3d")
    page.click("#tab-2d")
    assert page.is_visible("#panel2d") and page.is_hidden("#stage-area")


def _wait_job(page: Any, previous: str | None = None) -> dict[str, Any]:
    page.wait_for_function(
        f"({STATE2D}.loadedJob !== null && {STATE2D}.loadedJob !== {json.dumps(previous)} && "
        f"{STATE2D}.loadedJob === {STATE2D}.jobId) || {STATE2D}.error !== null",
        timeout=180_000,
    )
    state: dict[str, Any] = page.evaluate(STATE2D)
    assert state["error"] is None, (state, page.text_content("#status2d"))
    assert state["jobState"] == "succeeded" and state["frames"] > 0
    return state


def _frames(server: LiveServer, job_id: str) -> dict[str, Any]:
    r = httpx.get(f"{server.url}/v1/jobs/{job_id}/artifacts/frames.json")
    assert r.status_code == 200
    doc: dict[str, Any] = r.json()
    return doc


def _ring(d: str) -> np.ndarray:
    return np.array(
        [
            [float(v) for v in p.split(",")]
            for p in d.replace("M", "").replace("L", "").replace("Z", "").split()
        ]
    )


def _screen_point(page: Any, svg: str, x: float, y: float) -> tuple[float, float]:
    """Page coordinates of the SVG point (x, y) of the svg element ``svg``."""
    p = page.evaluate(
        """([id, x, y]) => {
          const m = document.getElementById(id).getScreenCTM();
          const p = new DOMPoint(x, y).matrixTransform(m);
          return [p.x, p.y];
        }""",
        [svg, x, y],
    )
    return float(p[0]), float(p[1])


def test_two_shapes_morph_show_points_play_and_download(server: LiveServer, page: Any) -> None:
    _open_2d(page, server.url)
    page.set_input_files("#shapes", [str(SHAPES / "dejavu_bold_C.json")])
    page.click("#start2d")  # one shape: refused in the browser
    page.wait_for_function(f"{STATE2D}.error !== null")
    assert "choose two shapes" in page.text_content("#status2d")

    page.set_input_files(
        "#shapes", [str(SHAPES / "dejavu_bold_C.json"), str(SHAPES / "dejavu_bold_U.json")]
    )
    page.fill("#frames2d", "12")
    page.click("#start2d")
    state = _wait_job(page)
    assert state["frames"] == 12 and state["sentAnchors"] is None
    job = httpx.get(f"{server.url}/v1/jobs/{state['jobId']}").json()
    assert job["params"]["frames"] == 12 and job["params"].get("anchors") is None
    # the points drawn are the job's anchors.json, numbered 1 … n on both shapes
    chosen = httpx.get(f"{server.url}/v1/jobs/{state['jobId']}/artifacts/anchors.json").json()
    n = len(chosen["anchors"])
    assert n >= 2 and state["anchors"] == chosen["anchors"]
    assert state["drawn"] == {"source": n, "target": n}
    for side in ("source", "target"):
        labels = page.eval_on_selector_all(
            f"#corr-{side} g.anchor2d text", "els => els.map(e => e.textContent)"
        )
        assert labels == [str(i + 1) for i in range(n)]
    # it plays: the frame advances on its own, and the path follows frames.json
    assert state["playing"]
    seen = set()
    for _ in range(10):
        page.wait_for_timeout(120)
        seen.add(page.evaluate(STATE2D)["frame"])
    assert len(seen) >= 3, seen
    frames = _frames(server, state["jobId"])["frames"]
    page.click("#play2d")
    page.eval_on_selector(
        "#scrub2d", "el => { el.value = '5'; el.dispatchEvent(new Event('input')); }"
    )
    assert page.evaluate(STATE2D)["frame"] == 5 and not page.evaluate(STATE2D)["playing"]
    drawn = _ring(page.get_attribute("#anim2d-path", "d").split("Z")[0] + "Z")
    assert np.allclose(drawn, _ring(frames[5]["outline"]), atol=1e-5)
    # the job's files, offered as downloads
    page.wait_for_function(f"{STATE2D}.downloads.length === 5")
    svg = page.evaluate(
        """() => fetch(document.querySelector('#downloads2d a[data-name="animation.svg"]').href)
                 .then(r => r.text())"""
    )
    assert svg.startswith("<?xml") and "<animate" in svg


def test_a_dragged_point_is_sent_as_anchors(server: LiveServer, page: Any) -> None:
    _open_2d(page, server.url)
    page.set_input_files(
        "#shapes", [str(SHAPES / "dejavu_bold_C.json"), str(SHAPES / "dejavu_bold_U.json")]
    )
    page.fill("#frames2d", "8")
    page.click("#start2d")
    first = _wait_job(page)
    anchors = first["anchors"]
    # a source outline vertex far from every anchor: where point 1 is dragged to
    outline = _ring(_frames(server, first["jobId"])["frames"][0]["outline"])
    used = np.array([[a[0][0], -a[0][1]] for a in anchors])
    far = outline[np.argmax(np.min(np.linalg.norm(outline[:, None] - used[None], axis=2), 1))]
    box = page.locator('#corr-source g.anchor2d[data-index="0"] circle').bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.down()
    x, y = _screen_point(page, "corr-source", float(far[0]), float(far[1]))
    page.mouse.move(x + 2, y - 1, steps=8)  # near it: the drop snaps to the vertex
    page.mouse.up()
    state = page.evaluate(STATE2D)
    assert state["corrected"]
    assert state["anchors"][0][0] == pytest.approx([far[0], -far[1]], abs=1e-6)
    assert state["anchors"][1:] == anchors[1:] and state["anchors"][0][1] == anchors[0][1]
    assert "corrected" in page.text_content("#anchor-info")

    page.click("#start2d")
    second = _wait_job(page, previous=first["jobId"])
    assert second["sentAnchors"] == state["anchors"]
    params = httpx.get(f"{server.url}/v1/jobs/{second['jobId']}").json()["params"]
    assert np.allclose(params["anchors"], state["anchors"])
    # the new morph starts from the source and ends on the target with those points
    frames = _frames(server, second["jobId"])["frames"]
    ring0 = _ring(frames[0]["outline"])
    assert np.min(np.linalg.norm(ring0 - far, axis=1)) < 1e-3
    assert second["anchors"] == state["anchors"] and not second["corrected"]
