"""Stage bodies of the face morph (``POST /v1/morphs``), one task per stage of
:mod:`pipelines.face_morph_pipeline`, intermediate results kept as internal
``.npz`` artifacts of the job:

1. ``prepare``: every key mesh validated, normalised, mapped to the disk,
   (H, Hn, λ) and landmarks (``prepare_mesh``);
2. ``register``: rigid alignment and disk registration (``register_meshes``);
3. ``frames``: the homotopy frames (``compute_frames`` without metrics);
4. ``export``: ``animation.glb`` and ``frames/NNN.glb`` (``export_outputs``),
   published at once so a client can fetch the animation while
5. ``metrics`` measures the key frames against the inputs for the method and
   the baselines (``compute_frames`` at the key times with ``key_metrics``)
   and writes ``metrics.json``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from pipelines.jsonable import jsonable
from worker import names
from worker.job_runner import StageBody, StageContext
from worker.stages.validation import load_mesh_file


def _tag(exc: Exception, field: str) -> Exception:
    if not hasattr(exc, "conformorph_field"):
        exc.conformorph_field = field  # type: ignore[attr-defined]
    return exc


def _mesh_path(ctx: StageContext, i: int) -> tuple[Path, str]:
    m = ctx.params["meshes"][i]
    return ctx.storage.local_path(m["storage_key"]), str(m["file_type"])


def _save(ctx: StageContext, name: str, arrays: dict[str, Any]) -> None:
    from pipelines.face_morph_pipeline import save_stage

    with ctx.scratch_dir() as d:
        save_stage(d / name, arrays)
        ctx.put_file(name, d / name, internal=True)


def _load(ctx: StageContext, name: str) -> dict[str, Any]:
    from pipelines.face_morph_pipeline import load_stage

    out: dict[str, Any] = load_stage(ctx.artifact_path(name))
    return out


def morph_prepare_stage(ctx: StageContext) -> None:
    """Stage 1 for every key mesh (``prepare_mesh``)."""
    from geometry.threads import map_in_threads
    from pipelines.face_morph_pipeline import (
        prepare_mesh,
        read_texture,
        read_vertex_colors,
        repair_key_mesh,
    )
    from pipelines.landmarks_io import LandmarkError, parse_landmark_json

    p = ctx.params
    n = len(p["meshes"])
    try:
        entries = parse_landmark_json({"landmarks": p["landmarks"]}, n)
    except ValueError as exc:
        raise _tag(exc, "landmarks") from exc
    textures = p.get("textures") or []

    def prepare_key(i: int) -> dict[str, Any]:
        path, ftype = _mesh_path(ctx, i)
        try:
            V, F = load_mesh_file(path, ftype)
            tex_uv = image = None
            colors = None if textures else read_vertex_colors(path, V.shape[0], file_type=ftype)
            if textures:
                tex_uv, image = read_texture(
                    path,
                    ctx.storage.local_path(textures[i]["storage_key"]),
                    V.shape[0],
                    file_type=ftype,
                )
            V, F, entries[i], tex_uv, colors = repair_key_mesh(
                V,
                F,
                entries[i],
                tex_uv,
                colors,
                i,
                fill_holes=bool(p.get("fill_holes", False)),
                remove_ears=bool(p.get("remove_ears", False)),
            )
            prepared = prepare_mesh(
                V,
                F,
                entries[i],
                mesh_index=i,
                disk_method=p.get("disk_method", "fast"),
                tex_uv=tex_uv,
                colors=colors,
                texture=image,
            )
        except LandmarkError as exc:
            raise _tag(exc, f"landmarks[{i}]") from exc
        except (ValueError, ArithmeticError) as exc:  # ArithmeticError: a folded disk map
            raise _tag(exc, f"meshes[{i}]") from exc
        return prepared

    # the keys are independent: side by side on threads, the first failing key (in
    # input order) raising; stored (and progress reported) in key order
    for i, prepared in enumerate(map_in_threads(prepare_key, range(n))):
        _save(ctx, f"prepared_{i}.npz", prepared)
        ctx.progress((i + 1) / n)


def morph_register_stage(ctx: StageContext) -> None:
    """Stage 2 (``register_meshes``)."""
    from pipelines.face_morph_pipeline import register_meshes

    n = len(ctx.params["meshes"])
    prepared = [_load(ctx, f"prepared_{i}.npz") for i in range(n)]
    ctx.progress(0.2)
    reg = register_meshes(
        prepared,
        method=ctx.params.get("method", "dmt"),
        consistent=ctx.params.get("consistent", "source"),
        refine=ctx.params.get("refine", "auto"),
        baselines=True,
    )
    _save(ctx, "registration.npz", reg)


def _key_times(ctx: StageContext) -> np.ndarray:
    times = ctx.params.get("times")
    n = len(ctx.params["meshes"])
    return np.arange(n, dtype=np.float64) if times is None else np.asarray(times, dtype=np.float64)


def morph_frames_stage(ctx: StageContext) -> None:
    """Stage 3 (``compute_frames``)."""
    from pipelines.face_morph_pipeline import DEFAULT_CURVATURE, compute_frames, frame_times_for

    reg = _load(ctx, "registration.npz")
    meshes, _ = _prepared_meshes(ctx)
    times = _key_times(ctx)
    explicit = ctx.params.get("frame_times")
    ft = (
        frame_times_for(times, int(ctx.params.get("frames", 30)))
        if explicit is None
        else np.asarray(explicit, dtype=np.float64)
    )
    ctx.progress(0.1)
    fr = compute_frames(
        reg,
        meshes,
        times,
        ft,
        curvature=ctx.params.get("curvature", DEFAULT_CURVATURE),
        key_metrics=False,
    )
    _save(ctx, "frames.npz", fr)


def _prepared_meshes(ctx: StageContext) -> tuple[list[tuple[Any, Any]], list[dict[str, Any]]]:
    meshes, metas = [], []
    for i in range(len(ctx.params["meshes"])):
        prepared = _load(ctx, f"prepared_{i}.npz")
        meshes.append((prepared["V"], prepared["F"]))
        metas.append({"mesh": ctx.params["meshes"][i]["id"], **prepared.get("meta", {})})
    return meshes, metas


def morph_export_stage(ctx: StageContext) -> None:
    """Stage 4 (``export_outputs``): ``animation.glb`` and optional ``frames/NNN.glb``."""
    from pipelines.face_morph_pipeline import export_outputs

    reg = _load(ctx, "registration.npz")
    fr = _load(ctx, "frames.npz")
    with ctx.scratch_dir() as d:
        files = export_outputs(
            reg,
            fr,
            d,
            per_frame=bool(ctx.params.get("per_frame", False)),
            normals=bool(ctx.params.get("normals", False)),
        )
        for name in sorted(files):
            ctx.put_file(name, d / name)


def morph_metrics_stage(ctx: StageContext) -> None:
    """Stage 5: key frames of the method and the baselines against the inputs; ``metrics.json``."""
    from pipelines.face_morph_pipeline import DEFAULT_CURVATURE, bijectivity_summary, compute_frames

    reg = _load(ctx, "registration.npz")
    fr = _load(ctx, "frames.npz")
    meshes, inputs = _prepared_meshes(ctx)
    times = _key_times(ctx)
    keys = compute_frames(
        reg,
        meshes,
        times,
        times,
        curvature=ctx.params.get("curvature", DEFAULT_CURVATURE),
        key_metrics=True,
    )
    frames_meta = {**fr.get("meta", {})}
    frames_meta["key_frame_L2_to_inputs"] = keys["meta"].get("key_frame_L2_to_inputs")
    files = {
        name: rec["size"]
        for name, rec in ctx.job.artifacts.items()
        if not rec.get("internal") and name.endswith(".glb")
    }
    metrics = {
        "inputs": inputs,
        "bijectivity": bijectivity_summary(inputs, reg.get("meta", {})),
        "key_times": times.tolist(),
        "frame_times": np.asarray(fr["frame_times"]).tolist(),
        "registration": reg.get("meta", {}),
        "frames": frames_meta,
        "files": files,
        "seconds": {**ctx.job.stage_seconds},
    }
    ctx.put_json("metrics.json", jsonable(metrics))


STAGE_BODIES: dict[str, StageBody] = {
    names.STAGE_MORPH_PREPARE: morph_prepare_stage,
    names.STAGE_MORPH_REGISTER: morph_register_stage,
    names.STAGE_MORPH_FRAMES: morph_frames_stage,
    names.STAGE_MORPH_EXPORT: morph_export_stage,
    names.STAGE_MORPH_METRICS: morph_metrics_stage,
}
