"""The browser viewer: ``/`` serves its page, ``/viewer/{name}`` its bundled assets.

The assets are built from ``viewer/`` (three.js from npm, bundled by esbuild)
into ``service/static/`` by ``npm install && npm run build:viewer``, which the
README's set-up commands run. Without a build, ``/`` answers 404 saying how to
build it.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from fastapi.responses import FileResponse, Response

from service.errors import ApiError

STATIC_DIR = Path(__file__).resolve().parent / "static"
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".txt": "text/plain; charset=utf-8",
}


def _asset(name: str, static_dir: Path) -> Path:
    try:
        path = (static_dir / name).resolve()
    except (ValueError, OSError):  # e.g. a NUL in the name
        path = static_dir
    if static_dir.resolve() not in path.parents or path.suffix not in _TYPES or not path.is_file():
        raise ApiError(404, "not_found", f"no viewer asset {name!r}", "name")
    return path


def install_viewer(app: FastAPI, static_dir: Path = STATIC_DIR) -> None:
    """Add ``GET /`` and ``GET /viewer/{name}`` (not part of the API's OpenAPI document)."""

    @app.get("/", include_in_schema=False)
    def viewer_page() -> Response:
        if not (static_dir / "index.html").is_file():
            raise ApiError(
                404,
                "viewer_not_built",
                "the browser viewer is not built: run 'npm install && npm run build:viewer'",
            )
        return FileResponse(
            static_dir / "index.html",
            media_type=_TYPES[".html"],
            headers={"Cache-Control": "no-cache"},
        )

    @app.get("/viewer/{name}", include_in_schema=False)
    def viewer_asset(name: str) -> Response:
        path = _asset(name, static_dir)
        return FileResponse(
            path, media_type=_TYPES[path.suffix], headers={"Cache-Control": "no-cache"}
        )
