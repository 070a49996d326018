"""The browser viewer: ``/`` serves its page, ``/viewer/{name}`` its bundled assets.

``/favicon.ico`` serves the viewer's icon (an SVG, ``viewer/favicon.svg``, with its
SVG media type: browsers take the type from the header, not the name), so a page
load logs no 404.

The assets are built from ``viewer/`` (three.js from npm, bundled by esbuild)
into ``service/static/`` by ``npm install && npm run build:viewer``, which the
README's set-up commands run and a wheel or sdist build runs itself (setup.py).
Without a build, ``/`` answers 404 saying how to build it (a page for a browser,
the JSON error body otherwise), and creating the app logs the same advice.
"""

from __future__ import annotations

import html
import logging
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import FileResponse, HTMLResponse, Response

from conformorph.service.api.deps import SettingsDep
from conformorph.service.errors import ApiError
from conformorph.service.schemas import VERTEX_BUDGET_DEFAULT

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).resolve().parent / "static"
#: what to do when the viewer is not built (said at / and in the start-up log)
BUILD_HINT = (
    "the browser viewer is not built: in a checkout run 'npm install && npm run build:viewer' "
    "(Node.js and npm), or install conformorph from a wheel or sdist built where npm is "
    "available ('pip install .' builds it)"
)
#: what the viewer sends with a morph: the CLI's defaults (``conformorph morph --prepare
#: auto`` and its --vertex-budget; the API's own default for prepare is "none"), so a
#: 445k-vertex key runs at the working resolution in the browser as on the command line
VIEWER_MORPH_DEFAULTS = {"prepare": "auto", "vertex_budget": VERTEX_BUDGET_DEFAULT}
_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".txt": "text/plain; charset=utf-8",
    ".svg": "image/svg+xml",
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
    """Add ``GET /`` and ``GET /viewer/{name}`` (not part of the API's OpenAPI document).

    Logs a warning saying how to build the viewer when ``static_dir`` has no build.
    """
    if not (static_dir / "index.html").is_file():
        log.warning("%s (no %s)", BUILD_HINT, static_dir / "index.html")

    @app.get("/", include_in_schema=False)
    def viewer_page(request: Request) -> Response:
        if not (static_dir / "index.html").is_file():
            if "text/html" in request.headers.get("accept", ""):
                return HTMLResponse(_NOT_BUILT_PAGE, status_code=404)
            raise ApiError(404, "viewer_not_built", BUILD_HINT)
        return FileResponse(
            static_dir / "index.html",
            media_type=_TYPES[".html"],
            headers={"Cache-Control": "no-cache"},
        )

    @app.get("/favicon.ico", include_in_schema=False)
    def favicon() -> Response:
        path = _asset("favicon.svg", static_dir)
        return FileResponse(
            path, media_type=_TYPES[".svg"], headers={"Cache-Control": "max-age=86400"}
        )

    @app.get("/viewer/config.json", include_in_schema=False)
    def viewer_config(settings: SettingsDep) -> dict[str, object]:
        """What the viewer checks and sends before a job: the upload limit, the morph
        defaults (:data:`VIEWER_MORPH_DEFAULTS`)."""
        return {
            "max_upload_bytes": settings.max_upload_bytes,
            "morph_defaults": dict(VIEWER_MORPH_DEFAULTS),
        }

    @app.get("/viewer/{name}", include_in_schema=False)
    def viewer_asset(name: str) -> Response:
        path = _asset(name, static_dir)
        return FileResponse(
            path, media_type=_TYPES[path.suffix], headers={"Cache-Control": "no-cache"}
        )


_NOT_BUILT_PAGE = (
    "<!doctype html><html><head><meta charset='utf-8'><title>conformorph: viewer not built"
    "</title></head><body><h1>The browser viewer is not built</h1><p>"
    + html.escape(BUILD_HINT[BUILD_HINT.index(":") + 2 :].capitalize())
    + ".</p><p>The REST API is served: see <a href='/docs'>/docs</a>.</p></body></html>"
)
