"""``/v1/textures``: PNG or JPEG images for morphs, checked with Pillow, size-limited."""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, File, Response, UploadFile
from fastapi.concurrency import run_in_threadpool
from PIL import Image, UnidentifiedImageError

from service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep
from service.api.uploads import (
    content_id,
    find_repeat,
    get_owned,
    spooled,
    stored_filename,
    upload_errors,
    upload_responses,
)
from service.errors import ApiError
from service.schemas import TexturePublic
from worker.job_store import TextureView

router = APIRouter(prefix="/v1/textures", tags=["textures"])

_FORMATS = {"PNG": ("image/png", "png"), "JPEG": ("image/jpeg", "jpg")}
ERRORS = upload_errors(
    "no such texture for this key",
    "not a PNG or JPEG image within the limits",
    worker_validated=False,
)


def _public(t: TextureView) -> TexturePublic:
    return TexturePublic(
        id=t.id,
        filename=t.filename,
        content_type=t.content_type,
        size_bytes=t.size_bytes,
        width=t.width,
        height=t.height,
        created_at=t.created_at,
    )


def inspect_image(path: Path, max_pixels: int) -> tuple[str, int, int]:
    """(format, width, height) of a PNG/JPEG, fully decoded once; ApiError 422 otherwise."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(path) as im:
                fmt = im.format or ""
                w, h = im.size
                if fmt not in _FORMATS:
                    raise ApiError(
                        422,
                        "unsupported_image",
                        f"image format {fmt or 'unknown'}; expected PNG or JPEG",
                        "file",
                    )
                if w * h > max_pixels:
                    raise ApiError(
                        422,
                        "image_too_large",
                        f"image is {w}x{h} = {w * h} pixels; the limit is {max_pixels}",
                        "file",
                    )
                im.load()
    except ApiError:
        raise
    except (
        UnidentifiedImageError,
        OSError,
        SyntaxError,
        ValueError,
        Image.DecompressionBombWarning,
        Image.DecompressionBombError,
    ) as exc:
        raise ApiError(
            422, "invalid_image", f"not a readable PNG or JPEG image: {exc}", "file"
        ) from exc
    return fmt, w, h


@router.post(
    "",
    operation_id="upload_texture",
    status_code=201,
    responses=upload_responses(TexturePublic, ERRORS),
)
async def upload_texture(
    file: Annotated[UploadFile, File(description="PNG or JPEG image")],
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    storage: StorageDep,
    response: Response,
) -> TexturePublic:
    """Upload a texture image (PNG or JPEG)."""
    async with spooled(file, storage, settings.max_texture_bytes) as up:
        fmt, w, h = await run_in_threadpool(inspect_image, up.path, settings.max_texture_pixels)
        tex_id = content_id(owner, up.sha256)
        existing = await find_repeat(store.get_texture, owner, tex_id, response)
        if existing is not None:
            return _public(existing)
        ctype, ext = _FORMATS[fmt]
        key = f"textures/{owner}/{tex_id}.{ext}"
        await run_in_threadpool(storage.put_file, key, up.path, move=True)
        view = TextureView(
            owner=owner,
            id=tex_id,
            filename=stored_filename(file.filename, f"texture.{ext}"),
            content_type=ctype,
            storage_key=key,
            size_bytes=up.size,
            width=w,
            height=h,
            created_at=time.time(),
        )
        return _public(await run_in_threadpool(store.add_texture, view))


@router.get("/{texture_id}", operation_id="get_texture", responses=ERRORS)
async def get_texture(texture_id: str, owner: OwnerDep, store: StoreDep) -> TexturePublic:
    """An uploaded texture's record (404 for other keys' textures)."""
    return _public(await get_owned(store.get_texture, owner, texture_id, "texture", "texture_id"))
