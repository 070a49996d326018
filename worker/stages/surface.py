"""Stage bodies of the conformal-map and reconstruction jobs (``POST /v1/conformal-maps``,
``/v1/reconstructions``): each loads its inputs, calls one step of
:mod:`conformorph.pipelines.conformal` (disk map, (H, λ), Algorithm 1), stores, reports progress.

Job params map onto the steps' options in :func:`surface_options_from_params`.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Any

import numpy as np

from conformorph.pipelines.conformal import (
    CurvatureOptions,
    DiskMapOptions,
    DiskMesh,
    ReconstructionStepOptions,
    RepairOptions,
    curvature_step,
    disk_map_step,
    map_histogram_pngs,
    map_quality_report,
    prepared_disk_mesh,
    reconstruction_step,
)
from conformorph.pipelines.jsonable import jsonable
from conformorph.worker import names
from conformorph.worker.job_runner import StageBody, StageContext, input_field
from conformorph.worker.stages.validation import job_vertex_budget, load_mesh_file

#: internal artifact: the disk map of the repaired mesh (rows of ``DiskMesh.V``),
#: which the curvature and reconstruction stages run on
REPAIRED_MAP = "repaired_disk_map.npz"

#: internal artifact: H and λ on the repaired mesh
REPAIRED_H_LAMBDA = "repaired_h_lambda.npz"


@dataclass(frozen=True)
class SurfaceJobOptions:
    """A conformal-map or reconstruction job's params as the steps' options."""

    repairs: RepairOptions
    disk_map: DiskMapOptions
    curvature: CurvatureOptions
    reconstruction: ReconstructionStepOptions


def surface_options_from_params(params: dict[str, Any]) -> SurfaceJobOptions:
    """The one place job params (API fields) become options."""
    p = params
    refine = bool(p.get("refine_angles", True))
    return SurfaceJobOptions(
        repairs=RepairOptions(
            fill_holes=bool(p.get("fill_holes", False)),
            remove_ears=bool(p.get("remove_ears", False)),
            prepare=str(p.get("prepare") or "none"),
            vertex_budget=job_vertex_budget(p),
        ),
        disk_map=DiskMapOptions(
            method=p.get("method", "fast"),
            fold_policy=p.get("fold_policy", "repair"),
            refine_angles=refine,
            center_vertex=p.get("center_vertex"),
            angle_vertex=p.get("angle_vertex"),
        ),
        curvature=CurvatureOptions(curvature=p.get("curvature", "vector")),
        # the fold correction needs the harmonic map (no angle refinement)
        reconstruction=ReconstructionStepOptions(
            fold_correction=bool(p.get("fold_correction", False)) and not refine
        ),
    )


def _input_disk_mesh(ctx: StageContext, repairs: RepairOptions) -> DiskMesh:
    """The job's mesh and the disk the numerics run on, after the job's repairs."""
    mesh = ctx.params["mesh"]
    with input_field("mesh"):
        V, F = load_mesh_file(ctx.storage.local_path(mesh["storage_key"]), mesh["file_type"])
        return prepared_disk_mesh(V, F, repairs)


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


def conformal_map_stage(ctx: StageContext) -> None:
    """Disk conformal map of the job's mesh: ``disk_map.npz`` (uv, faces, kept) and
    ``quality.json`` (with its histograms).

    As ``conformorph map``: the map is computed on the repaired mesh (the
    job's ``fill_holes``/``remove_ears``) and given back on the input's
    vertices and faces (removed ears on the unit circle, ``kept`` False);
    ``center_vertex`` and ``angle_vertex`` are input vertex ids.
    """
    opts = surface_options_from_params(ctx.params)
    mesh = _input_disk_mesh(ctx, opts.repairs)
    ctx.progress(0.05)
    for name in ("center_vertex", "angle_vertex"):  # a removed ear: the field's error
        if ctx.params.get(name) is not None:
            with input_field(name):
                mesh.vertex(ctx.params[name])
    result = disk_map_step(mesh, opts.disk_map)
    ctx.progress(0.8)
    quality = map_quality_report(mesh, result, opts.disk_map.method)
    extra = {} if mesh.vertex_map is None else {"vertex_map": mesh.vertex_map}
    ctx.put_bytes(
        "disk_map.npz",
        _npz_bytes(uv=result.uv_input, faces=mesh.F_in, kept=result.kept, **extra),
    )
    ctx.put_bytes(REPAIRED_MAP, _npz_bytes(uv=result.uv), internal=True)
    ctx.put_json("quality.json", quality)
    for name, png in map_histogram_pngs(quality):
        ctx.put_bytes(name, png)
    ctx.progress(1.0)


def curvature_stage(ctx: StageContext) -> None:
    """Mean curvature H (scalar, or the mean-curvature vector) and conformal factor λ:
    ``h_lambda.npz``, one row per input vertex (NaN for an ear removed by
    ``remove_ears``; hole centres left out)."""
    opts = surface_options_from_params(ctx.params)
    mesh = _input_disk_mesh(ctx, opts.repairs)
    uv = _repaired_uv(ctx)
    ctx.progress(0.5)
    hl = curvature_step(mesh, uv, opts.curvature)
    ctx.put_bytes("h_lambda.npz", _npz_bytes(H=hl.H_input, lam=hl.lam_input))
    ctx.put_bytes(REPAIRED_H_LAMBDA, _npz_bytes(H=hl.H, lam=hl.lam), internal=True)
    ctx.progress(1.0)


def reconstruct_stage(ctx: StageContext) -> None:
    """Algorithm 1 from (H, λ), the disk and the boundary: ``reconstruction.obj``, ``errors.json``."""
    from conformorph.pipelines.mesh_io import write_obj

    opts = surface_options_from_params(ctx.params)
    mesh = _input_disk_mesh(ctx, opts.repairs)
    uv = _repaired_uv(ctx)
    with np.load(ctx.artifact_path(_stored(ctx, REPAIRED_H_LAMBDA, "h_lambda.npz"))) as z:
        H, lam = z["H"], z["lam"]
    rec = reconstruction_step(mesh, uv, H, lam, opts.reconstruction)
    ctx.progress(0.9)
    with ctx.scratch_dir() as d:
        # the input's vertices and faces; removed ears keep their input positions
        write_obj(d / "reconstruction.obj", rec.X_input, mesh.F_in)
        ctx.put_file("reconstruction.obj", d / "reconstruction.obj")
    ctx.put_json(
        "errors.json",
        {
            **mesh.done,
            "relative_error": rec.errors,
            "curvature": opts.curvature.curvature,
            "reconstruction": jsonable(rec.info.to_dict()),
        },
    )
    ctx.progress(1.0)


STAGE_BODIES: dict[str, StageBody] = {
    names.STAGE_CONFORMAL_MAP: conformal_map_stage,
    names.STAGE_CURVATURE: curvature_stage,
    names.STAGE_RECONSTRUCT: reconstruct_stage,
}
