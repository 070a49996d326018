"""Issue 15, in-process: what an outside probe sent must get a clear 4xx (JSON saying
what and where), cost the server nothing before the caller is known, and answer
201 exactly once for one upload."""

from __future__ import annotations

import asyncio
import io
import json
import zlib
from pathlib import Path
from typing import Any

import pytest
from PIL import Image, ImageFile

from conformorph.service.api.routes.jobs import _parse_range
from conformorph.service.errors import ApiError
from tests.conftest import SMALL_FACE
from tests.service.conftest import Api

PNG = b"\x89PNG\r\n\x1a\n"


def _err(r: Any) -> dict[str, Any]:
    body = r.json()
    assert set(body) == {"error"}, body
    return body["error"]  # type: ignore[no-any-return]


# ----------------------------------------------------------------- Range (item 4)
@pytest.mark.parametrize(
    "header",
    [
        "bytes=" + "9" * 5000 + "-",
        "bytes=0-" + "9" * 5000,
        "bytes=-" + "9" * 5000,
        "bytes=" + "1" * 5000 + "-" + "2" * 5000,
        "bytes=" + "0" * 5000 + "1-",
        "bytes=" + "0" * 5000 + "-",
    ],
)
def test_long_range_numbers_are_416_or_ignored(header: str) -> None:
    try:
        got = _parse_range(header, 100)
    except ApiError as exc:
        assert exc.status == 416 and exc.field == "Range"
        assert exc.headers == {"Content-Range": "bytes */100"}
        return
    assert got is None or (0 <= got[0] <= got[1] <= 99)


def test_long_range_values_by_meaning() -> None:
    assert _parse_range("bytes=0-" + "9" * 5000, 100) == (0, 99)  # end past the size: clamped
    assert _parse_range("bytes=-" + "9" * 5000, 100) == (0, 99)  # suffix longer: whole body
    assert _parse_range("bytes=" + "0" * 5000 + "1-", 100) == (1, 99)  # leading zeros
    with pytest.raises(ApiError) as exc:
        _parse_range("bytes=" + "9" * 5000 + "-", 100)  # start past the end
    assert exc.value.status == 416


def test_long_range_on_a_real_artifact_is_not_a_500(api: Api) -> None:
    mid = api.upload(SMALL_FACE).json()["id"]
    job = api.client.post("/v1/conformal-maps", json={"mesh": mid}).json()
    api.run_job(str(job["id"]))
    url = f"/v1/jobs/{job['id']}/artifacts/quality.json"
    for rng in ("bytes=" + "9" * 5000 + "-", "bytes=0-" + "9" * 5000, "bytes=x-y", "bytes=5-1"):
        r = api.client.get(url, headers={"Range": rng})
        assert r.status_code in (200, 206, 416), (rng[:20], r.status_code)
        if r.status_code == 416:
            assert _err(r)["field"] == "Range"


# ------------------------------------------------------ authentication first (item 7)
class _Body:
    """An ASGI receive that hands out ``total`` bytes in 1 MB chunks, counting them."""

    def __init__(self, total: int) -> None:
        self.left, self.read = total, 0

    async def __call__(self) -> dict[str, Any]:
        n = min(self.left, 1 << 20)
        self.left -= n
        self.read += n
        return {"type": "http.request", "body": b"\0" * n, "more_body": self.left > 0}


def _asgi_post(api: Api, path: str, total: int, ctype: bytes, auth: bytes | None) -> Any:
    body = _Body(total)
    sent: list[dict[str, Any]] = []

    async def send(msg: dict[str, Any]) -> None:
        sent.append(msg)

    headers = [(b"content-type", ctype), (b"content-length", str(total).encode())]
    if auth is not None:
        headers.append((b"authorization", auth))
    scope = {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": path,
        "raw_path": path.encode(),
        "query_string": b"",
        "root_path": "",
        "headers": headers,
        "client": ("127.0.0.1", 5000),
        "server": ("127.0.0.1", 8000),
    }
    asyncio.run(api.app(scope, body, send))
    start = next(m for m in sent if m["type"] == "http.response.start")
    payload = b"".join(m.get("body", b"") for m in sent if m["type"] == "http.response.body")
    return start["status"], json.loads(payload), body.read


@pytest.mark.parametrize(
    ("path", "ctype"),
    [
        ("/v1/meshes", b"multipart/form-data; boundary=xyz"),
        ("/v1/textures", b"multipart/form-data; boundary=xyz"),
        ("/v1/shapes", b"multipart/form-data; boundary=xyz"),
        ("/v1/landmarks", b"application/json"),
        ("/v1/conformal-maps", b"application/json"),
        ("/v1/morphs", b"application/json"),
    ],
)
@pytest.mark.parametrize("auth", [None, b"Bearer wrong", b"Basic abc"])
def test_no_body_is_read_before_the_key_is_checked(
    api: Api, path: str, ctype: bytes, auth: bytes | None
) -> None:
    api.store.create_key("alice")
    status, body, read = _asgi_post(api, path, 3 << 20, ctype, auth)
    assert status == 401 and body["error"]["type"] == "unauthorized", body
    assert read == 0
    assert list(api.storage.staging_dir().iterdir()) == []


def test_a_valid_key_still_gets_its_body_read(api: Api) -> None:
    _, key = api.store.create_key("alice")
    status, body, read = _asgi_post(
        api, "/v1/landmarks", 10, b"application/json", f"Bearer {key}".encode()
    )
    assert status in (400, 422) and read == 10, body  # the body was parsed (and is junk)


# -------------------------------------------------------------- textures (item 8)
def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return len(data).to_bytes(4, "big") + kind + data + zlib.crc32(kind + data).to_bytes(4, "big")


def _bomb_png(w: int, h: int) -> bytes:
    """A valid RGBA PNG of ``w`` x ``h`` zero pixels: tiny file, huge decode."""
    raw = (b"\0" + b"\0" * (4 * w)) * h
    ihdr = w.to_bytes(4, "big") + h.to_bytes(4, "big") + bytes([8, 6, 0, 0, 0])
    return (
        PNG
        + _png_chunk(b"IHDR", ihdr)
        + _png_chunk(b"IDAT", zlib.compress(raw, 9))
        + _png_chunk(b"IEND", b"")
    )


def test_texture_bomb_is_refused_without_decoding(
    api: Api, monkeypatch: pytest.MonkeyPatch
) -> None:
    bomb = _bomb_png(4096, 4096)
    assert len(bomb) < 100_000

    def no_decode(self: Any) -> Any:
        raise AssertionError("the API decoded an image")

    monkeypatch.setattr(ImageFile.ImageFile, "load", no_decode)
    r = api.client.post("/v1/textures", files={"file": ("bomb.png", bomb)})
    assert r.status_code in (413, 422), r.text
    assert _err(r)["type"] == "image_too_compressed" and _err(r)["field"] == "file"
    # a real texture is still accepted, and still without a decode in the API
    buf = io.BytesIO()
    Image.new("RGB", (64, 32), (200, 10, 10)).save(buf, "PNG")
    r = api.client.post("/v1/textures", files={"file": ("skin.png", buf.getvalue())})
    assert r.status_code == 201, r.text
    assert (r.json()["width"], r.json()["height"]) == (64, 32)


def test_texture_over_the_pixel_limit_is_refused_from_its_header(make_api: Any) -> None:
    api: Api = make_api(max_texture_pixels=1000 * 1000)
    # a header claiming 100000 x 100000 with no pixel data at all
    ihdr = (100_000).to_bytes(4, "big") * 2 + bytes([8, 6, 0, 0, 0])
    fake = PNG + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IEND", b"")
    r = api.client.post("/v1/textures", files={"file": ("huge.png", fake)})
    assert r.status_code == 422 and _err(r)["type"] == "image_too_large", r.text


def test_texture_with_a_corrupt_chunk_is_invalid(api: Api) -> None:
    good = io.BytesIO()
    Image.new("RGB", (8, 8), (1, 2, 3)).save(good, "PNG")
    data = bytearray(good.getvalue())
    data[40] ^= 0xFF  # inside IDAT: its CRC no longer matches
    r = api.client.post("/v1/textures", files={"file": ("bad.png", bytes(data))})
    assert r.status_code == 422 and _err(r)["type"] == "invalid_image", r.text


# ------------------------------------------------------ no interior vertex (item 10)
def _with_interior(api: Api, n: int | None) -> None:
    real = api.tasks.validate_mesh

    def patched(*args: Any, **kw: Any) -> dict[str, Any]:
        out = real(*args, **kw)
        if n is not None and out.get("ok"):
            out["report"]["interior_vertices"] = n
        return out

    api.tasks.validate_mesh = patched  # type: ignore[method-assign]


def test_reconstruction_of_a_mesh_without_interior_vertex_is_422(api: Api) -> None:
    _with_interior(api, 0)
    mid = api.upload(SMALL_FACE).json()["id"]
    r = api.client.post("/v1/reconstructions", json={"mesh": mid})
    assert r.status_code == 422, r.text
    assert _err(r)["type"] == "no_interior_vertex" and _err(r)["field"] == "mesh"
    assert "interior" in _err(r)["message"]
    assert api.tasks.submitted == []
    # its conformal map is allowed
    assert api.client.post("/v1/conformal-maps", json={"mesh": mid}).status_code == 202


@pytest.mark.parametrize("n", [None, 7])
def test_reconstruction_with_interior_vertices_or_an_old_report_runs(
    api: Api, n: int | None
) -> None:
    _with_interior(api, n)
    mid = api.upload(SMALL_FACE).json()["id"]
    assert api.client.post("/v1/reconstructions", json={"mesh": mid}).status_code == 202


# ------------------------------------------------------- one 201 per upload (item 14)
@pytest.mark.parametrize("route", ["/v1/meshes", "/v1/textures", "/v1/shapes"])
def test_an_upload_that_loses_the_insert_race_answers_200(
    api: Api, route: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    buf = io.BytesIO()
    Image.new("RGB", (8, 4), (10, 200, 10)).save(buf, "PNG")
    shape = Path(__file__).resolve().parents[1] / "fixtures" / "shapes" / "bar_straight.json"
    name, payload = {
        "/v1/meshes": ("face.obj", SMALL_FACE.read_bytes()),
        "/v1/textures": ("skin.png", buf.getvalue()),
        "/v1/shapes": ("bar.json", shape.read_bytes()),
    }[route]
    first = api.client.post(route, files={"file": (name, payload)})
    assert first.status_code == 201, first.text
    # the second request's look-up ran before the first one's insert (a race)
    getter = {"/v1/meshes": "get_mesh", "/v1/textures": "get_texture", "/v1/shapes": "get_shape"}
    real = getattr(api.store, getter[route])
    calls: list[int] = []

    def late(owner: str, item_id: str) -> Any:
        calls.append(1)
        return None if len(calls) == 1 else real(owner, item_id)

    monkeypatch.setattr(api.store, getter[route], late)
    second = api.client.post(route, files={"file": (name, payload)})
    assert second.status_code == 200, second.text
    assert second.json() == first.json()


def test_a_landmark_upload_that_loses_the_insert_race_answers_200(
    api: Api, monkeypatch: pytest.MonkeyPatch
) -> None:
    doc = {"landmarks": [[0, 1, 2], [0, 1, 2]]}
    first = api.client.post("/v1/landmarks", json=doc)
    assert first.status_code == 201, first.text
    real = api.store.get_landmarks
    calls: list[int] = []

    def late(owner: str, set_id: str) -> Any:
        calls.append(1)
        return None if len(calls) == 1 else real(owner, set_id)

    monkeypatch.setattr(api.store, "get_landmarks", late)
    second = api.client.post("/v1/landmarks", json=doc)
    assert second.status_code == 200, second.text
    assert second.json() == first.json()


# ------------------------------------------- file type from the part (item 13)
@pytest.mark.parametrize(
    ("route", "ctype", "payload"),
    [
        ("/v1/meshes", "model/obj", SMALL_FACE.read_bytes()),
        (
            "/v1/shapes",
            "application/json",
            (
                Path(__file__).resolve().parents[1] / "fixtures/shapes/bar_straight.json"
            ).read_bytes(),
        ),
    ],
)
def test_a_part_without_extension_is_typed_by_its_content_type(
    api: Api, route: str, ctype: str, payload: bytes
) -> None:
    assert api.client.post(route, files={"file": ("file", payload, ctype)}).status_code == 201
    r = api.client.post(route, files={"file": ("file", payload, "application/octet-stream")})
    assert r.status_code == 422 and _err(r)["type"] == "unsupported_file_type"
