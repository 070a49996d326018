"""Stage bodies: thin adapters between storage and one ``geometry`` function each.

Each body loads its inputs by storage key (the uploaded mesh, or an artifact of
an earlier stage of the same job), calls one geometry function, writes its
outputs atomically through :class:`worker.job_runner.StageContext` and reports
progress. Geometry is imported inside the bodies so that importing this module
(and the Celery task registry) stays cheap.

Also here: :func:`validate_upload`, the body of the synchronous validation
task the API calls before it stores an upload.
"""

from __future__ import annotations

import dataclasses
import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from worker import names
from worker.histogram_png import histogram_png
from worker.job_runner import StageBody, StageContext, input_field
from worker.storage import Storage


def _jsonable(value: Any) -> Any:
    """Best-effort conversion of diagnostics (dataclasses, numpy) to JSON values."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        if value.size > 64:
            return {"shape": list(value.shape), "dtype": str(value.dtype)}
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    return str(value)


def load_mesh_file(path: Path, file_type: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a stored mesh with the project's reader (vertex order kept)."""
    from worker.mesh_io import read_mesh

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
    rep = _jsonable(report)
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
    from worker.disk_mesh import repair_disk_mesh

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


def _input_mesh(ctx: StageContext, field_name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    mesh = ctx.params["mesh"]
    with input_field(field_name):
        return load_mesh_file(ctx.storage.local_path(mesh["storage_key"]), mesh["file_type"])


def _input_disk_mesh(ctx: StageContext) -> Any:
    """The job's mesh and the disk the numerics run on, after the job's repairs
    (``fill_holes``, ``remove_ears``): a :class:`worker.disk_mesh.DiskMesh`."""
    from worker.disk_mesh import repair_disk_mesh

    V, F = _input_mesh(ctx)
    with input_field("mesh"):
        return repair_disk_mesh(
            V,
            F,
            fill_holes=bool(ctx.params.get("fill_holes", False)),
            remove_ears=bool(ctx.params.get("remove_ears", False)),
        )


#: internal artifact: the disk map of the repaired mesh (rows of ``DiskMesh.V``),
#: which the curvature and reconstruction stages run on
REPAIRED_MAP = "repaired_disk_map.npz"


#: internal artifact: H and λ on the repaired mesh
REPAIRED_H_LAMBDA = "repaired_h_lambda.npz"


def _stored(ctx: StageContext, repaired: str, public: str) -> str:
    """The repaired-mesh artifact, or the public one of a job whose earlier stage ran
    before repairs existed (no repairs: the same rows)."""
    return repaired if repaired in ctx.job.artifacts or repaired in ctx.artifacts else public


def _repaired_uv(ctx: StageContext) -> np.ndarray:
    with np.load(ctx.artifact_path(_stored(ctx, REPAIRED_MAP, "disk_map.npz"))) as z:
        return np.asarray(z["uv"])


def _npz_bytes(**arrays: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def _quality(V: np.ndarray, F: np.ndarray, uv: np.ndarray, b: np.ndarray) -> dict[str, Any]:
    """Quality measures shipped beside a map (the lead's ``map_quality`` when present)."""
    try:
        from geometry.map_quality import map_quality
    except ImportError:  # pragma: no cover - older geometry without map_quality
        from geometry import angle_distortion, flipped_triangles

        d = np.asarray(angle_distortion(V, F, uv), dtype=np.float64)
        r = np.linalg.norm(uv, axis=1)
        return {
            "angle_distortion_mean": float(d.mean()),
            "angle_distortion_max": float(d.max()),
            "flipped": int(np.asarray(flipped_triangles(uv, F)).sum()),
            "boundary_circle_error": float(np.max(np.abs(r[b] - 1.0))),
        }
    out: dict[str, Any] = _jsonable(map_quality(V, F, uv, b).to_dict())
    return out


def conformal_map_stage(ctx: StageContext) -> None:
    """Disk conformal map of the job's mesh: ``disk_map.npz`` (uv, faces, kept) and
    ``quality.json``.

    As ``conformorph map``: the map is computed on the repaired mesh (the
    job's ``fill_holes``/``remove_ears``) and given back on the input's
    vertices and faces (removed ears on the unit circle, ``kept`` False);
    ``center_vertex`` and ``angle_vertex`` are input vertex ids.
    """
    from geometry import boundary_loop, disk_conformal_map, extend_uv_to_ears

    mesh = _input_disk_mesh(ctx)
    V, F = mesh.V, mesh.F
    ctx.progress(0.05)
    p = ctx.params
    moved = {}
    for name in ("center_vertex", "angle_vertex"):
        if p.get(name) is not None:
            with input_field(name):
                moved[name] = mesh.vertex(p[name])
    uv, info = disk_conformal_map(
        V,
        F,
        method=p.get("method", "fast"),
        center_vertex=moved.get("center_vertex"),
        angle_vertex=moved.get("angle_vertex"),
        fold_policy=p.get("fold_policy", "repair"),
        refine_angles=bool(p.get("refine_angles", True)),
    )
    ctx.progress(0.8)
    b = np.asarray(boundary_loop(F), dtype=np.int64)
    quality = {
        "method": p.get("method", "fast"),
        "vertices": int(mesh.V_in.shape[0]),
        "faces": int(mesh.F_in.shape[0]),
        "mapped_vertices": int(V.shape[0]),
        "mapped_faces": int(F.shape[0]),
        **mesh.done,
        **_quality(V, F, uv, b),
        "info": _jsonable(info.to_dict() if hasattr(info, "to_dict") else info),
    }
    uv_in = mesh.input_rows(uv, extend_uv_to_ears(uv, mesh.F_filled, mesh.kept))
    ctx.put_bytes("disk_map.npz", _npz_bytes(uv=uv_in, faces=mesh.F_in, kept=mesh.kept_mask()))
    ctx.put_bytes(REPAIRED_MAP, _npz_bytes(uv=uv), internal=True)
    ctx.put_json("quality.json", quality)
    for key, name, label in (
        ("angle_histogram", "angle_distortion_histogram.png", "angle distortion (degrees)"),
        ("beltrami_histogram", "beltrami_histogram.png", "Beltrami coefficient |mu|"),
    ):
        hist = quality.get(key)
        if isinstance(hist, dict) and "counts" in hist and "edges" in hist:
            ctx.put_bytes(name, histogram_png(hist["counts"], hist["edges"], label))
    ctx.progress(1.0)


def curvature_stage(ctx: StageContext) -> None:
    """Mean curvature H (scalar, or the mean-curvature vector) and conformal factor λ:
    ``h_lambda.npz``, one row per input vertex (NaN for an ear removed by
    ``remove_ears``; hole centres left out)."""
    from geometry import conformal_factor, mean_curvature, mean_curvature_vector

    mesh = _input_disk_mesh(ctx)
    V, F = mesh.V, mesh.F
    uv = _repaired_uv(ctx)
    if ctx.params.get("curvature", "vector") == "vector":
        H = mean_curvature_vector(V, F)
    else:
        H = mean_curvature(V, F)
    ctx.progress(0.5)
    lam = conformal_factor(V, F, uv)
    H, lam = np.asarray(H, dtype=np.float64), np.asarray(lam, dtype=np.float64)
    n_filled = mesh.V_filled.shape[0]
    public = {
        name: mesh.input_rows(a, np.full((n_filled, *a.shape[1:]), np.nan))
        for name, a in (("H", H), ("lam", lam))
    }
    ctx.put_bytes("h_lambda.npz", _npz_bytes(**public))
    ctx.put_bytes(REPAIRED_H_LAMBDA, _npz_bytes(H=H, lam=lam), internal=True)
    ctx.progress(1.0)


def reconstruct_stage(ctx: StageContext) -> None:
    """Algorithm 1 from (H, λ), the disk and the boundary: ``reconstruction.obj``, ``errors.json``."""
    from geometry import boundary_loop, reconstruct_surface, reconstruction_error
    from worker.mesh_io import write_obj

    mesh = _input_disk_mesh(ctx)
    V, F = mesh.V, mesh.F
    uv = _repaired_uv(ctx)
    with np.load(ctx.artifact_path(_stored(ctx, REPAIRED_H_LAMBDA, "h_lambda.npz"))) as z:
        H, lam = z["H"], z["lam"]
    b = np.asarray(boundary_loop(F), dtype=np.int64)
    # the fold correction needs the harmonic map (no angle refinement) and the vector H
    correct = (
        bool(ctx.params.get("fold_correction", False))
        and H.ndim == 2
        and not ctx.params.get("refine_angles", True)
    )
    X, info = reconstruct_surface(uv, F, H, lam, V[b], b=b, correct_folds=correct)
    ctx.progress(0.9)
    errors = {k: float(v) for k, v in reconstruction_error(V, X, F).items()}
    with ctx.scratch_dir() as d:
        # the input's vertices and faces; removed ears keep their input positions
        write_obj(d / "reconstruction.obj", mesh.input_rows(X, mesh.V_filled), mesh.F_in)
        ctx.put_file("reconstruction.obj", d / "reconstruction.obj")
    ctx.put_json(
        "errors.json",
        {
            **mesh.done,
            "relative_error": errors,
            "curvature": ctx.params.get("curvature", "vector"),
            "reconstruction": _jsonable(info.to_dict() if hasattr(info, "to_dict") else info),
        },
    )
    ctx.progress(1.0)


STAGE_BODIES: dict[str, StageBody] = {
    names.STAGE_CONFORMAL_MAP: conformal_map_stage,
    names.STAGE_CURVATURE: curvature_stage,
    names.STAGE_RECONSTRUCT: reconstruct_stage,
}


def validate_shape_upload(
    storage: Storage, key: str, *, max_points: int | None = None
) -> dict[str, Any]:
    """Read and validate an uploaded 2D shape (JSON rings or SVG) like ``conformorph morph2d``.

    Returns ``{"ok": True, "report": {...}}`` or ``{"ok": False, "error": {...}}``
    (``shape_too_large`` beyond ``max_points``, default
    ``worker.shape_io.DEFAULT_MAX_POINTS``). The report holds ``rings``,
    ``points``, ``fixes`` and ``bbox`` ``[xmin, ymin, xmax, ymax]`` (y up), which
    the API checks a morph's holes and anchors against before enqueueing.
    """
    from geometry.shape_rings import validate_rings
    from worker.shape_io import DEFAULT_MAX_POINTS, read_shape

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


def _all_bodies() -> dict[str, StageBody]:
    from worker.morph_stages import MORPH_STAGE_BODIES

    return {**STAGE_BODIES, **MORPH_STAGE_BODIES}


ALL_STAGE_BODIES = _all_bodies()
