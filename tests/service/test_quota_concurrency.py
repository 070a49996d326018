"""The storage quota holds under concurrent uploads (issue 30): 40 concurrent 420 KB uploads
against a 3,000,000-byte quota store at most the quota."""

from __future__ import annotations

import asyncio

import httpx

from conformorph.service.api import uploads
from tests.fixtures.malformed_corpus import valid_disk_files
from tests.service.conftest import Api

QUOTA = 3_000_000


def _upload(k: int) -> bytes:
    """A valid disk, padded with comment lines to about 420 KB, different for each ``k``."""
    pad = b"".join(b"# pad %d %d\n" % (k, j) + b"x" * 990 + b"\n" for j in range(420))
    return valid_disk_files()["obj"] + pad


def test_concurrent_uploads_do_not_overshoot_the_quota(make_api) -> None:
    api: Api = make_api(storage_quota_bytes=QUOTA)
    files = [_upload(k) for k in range(40)]

    async def scenario() -> list[int]:
        transport = httpx.ASGITransport(app=api.app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            posts = [
                client.post("/v1/meshes", files={"file": (f"m{k}.obj", data)})
                for k, data in enumerate(files)
            ]
            return [r.status_code for r in await asyncio.gather(*posts)]

    statuses = asyncio.run(scenario())
    assert set(statuses) <= {201, 413}, statuses
    stored = api.store.storage_used("open")
    accepted = statuses.count(201)
    assert stored <= QUOTA, f"{accepted} accepted, {stored} bytes stored (quota {QUOTA})"
    assert accepted == QUOTA // len(files[0]) and stored == sum(
        len(files[k]) for k, s in enumerate(statuses) if s == 201
    )
    assert uploads._RESERVED == {}  # every reservation released
