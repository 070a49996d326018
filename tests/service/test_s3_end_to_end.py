"""The API and a real Celery worker on S3 artifact storage (moto's S3 server on 127.0.0.1).

The API and the worker have separate data folders, as on two hosts: the
only things they share are Redis (broker), the job store and the bucket. Meshes
are uploaded, a morph job runs, and ``animation.glb`` is downloaded whole and
by a Range request, streamed by the API, then through a second API that
redirects downloads to presigned URLs.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import httpx
import pytest

from conformorph_client import Client
from tests.live_server import SMALL_FACE_LANDMARKS, LiveServer, server_env, small_face_pair
from tests.s3_server import S3Endpoint

pytestmark = [pytest.mark.timeout(400), pytest.mark.redis, pytest.mark.slow]


def _started(data_dir: Path, env: dict[str, str]) -> LiveServer:
    """An API without workers of its own (``--workers 0``), answering."""
    srv = LiveServer(data_dir, workers=0, env=env)
    srv.wait_ready(probe="/healthz")
    return srv


def _bucket_keys(moto_s3: S3Endpoint, bucket: str) -> list[str]:
    listed = moto_s3.client().list_objects_v2(Bucket=bucket)
    return [str(o["Key"]) for o in listed.get("Contents", [])]


def _no_local_artifacts(data_dir: Path) -> bool:
    """No artifact on the local disk: no local storage folder, nothing cached but
    copies named by their content."""
    return not (data_dir / "artifacts").exists()


def test_morph_job_on_s3_storage(
    tmp_path: Path, moto_s3: S3Endpoint, redis_url: str, start_worker: Any
) -> None:
    bucket = moto_s3.new_bucket()
    shared = {
        **moto_s3.env(bucket, prefix="cm"),
        "CONFORMORPH_BROKER_URL": redis_url,
        "CONFORMORPH_DATABASE_URL": f"sqlite:///{tmp_path / 'jobs.sqlite'}",
    }
    servers: list[LiveServer] = []
    try:
        api = _started(tmp_path / "api", shared)
        servers.append(api)
        start_worker({**server_env(tmp_path / "worker"), **shared}, log=tmp_path / "worker.log")
        api.wait_ready(probe="/readyz")  # the storage answers and a worker validates
        ready = httpx.get(f"{api.url}/readyz").json()
        assert ready["checks"]["storage"] is True

        a, b, _ = small_face_pair(tmp_path / "in")
        with Client(api.url) as c:
            ids = [c.upload_mesh(p).id for p in (a, b)]
            lm = [SMALL_FACE_LANDMARKS, SMALL_FACE_LANDMARKS]
            job = c.wait(c.create_morph(ids, landmarks=lm, frames=4).id, timeout=300)
            assert job.state == "succeeded", job
            glb = c.download(job.id, "animation.glb", tmp_path / "out" / "animation.glb")
        data = glb.read_bytes()
        assert data[:4] == b"glTF"

        keys = _bucket_keys(moto_s3, bucket)
        assert sum(k.startswith("cm/meshs/") for k in keys) == 2  # the uploads (sic: f"{kind}s")
        stored = [
            k for k in keys if k.startswith(f"cm/jobs/{job.id}/") and k.endswith("/animation.glb")
        ]
        assert len(stored) == 1
        got = moto_s3.client().get_object(Bucket=bucket, Key=stored[0])["Body"].read()
        assert got == data  # the API served the object's bytes
        assert _no_local_artifacts(tmp_path / "api") and _no_local_artifacts(tmp_path / "worker")

        url = f"{api.url}/v1/jobs/{job.id}/artifacts/animation.glb"
        part = httpx.get(url, headers={"Range": "bytes=4-15"})
        assert part.status_code == 206 and part.content == data[4:16]
        assert part.headers["content-range"] == f"bytes 4-15/{len(data)}"
        tail = httpx.get(url, headers={"Range": "bytes=-10"})
        assert tail.status_code == 206 and tail.content == data[-10:]
        etag = f'"{hashlib.sha256(data).hexdigest()}"'
        head = httpx.head(url)
        assert head.headers["etag"] == etag and int(head.headers["content-length"]) == len(data)
        assert httpx.get(url, headers={"If-None-Match": etag}).status_code == 304
        past = httpx.get(url, headers={"Range": f"bytes={len(data)}-"})
        assert past.status_code == 416

        # a second API that hands out presigned URLs instead of streaming
        redirecting = _started(
            tmp_path / "api2", {**shared, "CONFORMORPH_S3_DOWNLOADS": "redirect"}
        )
        servers.append(redirecting)
        url2 = f"{redirecting.url}/v1/jobs/{job.id}/artifacts/animation.glb"
        r = httpx.get(url2)
        assert r.status_code == 307 and r.headers["etag"] == etag
        assert r.headers["location"].startswith(f"{moto_s3.url}/{bucket}/cm/jobs/{job.id}/")
        assert httpx.get(url2, headers={"If-None-Match": etag}).status_code == 304
        ranged = httpx.get(url2, headers={"Range": "bytes=4-15"}, follow_redirects=True)
        assert ranged.status_code == 206 and ranged.content == data[4:16]
        with Client(redirecting.url) as c:
            again = c.download(job.id, "animation.glb", tmp_path / "out2" / "animation.glb")
            assert again.read_bytes() == data
            assert c.get_artifact(job.id, "metrics.json")[:1] == b"{"
            c.delete_job(job.id)  # a finished job: its record and its objects go
        assert not any(k.startswith(f"cm/jobs/{job.id}/") for k in _bucket_keys(moto_s3, bucket))
    finally:
        for srv in servers:
            srv.stop()
