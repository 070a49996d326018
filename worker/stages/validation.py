"""Upload validation: the bodies of the synchronous tasks the API calls before it stores an upload."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pipelines.jsonable import jsonable
from worker.storage import Storage


def load_mesh_file(path: Path, file_type: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a stored mesh with the project's reader (vertex order kept)."""
    from pipelines.mesh_io import read_mesh

    V, F = read_mesh(path, file_type)
    return np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)


def validate_upload(
    storage: Storage,
    key: str,
    file_type: str,
    *,
    max_vertices: int,
    max_faces: int,
) -> dict[str, Any]:
    """Read and validate an uploaded mesh exactly as the CLI does.

    Returns ``{"ok": True, "report": {...}}`` or ``{"ok": False, "error":
    {"type", "message", "field", "status"}}`` (``status`` 422 for a bad mesh
    or a mesh over the limits).
    """
    from geometry.mesh_errors import MeshError
    from geometry.validate_mesh import validate_mesh

    try:
        V, F = load_mesh_file(storage.local_path(key), file_type)
        if V.shape[0] > max_vertices or F.shape[0] > max_faces:
            return {
                "ok": False,
                "error": {
                    "type": "mesh_too_large",
                    "message": (
                        f"mesh has {V.shape[0]} vertices and {F.shape[0]} faces; the limits "
                        f"are {max_vertices} vertices and {max_faces} faces"
                    ),
                    "field": "file",
                    "status": 422,
                },
            }
        repairs: dict[str, Any] = {}
        try:
            report = validate_mesh(V, F, require_disk=True)
        except MeshError as exc:
            report, repairs = repairable_mesh(V, F, exc)
    except MeshError as exc:
        return {
            "ok": False,
            "error": {
                "type": getattr(exc, "code", type(exc).__name__),
                "message": str(exc),
                "field": "file",
                "status": 422,
            },
        }
    except Exception as exc:  # noqa: BLE001 - any parser failure means the file is unreadable
        return {
            "ok": False,
            "error": {
                "type": "unreadable_mesh",
                "message": f"the file cannot be read as a {file_type.upper()} mesh: {exc}"[:2000],
                "field": "file",
                "status": 422,
            },
        }
    rep = jsonable(report, summarize_arrays_over=64)
    rep.setdefault("n_vertices", int(V.shape[0]))
    rep.setdefault("n_faces", int(F.shape[0]))
    if repairs:
        rep["repairs_needed"] = repairs
    return {"ok": True, "report": rep}


def repairable_mesh(V: np.ndarray, F: np.ndarray, error: Exception) -> tuple[Any, dict[str, Any]]:
    """A mesh that is a disk once its holes are filled and/or its ears removed.

    Called with the error of the strict validation; returns the lenient
    report and the repairs that make the mesh a valid disk, ``{"fill_holes":
    holes, "remove_ears": [ear vertex ids]}`` (only those needed), exactly
    the repairs of ``conformorph morph --fill-holes --remove-ears``. Re-raises
    ``error`` when those repairs do not give a valid disk (a closed surface,
    handles, several components, …).
    """
    from geometry.mesh_errors import BoundaryEarError, MeshError, NotDiskError
    from geometry.validate_mesh import validate_mesh
    from pipelines.conformal.disk_mesh import repair_disk_mesh

    if not isinstance(error, NotDiskError | BoundaryEarError):
        raise error
    try:
        report = validate_mesh(V, F, require_disk=False, allow_ears=True)
        holes = report.boundary_loops - 1
        if report.boundary_loops < 1 or report.euler_characteristic != 1 - holes:
            raise error  # closed, or handles: not a disk with holes
        # the jobs' own repairs (removing ears from an ear-free mesh removes nothing)
        mesh = repair_disk_mesh(V, F, fill_holes=holes > 0, remove_ears=True)
        validate_mesh(mesh.V, mesh.F, require_disk=True)
    except MeshError:
        raise error from None
    repairs: dict[str, Any] = {"fill_holes": holes} if holes else {}
    if mesh.done["removed_ear_vertex_ids"]:
        repairs["remove_ears"] = mesh.done["removed_ear_vertex_ids"]
    return report, repairs


def validate_shape_upload(
    storage: Storage, key: str, *, max_points: int | None = None
) -> dict[str, Any]:
    """Read and validate an uploaded 2D shape (JSON rings or SVG) like ``conformorph morph2d``.

    Returns ``{"ok": True, "report": {...}}`` or ``{"ok": False, "error": {...}}``
    (``shape_too_large`` beyond ``max_points``, default
    ``pipelines.shape_io.DEFAULT_MAX_POINTS``). The report holds ``rings``,
    ``points``, ``fixes`` and ``bbox`` ``[xmin, ymin, xmax, ymax]`` (y up), which
    the API checks a morph's holes and anchors against before enqueueing.
    """
    from geometry.shape_rings import validate_rings
    from pipelines.shape_io import DEFAULT_MAX_POINTS, read_shape

    cap = DEFAULT_MAX_POINTS if max_points is None else int(max_points)
    try:
        shape = validate_rings(read_shape(storage.local_path(key), max_points=cap))
    except Exception as exc:  # noqa: BLE001 - any parser failure means the file is unreadable
        return {
            "ok": False,
            "error": {
                "type": getattr(exc, "code", None) or "unreadable_shape",
                "message": str(exc),
                "field": "file",
                "status": 422,
            },
        }
    rings = [np.asarray(r) for r in getattr(shape, "rings", [])]
    lo, hi = rings[0].min(axis=0), rings[0].max(axis=0)
    return {
        "ok": True,
        "report": {
            "rings": len(rings),
            "points": int(sum(r.shape[0] for r in rings)),
            "fixes": list(getattr(shape, "fixes", [])),
            "bbox": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])],
        },
    }
