"""``/v1/textures``: PNG or JPEG images for morphs, checked from their headers, size-limited."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, File, Response, UploadFile
from fastapi.concurrency import run_in_threadpool
from PIL import Image, UnidentifiedImageError

from conformorph.service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep
from conformorph.service.api.uploads import (
    add_once,
    content_id,
    find_repeat,
    get_owned,
    quota_reserved,
    spooled,
    stored_filename,
    upload_errors,
    upload_responses,
)
from conformorph.service.core.config import Settings
from conformorph.service.errors import ApiError
from conformorph.service.schemas import TexturePublic
from conformorph.worker.job_store import TextureView

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


#: bytes per pixel of the modes a PNG/JPEG opens as (others count as 4)
_MODE_BYTES = {"1": 1, "L": 1, "P": 1, "LA": 2, "I;16": 2, "RGB": 3, "YCbCr": 3}


def inspect_image(path: Path, limits: TextureLimits) -> tuple[str, int, int]:
    """(format, width, height) of a PNG/JPEG from its header, never decoded here.

    The API does not decode textures (the workers do, where the numerics run):
    Pillow's ``open`` reads the header only; the declared pixels must be within
    ``limits.max_pixels`` and, for an image whose decode would take more than
    ``limits.ratio_floor_bytes``, its decoded size at most ``limits.max_ratio``
    times the file's size (a tiny file that decodes to a huge one is refused);
    a PNG's chunk checksums are verified without decompressing. ApiError 422
    (``unsupported_image``, ``image_too_large``, ``image_too_compressed`` or
    ``invalid_image``) otherwise.
    """
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
                _check_declared_size(w, h, _MODE_BYTES.get(im.mode, 4), path, limits)
                if fmt == "PNG":
                    im.verify()  # chunk CRCs, no decompression
    except ApiError:
        raise
    except (Image.DecompressionBombWarning, Image.DecompressionBombError) as exc:
        raise ApiError(422, "image_too_large", f"image too large: {exc}", "file") from exc
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise ApiError(
            422, "invalid_image", f"not a readable PNG or JPEG image: {exc}", "file"
        ) from exc
    return fmt, w, h


def _check_declared_size(w: int, h: int, depth: int, path: Path, limits: TextureLimits) -> None:
    """422 when the header's ``w`` x ``h`` (``depth`` bytes a pixel) is over a limit."""
    if w * h > limits.max_pixels:
        raise ApiError(
            422,
            "image_too_large",
            f"image is {w}x{h} = {w * h} pixels; the limit is {limits.max_pixels}",
            "file",
        )
    decoded, size = w * h * depth, max(1, path.stat().st_size)
    if decoded > limits.ratio_floor_bytes and decoded > limits.max_ratio * size:
        raise ApiError(
            422,
            "image_too_compressed",
            f"image is {w}x{h} ({decoded} bytes decoded) from a {size}-byte file, "
            f"{decoded / size:.0f} times larger; the limit is {limits.max_ratio:g} times "
            f"for images over {limits.ratio_floor_bytes} bytes decoded",
            "file",
        )


@dataclass(frozen=True)
class TextureLimits:
    """What a texture upload may declare (from :class:`conformorph.service.core.config.Settings`)."""

    #: most pixels (width x height)
    max_pixels: int
    #: largest decoded size / file size, for images over ``ratio_floor_bytes`` decoded
    max_ratio: float
    ratio_floor_bytes: int

    @classmethod
    def of(cls, settings: Settings) -> TextureLimits:
        return cls(
            settings.max_texture_pixels,
            settings.max_texture_ratio,
            settings.texture_ratio_floor_bytes,
        )


@router.post(
    "",
    operation_id="upload_texture",
    status_code=201,
    responses=upload_responses(TexturePublic, ERRORS),
)
async def upload_texture(
    file: Annotated[
        UploadFile,
        File(
            description="PNG or JPEG image, not empty (its type is read from its bytes)",
            json_schema_extra={"minLength": 1},
        ),
    ],
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    storage: StorageDep,
    response: Response,
) -> TexturePublic:
    """Upload a texture image (PNG or JPEG)."""
    async with spooled(file, storage, settings.max_texture_bytes) as up:
        fmt, w, h = await run_in_threadpool(inspect_image, up.path, TextureLimits.of(settings))
        tex_id = content_id(owner, up.sha256)
        existing = await find_repeat(store.get_texture, owner, tex_id, response)
        if existing is not None:
            return _public(existing)
        async with quota_reserved(store, owner, settings, up.size):
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
            return _public(await add_once(store.add_texture, view, response))


@router.get("/{texture_id}", operation_id="get_texture", responses=ERRORS)
async def get_texture(texture_id: str, owner: OwnerDep, store: StoreDep) -> TexturePublic:
    """An uploaded texture's record (404 for other keys' textures)."""
    return _public(await get_owned(store.get_texture, owner, texture_id, "texture", "texture_id"))
