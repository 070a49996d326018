"""Stage bodies of the conformal-map and reconstruction jobs (``POST /v1/conformal-maps``,
``/v1/reconstructions``): disk map, (H, λ), Algorithm 1."""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from pipelines.histogram_png import histogram_png
from pipelines.jsonable import jsonable
from worker import names
from worker.job_runner import StageBody, StageContext, input_field
from worker.stages.validation import load_mesh_file


def _input_mesh(ctx: StageContext, field_name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    mesh = ctx.params["mesh"]
    with input_field(field_name):
        return load_mesh_file(ctx.storage.local_path(mesh["storage_key"]), mesh["file_type"])


def _input_disk_mesh(ctx: StageContext) -> Any:
    """The job's mesh and the disk the numerics run on, after the job's repairs
    (``fill_holes``, ``remove_ears``): a :class:`pipelines.disk_mesh.DiskMesh`."""
    from pipelines.disk_mesh import repair_disk_mesh

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
    out: dict[str, Any] = jsonable(map_quality(V, F, uv, b).to_dict())
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
        "info": jsonable(info.to_dict() if hasattr(info, "to_dict") else info),
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
    from geometry import (
        ReconstructionOptions,
        boundary_loop,
        reconstruct_surface,
        reconstruction_error,
    )
    from pipelines.mesh_io import write_obj

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
    X, info = reconstruct_surface(uv, F, H, lam, V[b], b=b, options=ReconstructionOptions(correct_folds=correct))
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
            "reconstruction": jsonable(info.to_dict() if hasattr(info, "to_dict") else info),
        },
    )
    ctx.progress(1.0)


STAGE_BODIES: dict[str, StageBody] = {
    names.STAGE_CONFORMAL_MAP: conformal_map_stage,
    names.STAGE_CURVATURE: curvature_stage,
    names.STAGE_RECONSTRUCT: reconstruct_stage,
}
