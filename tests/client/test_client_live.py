"""The client against a live embedded server (``conformorph serve`` with a real Celery worker)."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import numpy as np
import pytest

from conformorph_client import (
    AsyncClient,
    Client,
    Conflict,
    InvalidInput,
    JobFailed,
    NotFound,
    Unauthorized,
)
from conformorph_client.models import JobPublic
from tests.live_server import LiveServer, small_face_pair

SMALL_FACE = Path(__file__).resolve().parents[1] / "fixtures" / "service_small_face.obj"
SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"

pytestmark = pytest.mark.timeout(180)


def test_conformal_map_round_trip(live_server: LiveServer, tmp_path: Path) -> None:
    with Client(live_server.url) as c:
        assert c.healthz().status == "ok"
        assert c.readyz().status == "ready"
        mesh = c.upload_mesh(SMALL_FACE)
        assert mesh.vertices == sum(
            1 for line in SMALL_FACE.read_text().splitlines() if line.startswith("v ")
        )
        assert c.upload_mesh(("other-name.obj", SMALL_FACE.read_bytes())).id == mesh.id
        job = c.create_conformal_map(mesh.id)
        assert job.state == "queued" and job.kind == "conformal_map"
        seen: list[JobPublic] = []
        done = c.wait(job.id, on_update=seen.append, timeout=120)
        assert done.state == "succeeded" and done.progress == 1.0
        assert seen[-1].state == "succeeded"
        assert [p.progress for p in seen] == sorted(p.progress for p in seen)
        arts = {a.name: a for a in done.artifacts}
        dest = c.download(job.id, "disk_map.npz", tmp_path / "disk_map.npz")
        with np.load(dest) as z:
            uv = z["uv"]
        assert uv.shape == (mesh.vertices, 2)
        assert np.all(np.hypot(uv[:, 0], uv[:, 1]) <= 1 + 1e-9)
        q = c.get_artifact(job.id, "quality.json")
        assert len(q) == arts["quality.json"].size and json.loads(q)
        assert c.get_artifact(job.id, "quality.json", byte_range=(5, 14)) == q[5:15]
        assert dest.stat().st_size == arts["disk_map.npz"].size
        # HEAD over real HTTP: the same type, size and ETag the job lists, no bytes
        assert c.head_artifact(job.id, "quality.json") == arts["quality.json"]
        with pytest.raises(NotFound):
            c.head_artifact(job.id, "nope.json")
        assert job.id in {j.id for j in c.iter_jobs(state="succeeded", page_size=1)}
        assert c.delete_job(job.id) is None
        with pytest.raises(NotFound):
            c.get_job(job.id)


def test_server_errors_reach_the_caller(live_server: LiveServer) -> None:
    with Client(live_server.url) as c:
        with pytest.raises(InvalidInput) as info:
            c.upload_mesh(("broken.obj", b"v 0 0 0\nf 1 2 3\n"))
        assert info.value.field == "file" and info.value.message
        mesh = c.upload_mesh(SMALL_FACE)
        with pytest.raises(InvalidInput) as info:
            c.create_conformal_map(mesh.id, center_vertex=mesh.vertices)
        assert info.value.field == "center_vertex"
        assert str(mesh.vertices) in info.value.message
        with pytest.raises(NotFound):
            c.create_reconstruction("0" * 32)
        # not an id the server makes: refused before any look-up
        with pytest.raises(InvalidInput) as info:
            c.create_reconstruction("no-such-mesh")
        assert info.value.field == "mesh"


def test_idempotency_key_returns_the_same_job(live_server: LiveServer) -> None:
    with Client(live_server.url) as c:
        mesh = c.upload_mesh(SMALL_FACE)
        a = c.create_reconstruction(mesh.id, idempotency_key="client-live-1")
        b = c.create_reconstruction(mesh.id, idempotency_key="client-live-1")
        assert a.id == b.id
        with pytest.raises(Conflict):
            c.create_reconstruction(mesh.id, curvature="scalar", idempotency_key="client-live-1")
        done = c.wait(a.id, timeout=120)
        assert "reconstruction.obj" in {x.name for x in done.artifacts}


def test_async_client_live(live_server: LiveServer, tmp_path: Path) -> None:
    async def run() -> tuple[JobPublic, list[JobPublic]]:
        async with AsyncClient(live_server.url) as c:
            mesh = await c.upload_mesh(SMALL_FACE)
            jobs = await asyncio.gather(
                c.create_conformal_map(mesh.id), c.create_conformal_map(mesh.id, method="fast")
            )
            seen: list[JobPublic] = []
            done = await asyncio.gather(
                *(c.wait(j.id, on_update=seen.append, timeout=120) for j in jobs)
            )
            await c.download(done[0].id, "quality.json", tmp_path / "q.json")
            head = await c.head_artifact(done[0].id, "quality.json")
            assert head.size == (tmp_path / "q.json").stat().st_size
            return done[0], seen

    done, seen = asyncio.run(run())
    assert done.state == "succeeded" and seen
    assert json.loads((tmp_path / "q.json").read_text())


def test_keyed_server_needs_the_key_and_isolates(keyed_server: LiveServer) -> None:
    assert keyed_server.api_key
    with Client(keyed_server.url) as anonymous, pytest.raises(Unauthorized) as info:
        anonymous.list_jobs()
    assert "API key" in info.value.message
    with Client(keyed_server.url, api_key="not-a-key") as wrong, pytest.raises(Unauthorized):
        wrong.list_jobs()
    other_key = keyed_server.create_key("other")
    with Client(keyed_server.url, api_key=keyed_server.api_key) as c:
        mesh = c.upload_mesh(SMALL_FACE)
        job = c.create_conformal_map(mesh.id)
        with Client(keyed_server.url, api_key=other_key) as other:
            with pytest.raises(NotFound):
                other.get_job(job.id)
            with pytest.raises(NotFound):
                other.get_mesh(mesh.id)
        assert c.wait(job.id, timeout=120).state == "succeeded"


def test_face_morph_through_the_client(live_server: LiveServer, tmp_path: Path) -> None:
    a, b, lm = small_face_pair(tmp_path / "in")
    landmarks = json.loads(lm.read_text())["landmarks"]
    with Client(live_server.url) as c:
        ids = [c.upload_mesh(a).id, c.upload_mesh(b).id]
        job = c.create_morph(ids, landmarks=landmarks, frames=5, method="dmt")
        assert job.kind == "morph" and job.params["frames"] == 5
        stages_seen: set[str] = set()
        done = c.wait(job.id, timeout=120, on_update=lambda j: stages_seen.add(j.stage or ""))
        assert {s.name for s in done.stages} >= {"prepare", "register", "frames", "export"}
        assert all(s.state == "done" for s in done.stages)
        assert stages_seen - {""}
        glb = c.download(done.id, "animation.glb", tmp_path / "animation.glb")
        assert glb.read_bytes()[:4] == b"glTF"
        assert json.loads(c.get_artifact(done.id, "metrics.json"))
        bad = c.create_morph(ids, landmarks=[[0, 1, 100000], landmarks[1][:3]])
        with pytest.raises(JobFailed) as info:
            c.wait(bad.id, timeout=120)
        assert info.value.stage == "prepare" and "100000" in info.value.message


def test_landmark_sets_through_the_client(live_server: LiveServer, tmp_path: Path) -> None:
    a, b, lm = small_face_pair(tmp_path / "in")
    document = json.loads(lm.read_text())
    with Client(live_server.url) as c:
        ids = [c.upload_mesh(a).id, c.upload_mesh(b).id]
        first = c.upload_landmarks(document)
        assert c.upload_landmarks(document).id == first.id
        got = c.get_landmarks(first.id)
        assert got.meshes == 2 and got.landmarks_per_mesh == len(document["landmarks"][0])
        with pytest.raises(NotFound):
            c.get_landmarks("0" * 32)
        with pytest.raises(InvalidInput):
            c.upload_landmarks({"landmarks": [[0, 1], [0, 1]]})
        job = c.wait(c.create_morph(ids, landmarks_id=first.id, frames=3).id, timeout=120)
        assert job.state == "succeeded"


def test_morph2d_through_the_client(live_server: LiveServer) -> None:
    with Client(live_server.url) as c:
        src = c.upload_shape(SHAPES / "bar_straight.json")
        dst = c.upload_shape(SHAPES / "bar_bent.json")
        assert c.get_shape(src.id).rings == src.rings >= 1
        anchors = json.loads((SHAPES / "bar_anchors.json").read_text())["anchors"]
        job = c.wait(c.create_morph2d(src.id, dst.id, anchors=anchors, frames=4).id, timeout=120)
        assert {"animation.glb", "metrics.json"} <= {x.name for x in job.artifacts}
        with pytest.raises(InvalidInput) as info:
            c.create_morph2d(src.id, dst.id, anchors=[[[0.0, 0.0]]] * 2)
        assert info.value.field is not None and info.value.field.startswith("anchors")


def test_textures(live_server: LiveServer, tmp_path: Path) -> None:
    from PIL import Image

    png = tmp_path / "skin.png"
    Image.new("RGB", (8, 4), (200, 150, 120)).save(png)
    with Client(live_server.url) as c:
        tex = c.upload_texture(png)
        assert (tex.width, tex.height, tex.content_type) == (8, 4, "image/png")
        assert c.get_texture(tex.id).id == tex.id == c.upload_texture(png).id
        with pytest.raises(InvalidInput) as info:
            c.upload_texture(("not.png", b"this is no image"))
        assert info.value.field == "file"
