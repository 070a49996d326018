"""``conformorph batch`` and ``submit`` with ``"landmarks": "auto"``, and the client's
``detect_landmarks`` (issue 16), against a live embedded server on the committed face."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from conformorph.cli.cmd_batch import load_manifest
from conformorph.cli.main import main
from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from conformorph_client import Client
from tests.fixtures.fixture_faces import gpp_pair
from tests.live_server import LiveServer, serve_fixture

pytestmark = pytest.mark.timeout(300)


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("auto-server"), workers=1)


def _inputs(folder: Path) -> list[str]:
    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for p in gpp_pair(folder):
        target = folder / p.name
        if p != target:
            target.write_bytes(p.read_bytes())
        names.append(p.name)
    return names


def test_manifest_takes_auto_and_still_checks_files(tmp_path: Path) -> None:
    names = _inputs(tmp_path)
    m = tmp_path / "m.json"
    m.write_text(json.dumps({"jobs": [{"name": "a", "meshes": names, "landmarks": "auto"}]}))
    (spec,) = load_manifest(m)
    assert spec.landmarks == "auto"
    m.write_text(json.dumps({"jobs": [{"name": "a", "meshes": names, "landmarks": "./auto"}]}))
    with pytest.raises(ValueError, match="auto"):  # a file named auto, which is missing
        load_manifest(m)
    m.write_text(json.dumps({"jobs": [{"name": "a", "meshes": names, "landmarks": 3}]}))
    with pytest.raises(ValueError, match="file path or \"auto\""):
        load_manifest(m)


@needs_mediapipe
def test_batch_auto_and_client_detection(
    server: LiveServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    names = _inputs(tmp_path / "in")
    jobs = [{"name": "auto", "meshes": names, "landmarks": "auto", "frames": 4,
             "remove_ears": True}]
    manifest = tmp_path / "in" / "m.json"
    manifest.write_text(json.dumps({"jobs": jobs}))
    out = tmp_path / "out"
    argv = ["batch", str(manifest), "--server", server.url, "-o", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    doc = json.loads((out / "auto" / "landmarks.json").read_text())
    assert [len(x) for x in doc["landmarks"]] == [68, 68] and "landmarks_id" in doc
    metrics = json.loads((out / "auto" / "metrics.json").read_text())
    assert metrics["landmarks"]["source"] == "auto"
    with Client(server.url) as c:
        ids = [c.upload_mesh(tmp_path / "in" / n).id for n in names]
        job = c.wait(c.detect_landmarks(ids).id, timeout=180)
        assert job.state == "succeeded", job.error
        got = json.loads(c.get_artifact(job.id, "landmarks.json"))
        stored = c.get_landmark_document(got.pop("landmarks_id"))
        assert stored == got
        morph = c.create_morph(ids, landmarks="auto", frames=3, remove_ears=True)
        assert [s.name for s in morph.stages][0] == "detect_landmarks"
        assert c.wait(morph.id, timeout=180).state == "succeeded"


@needs_mediapipe
def test_submit_auto_downloads_the_detected_landmarks(server: LiveServer, tmp_path: Path) -> None:
    names = _inputs(tmp_path / "in")
    out = tmp_path / "out"
    argv = ["submit", *(str(tmp_path / "in" / n) for n in names), "--landmarks", "auto",
            "--remove-ears", "--frames", "3", "--server", server.url, "-o", str(out), "-q"]
    assert main(argv) == 0
    doc = json.loads((out / "landmarks.json").read_text())
    assert [len(x) for x in doc["landmarks"]] == [68, 68]
    assert json.loads((out / "metrics.json").read_text())["landmarks"]["source"] == "auto"
    assert (out / "animation.glb").read_bytes()[:4] == b"glTF"
