"""The viewer walked as a person uses it (issue 31), in headless chromium against a live
server; every walk fails on any console error or uncaught exception (a favicon 404 is one).

* a morph of two faces whose sizes differ 1000x stays in view at every frame: the
  projected bounding box of the current shape spans at least 20 % of the view;
* picking and a re-pick: the number clears after use, hover shows a label, and the
  points' provenance reaches the job's metrics;
* a bad file is named when chosen and nothing uploads; a too-large file likewise;
* a 2D pair is drawn as soon as it is chosen, before any job.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.live_server import LiveServer, serve_fixture, small_face_pair

STATE = "window.conformorphViewer.state()"
SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory, built: Path) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("viewer-walks"))


@pytest.fixture
def walk(page: Any) -> Iterator[Any]:
    """The page; afterwards, no console error may have been logged."""
    yield page
    assert not page.console_errors, page.console_errors


def _open(page: Any, url: str) -> None:
    page.goto(url + "/")
    page.wait_for_function("window.conformorphViewer !== undefined")
    page.wait_for_function(f"{STATE}.config.max_upload_bytes !== null")


def _wait_done(page: Any) -> dict[str, Any]:
    page.wait_for_function(
        f"{STATE}.loaded || {STATE}.error !== null || "
        f"['failed', 'cancelled'].includes({STATE}.jobState)",
        timeout=240_000,
    )
    state: dict[str, Any] = page.evaluate(STATE)
    assert state["loaded"] and state["error"] is None, (state, page.text_content("#status"))
    return state


def _scaled(src: Path, dest: Path, factor: float) -> Path:
    out = []
    for line in src.read_text().splitlines():
        if line.startswith("v "):
            x, y, z = (float(t) * factor for t in line.split()[1:4])
            out.append(f"v {x:.9g} {y:.9g} {z:.9g}")
        else:
            out.append(line)
    dest.write_text("\n".join(out) + "\n")
    return dest


def _spans(page: Any, follow: bool) -> list[dict[str, Any]]:
    """The projected box at 11 times across the animation (paused, scrubbed)."""
    if page.is_checked("#follow") != follow:
        page.click("#follow")
    if page.evaluate(STATE)["playing"]:
        page.click("#play")
    duration = page.evaluate(STATE)["duration"]
    spans = []
    for k in range(11):
        page.eval_on_selector(
            "#scrub", "(el, v) => { el.value = v; el.dispatchEvent(new Event('input')); }",
            str(duration * k / 10),
        )  # fmt: skip
        page.wait_for_timeout(60)  # a rendered frame: the camera has followed
        spans.append(page.evaluate("window.conformorphViewer.projected()"))
    return spans


def test_a_morph_between_numbers_1000x_apart_stays_in_view(
    server: LiveServer, walk: Any, tmp_path: Path
) -> None:
    """Face a in millimetres (160 across), face b in metres (0.16): 1000x apart in numbers,
    as a MeshMonk face beside Choi's (issue 27). The keys' units are inferred and the keys
    brought to one scale before the morph (issue 29: a real 1000x size change is refused as
    two keys whose sizes disagree), so the morph stays in view and the units line says so."""
    a, b, lm = small_face_pair(tmp_path / "in")
    big = _scaled(b, tmp_path / "in" / "face_b_in_metres.obj", 0.001)
    _open(walk, server.url)
    walk.set_input_files("#meshes", [str(a), str(big)])
    walk.set_input_files("#landmarks", str(lm))
    walk.wait_for_function(f"{STATE}.landmarks === 6 && {STATE}.checks.every(c => c && c.vertices)")
    walk.fill("#frames", "6")
    plan = walk.text_content("#plan")
    assert plan.startswith("mesh 1: 331 vertices; mesh 2: 331 vertices. 6 frames"), plan
    walk.click("#start")
    state = _wait_done(walk)
    # the size said before the job, against the GLB's (64 KB said, 69.4 KB measured:
    # position and normal targets, issue 29)
    said = float(plan.split("about ")[-1].split(" KB")[0]) * 1000
    assert 0.7 < said / state["glbBytes"] < 1.3, (plan, state["glbBytes"])
    spans = _spans(walk, follow=True)
    for k, s in enumerate(spans):
        assert s["inside"] and s["span"] >= 0.2, (k, spans)
    units = walk.text_content("#units")
    assert units.startswith("size ") and "units" in units, units
    assert "key 1 mm = 0.001 m, size; key 2 m, size" in units, units
    # metrics' per-key units (the output's report: keys' units, metres per unit, source)
    said = walk.evaluate(
        "window.conformorphViewer.unitsText({units: {working_unit: 'mm', keys: ["
        "{units: 'mm', metres_per_unit: 0.001, source: 'declared'},"
        "{units: 'm', metres_per_unit: 1, source: 'inferred'}]}})"
    )
    assert said == "key 1 mm = 0.001 m, declared; key 2 m, inferred (the animation in metres)"
    # the same frames with the camera fixed on the union of every frame's bounds: no
    # speck either, the units having brought the keys to one scale
    fixed = _spans(walk, follow=False)
    assert all(s["inside"] for s in fixed) and max(s["span"] for s in fixed) >= 0.5, fixed
    assert min(s["span"] for s in fixed) >= 0.2, fixed


def test_picks_a_re_pick_labels_and_provenance_reach_the_metrics(
    server: LiveServer, walk: Any, tmp_path: Path
) -> None:
    a, b, _ = small_face_pair(tmp_path / "in")
    _open(walk, server.url)
    walk.set_input_files("#meshes", [str(a), str(b)])
    box = walk.locator("#view").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    spots = [(0, 0), (-60, -40), (60, -40), (0, 60)]
    for mesh in ("0", "1"):
        walk.select_option("#pick-mesh", mesh)
        walk.wait_for_function(f"{STATE}.shownMesh === {mesh}")  # picking waits for it too
        for dx, dy in spots:
            walk.mouse.click(cx + dx, cy + dy)
    assert walk.evaluate(STATE)["picks"] == [4, 4]
    # hovering a marker names it (1-based, with where it came from)
    x, y = walk.evaluate("window.conformorphViewer.screenOf(2)")
    walk.mouse.move(x, y)
    walk.wait_for_function("!document.getElementById('marker-label').hidden")
    assert walk.text_content("#marker-label").startswith("landmark 3 · picked")
    walk.mouse.move(box["x"] + 5, box["y"] + 5)
    # re-pick landmark 2 of mesh 2: it moves, and the number clears after that click
    before = walk.evaluate("window.conformorphViewer.pick(1, 1)")
    walk.fill("#repick", "2")
    walk.wait_for_function("!document.getElementById('marker-label').hidden")
    assert walk.text_content("#marker-label").startswith("landmark 2")
    walk.mouse.click(cx - 30, cy + 20)
    state = walk.evaluate(STATE)
    assert walk.input_value("#repick") == "" and state["picks"] == [4, 4]
    after = walk.evaluate("window.conformorphViewer.pick(1, 1)")
    assert after != before and state["repicked"] == 1
    # the next click adds a point; it does not move landmark 2 again
    walk.mouse.click(cx + 30, cy + 20)
    assert walk.evaluate(STATE)["picks"] == [4, 5]
    assert walk.evaluate("window.conformorphViewer.pick(1, 1)") == after
    walk.click("#undo")
    walk.fill("#frames", "3")
    walk.click("#start")
    state = _wait_done(walk)
    job = httpx.get(f"{server.url}/v1/jobs/{state['jobId']}").json()
    assert job["params"]["landmark_provenance"] == [["picked"] * 4] * 2
    assert job["params"]["prepare"] == state["config"]["morph_defaults"]["prepare"] == "auto"
    metrics = httpx.get(f"{server.url}/v1/jobs/{state['jobId']}/artifacts/metrics.json").json()
    assert metrics["landmarks"]["source"] == "request"
    assert metrics["landmarks"]["counts"] == {"picked": 8}


def test_a_bad_file_is_named_when_chosen_and_nothing_uploads(
    server: LiveServer, walk: Any, tmp_path: Path
) -> None:
    a, _, lm = small_face_pair(tmp_path / "in")
    notes = tmp_path / "notes.obj"
    notes.write_text("these are my notes, not a mesh\n" * 20)
    uploads: list[str] = []
    walk.on("request", lambda r: uploads.append(r.url) if r.method == "POST" else None)
    _open(walk, server.url)
    walk.set_input_files("#meshes", [str(a), str(notes)])
    walk.wait_for_function(f"{STATE}.checks.every(c => c !== null)")
    listed = walk.text_content("#mesh-list")
    assert "notes.obj: not an OBJ mesh" in listed and "face_a.obj (" in listed, listed
    assert "KB" in listed or "MB" in listed
    assert "notes.obj" in walk.text_content("#status")
    walk.set_input_files("#landmarks", str(lm))
    walk.click("#start")
    walk.wait_for_function("document.getElementById('status').textContent.includes('nothing')")
    assert "notes.obj" in walk.text_content("#status") and uploads == []
    # a file over the server's upload limit (here the limit is lowered in the page's
    # copy of /viewer/config.json) is refused before the first file uploads
    walk.evaluate(f"{STATE}.config.max_upload_bytes = 2000")
    walk.set_input_files("#meshes", [str(a), str(a)])
    walk.wait_for_function(f"{STATE}.checks.every(c => c !== null)")
    assert "over the server's upload limit" in walk.text_content("#mesh-list")
    walk.click("#start")
    walk.wait_for_function("document.getElementById('status').textContent.includes('nothing')")
    assert uploads == []


def test_a_heavy_job_says_its_working_resolution_first(
    server: LiveServer, walk: Any, tmp_path: Path
) -> None:
    a, _, _ = small_face_pair(tmp_path / "in")
    n = 260  # a 260 x 260 grid: 67,600 vertices, above the default vertex budget
    grid = tmp_path / "grid.obj"
    rows = [f"v {i % n} {i // n} {((i % n) - n / 2) ** 2 / n}" for i in range(n * n)]
    rows += [
        f"f {i + j * n + 1} {i + 1 + j * n + 1} {i + (j + 1) * n + 1}"
        for j in range(n - 1) for i in range(n - 1)
    ]  # fmt: skip
    grid.write_text("\n".join(rows) + "\n")
    _open(walk, server.url)
    walk.set_input_files("#meshes", [str(grid), str(a)])
    walk.wait_for_function(f"{STATE}.checks.every(c => c && c.vertices)")
    budget = walk.evaluate(STATE)["config"]["morph_defaults"]["vertex_budget"]
    plan = walk.text_content("#plan")
    assert plan.startswith(
        f"mesh 1: {n * n:,} vertices → about {budget:,} (the server's working resolution)"
    ), plan
    assert "decimation" in plan and "MB" in plan


def test_a_2d_pair_is_drawn_as_soon_as_it_is_chosen(server: LiveServer, walk: Any) -> None:
    _open(walk, server.url)
    walk.click("#tab-2d")
    walk.set_input_files(
        "#shapes", [str(SHAPES / "bar_straight.svg"), str(SHAPES / "bar_bent.json")]
    )
    walk.wait_for_function(
        "(() => { const s = window.conformorphViewer.state2d(); "
        "return s.previewed.source && s.previewed.target; })()"
    )
    state = walk.evaluate("window.conformorphViewer.state2d()")
    assert state["jobId"] is None and state["frames"] == 0
    for side in ("source", "target"):
        d = walk.get_attribute(f"#corr-{side} path.shape2d", "d")
        assert d and d.count(",") >= 3 or d.count(" ") >= 3
        w, h = walk.evaluate(
            f"(() => {{ const b = document.querySelector('#corr-{side} path').getBoundingClientRect(); "
            "return [b.width, b.height]; })()"
        )
        assert w > 50 and h > 10, (side, w, h)  # drawn at a visible size
