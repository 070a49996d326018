"""The four upload routes behave alike: content-addressed ids per owner, 200 on a
repeat, 404 for another key's record, the size limit and the empty-file check."""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any

import pytest
from PIL import Image

from tests.conftest import SMALL_FACE
from tests.service.conftest import Api

SHAPE = Path(__file__).resolve().parents[1] / "fixtures" / "shapes" / "bar_straight.json"
LANDMARKS = {"landmarks": [[0, 1, 2, 3], [0, 1, 2, 3]]}


def _png() -> bytes:
    buf = io.BytesIO()
    Image.new("RGB", (8, 4), (10, 200, 10)).save(buf, "PNG")
    return buf.getvalue()


#: route, file name (None: a JSON body), payload, the kind in the id's hash (None: none)
KINDS: dict[str, tuple[str, str | None, Any, str | None]] = {
    "mesh": ("/v1/meshes", "face.obj", lambda: SMALL_FACE.read_bytes(), None),
    "shape": ("/v1/shapes", "bar.json", lambda: SHAPE.read_bytes(), "shape"),
    "texture": ("/v1/textures", "skin.png", _png, None),
    "landmarks": ("/v1/landmarks", None, lambda: LANDMARKS, "landmarks"),
}


def _post(api: Api, kind: str, key: str | None = None, payload: Any = None) -> Any:
    route, filename, make, _ = KINDS[kind]
    payload = make() if payload is None else payload
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    if filename is None:
        return api.client.post(route, json=payload, headers=headers)
    return api.client.post(route, files={"file": (filename, payload)}, headers=headers)


def _expected_id(owner: str, kind: str) -> str:
    """The id the route must give: hand-computed from the documented content address."""
    _, filename, make, space = KINDS[kind]
    payload = make()
    if filename is None:
        content = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    else:
        content = hashlib.sha256(payload).hexdigest()
    scoped = f"{owner}:{content}" if space is None else f"{owner}:{space}:{content}"
    return hashlib.sha256(scoped.encode()).hexdigest()[:32]


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_repeat_is_200_and_other_keys_get_404(api: Api, kind: str) -> None:
    kid_a, key_a = api.store.create_key("alice")
    kid_b, key_b = api.store.create_key("bob")
    first = _post(api, kind, key_a)
    assert first.status_code == 201, first.text
    assert first.json()["id"] == _expected_id(f"key-{kid_a}", kind)
    again = _post(api, kind, key_a)
    assert again.status_code == 200 and again.json() == first.json()

    route = KINDS[kind][0]
    url = f"{route}/{first.json()['id']}"
    assert api.client.get(url, headers={"Authorization": f"Bearer {key_a}"}).json() == first.json()
    other = api.client.get(url, headers={"Authorization": f"Bearer {key_b}"})
    assert other.status_code == 404
    assert other.json()["error"]["type"] == "not_found"

    # the same content from another key is a record of its own
    theirs = _post(api, kind, key_b)
    assert theirs.status_code == 201
    assert theirs.json()["id"] == _expected_id(f"key-{kid_b}", kind) != first.json()["id"]


@pytest.mark.parametrize("kind", ["mesh", "shape", "texture"])
def test_file_uploads_share_the_size_limit_and_empty_check(make_api: Any, kind: str) -> None:
    api: Api = make_api(max_upload_bytes=64, max_texture_bytes=64)
    r = _post(api, kind, payload=b"x" * 65)
    assert r.status_code == 413, r.text
    assert (r.json()["error"]["type"], r.json()["error"]["field"]) == ("payload_too_large", "file")
    r = _post(api, kind, payload=b"")
    assert r.status_code == 422
    assert (r.json()["error"]["type"], r.json()["error"]["field"]) == ("empty_file", "file")
    staged = list(api.storage.staging_dir().iterdir())
    assert staged == []  # nothing left behind by either rejection
