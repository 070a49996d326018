"""Stage bodies of the face morph (``POST /v1/morphs``), one task per stage of
:mod:`conformorph.pipelines.face_morph`, intermediate results kept as internal
``.npz`` artifacts of the job:

0. ``detect_landmarks`` (only with ``"landmarks": "auto"`` or a landmark set asking for
   ``"fill": "auto"``): see
   :mod:`conformorph.worker.stages.landmark_detection`;
1. ``prepare``: every key mesh validated, normalised, mapped to the disk,
   (H, Hn, λ) (the mesh's key artifact, :mod:`conformorph.worker.key_artifacts`: found
   ready or computed and stored) and landmarks (``prepare_key_cached``);
2. ``register``: rigid alignment and disk registration (``register_meshes``);
3. ``frames``: the homotopy frames (``compute_frames`` without metrics);
4. ``export``: ``animation.glb`` and ``frames/NNN.glb`` (``export_outputs``),
   published at once so a client can fetch the animation while
5. ``metrics`` measures the key frames against the inputs for the method and
   the baselines (``key_frame_metrics``) and writes ``metrics.json``.

Job parameters map onto the pipeline's options in :func:`morph_options_from_params`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from conformorph.pipelines.job_fields import MORPH_BASELINES_DEFAULT, MORPH_PREPARE_DEFAULT
from conformorph.worker import names
from conformorph.worker.job_runner import StageBody, StageContext
from conformorph.worker.stages.landmark_detection import detected_document, detected_report
from conformorph.worker.stages.validation import job_vertex_budget, load_mesh_file


def _tag(exc: Exception, field: str) -> Exception:
    if not hasattr(exc, "conformorph_field"):
        exc.conformorph_field = field  # type: ignore[attr-defined]
    return exc


def _mesh_path(ctx: StageContext, i: int) -> tuple[Path, str]:
    m = ctx.params["meshes"][i]
    return ctx.storage.local_path(m["storage_key"]), str(m["file_type"])


def morph_options_from_params(params: dict[str, Any]) -> Any:
    """The :class:`conformorph.pipelines.face_morph.FaceMorphOptions` of a morph job's parameters.

    The registration builds the MT baseline when the job asks (``baselines``, default
    :data:`~conformorph.pipelines.job_fields.MORPH_BASELINES_DEFAULT`, as the CLI's); the
    frames stage measures nothing (``key_metrics=False``): the metrics stage does.
    """
    from conformorph.pipelines.face_morph import (
        DEFAULT_CURVATURE,
        DEFAULT_LANDMARK_FIT_CHOICE,
        DEFAULT_NORMALS,
        DEFAULT_UNITS,
        ExportOptions,
        FaceMorphOptions,
        FrameOptions,
        KeyOptions,
        RegistrationOptions,
        resolve_landmark_fit,
    )

    times, frame_times = params.get("times"), params.get("frame_times")
    return FaceMorphOptions(
        times=None if times is None else tuple(times),
        frames=int(params.get("frames", 30)),
        frame_times=None if frame_times is None else tuple(frame_times),
        keys=KeyOptions(
            fill_holes=bool(params.get("fill_holes", False)),
            remove_ears=bool(params.get("remove_ears", False)),
            disk_method=params.get("disk_method", "fast"),
            prepare=str(params.get("prepare") or MORPH_PREPARE_DEFAULT),
            vertex_budget=job_vertex_budget(params),
        ),
        registration=RegistrationOptions(
            method=params.get("method", "dmt"),
            consistent=params.get("consistent", "source"),
            refine=params.get("refine", "auto"),
            landmark_fit=resolve_landmark_fit(
                params.get("landmark_fit") or DEFAULT_LANDMARK_FIT_CHOICE,
                names.detects_landmarks(params),
            ),
            baselines=bool(params.get("baselines", MORPH_BASELINES_DEFAULT)),
        ),
        homotopy=FrameOptions(
            curvature=params.get("curvature", DEFAULT_CURVATURE), key_metrics=False
        ),
        export=ExportOptions(
            per_frame=bool(params.get("per_frame", False)),
            normals=bool(params.get("normals", DEFAULT_NORMALS)),
            compress=str(params.get("compress") or "auto"),
            output_resolution=str(params.get("output_resolution") or "auto"),
        ),
        units=str(params.get("units") or DEFAULT_UNITS),
    )


def default_key_options() -> Any:
    """The :class:`KeyOptions` of a morph job whose fields are all at the API's defaults
    (``prepare`` the shared ``MORPH_PREPARE_DEFAULT``): what the upload's precompute
    (``conformorph.precompute_key``) computes, so that a default job finds it (a test holds
    it equal to what a default ``POST /v1/morphs`` body maps to)."""
    return morph_options_from_params({}).keys


def _save(ctx: StageContext, name: str, arrays: dict[str, Any]) -> None:
    from conformorph.pipelines.face_morph import save_stage

    with ctx.scratch_dir() as d:
        save_stage(d / name, arrays)
        ctx.put_file(name, d / name, internal=True)


def _load(ctx: StageContext, name: str) -> dict[str, Any]:
    from conformorph.pipelines.face_morph import load_stage

    out: dict[str, Any] = load_stage(ctx.artifact_path(name))
    return out


def morph_prepare_stage(ctx: StageContext) -> None:
    """Stage 1 for every key mesh (``prepare_key_file``)."""
    from conformorph.geometry.threads import map_in_threads
    from conformorph.pipelines.face_morph import prepare_key_file
    from conformorph.pipelines.face_morph.key_artifact import cacheable
    from conformorph.pipelines.face_morph.key_cache import prepare_key_cached
    from conformorph.pipelines.face_morph.units import keys_to_one_scale
    from conformorph.pipelines.landmarks_io import LandmarkError, parse_landmark_json
    from conformorph.worker.key_artifacts import StorageArtifactStore

    p = ctx.params
    n = len(p["meshes"])
    landmarks = p["landmarks"]
    if names.detects_landmarks(p):  # written by the detection stage before this one
        landmarks = detected_document(ctx)["landmarks"]
    try:
        entries = parse_landmark_json({"landmarks": landmarks}, n)
    except ValueError as exc:
        raise _tag(exc, "landmarks") from exc
    textures = p.get("textures") or []
    options = morph_options_from_params(p).keys

    def prepare_key(i: int) -> dict[str, Any]:
        path, ftype = _mesh_path(ctx, i)
        prepared: dict[str, Any]
        try:
            texture = ctx.storage.local_path(textures[i]["storage_key"]) if textures else None
            if cacheable(options, texture) is None:  # the mesh's work stored once, reused
                cache = StorageArtifactStore(
                    ctx.storage, ctx.store, ctx.job.owner, p["meshes"][i]["id"]
                )
                prepared = prepare_key_cached(
                    cache, path, entries[i], i, file_type=ftype, options=options
                )
            else:
                V, F = load_mesh_file(path, ftype)
                prepared = prepare_key_file(
                    V,
                    F,
                    entries[i],
                    i,
                    path,
                    texture_path=texture,
                    file_type=ftype,
                    options=options,
                )
        except LandmarkError as exc:
            raise _tag(exc, f"landmarks[{i}]") from exc
        except (ValueError, ArithmeticError) as exc:  # ArithmeticError: a folded disk map
            raise _tag(exc, f"meshes[{i}]") from exc
        return prepared

    # the keys are independent: side by side on threads, the first failing key (in
    # input order) raising; then brought to key 0's unit; stored (and progress
    # reported) in key order
    keys, _ = keys_to_one_scale(
        map_in_threads(prepare_key, range(n)), morph_options_from_params(p).units
    )
    for i, prepared in enumerate(keys):
        _save(ctx, f"prepared_{i}.npz", prepared)
        ctx.progress((i + 1) / n)


def morph_register_stage(ctx: StageContext) -> None:
    """Stage 2 (``register_meshes``)."""
    from conformorph.pipelines.face_morph import register_meshes

    n = len(ctx.params["meshes"])
    prepared = [_load(ctx, f"prepared_{i}.npz") for i in range(n)]
    ctx.progress(0.2)
    reg = register_meshes(prepared, morph_options_from_params(ctx.params).registration)
    _save(ctx, "registration.npz", reg)


def _key_times(ctx: StageContext) -> np.ndarray:
    times = morph_options_from_params(ctx.params).times
    n = len(ctx.params["meshes"])
    return np.arange(n, dtype=np.float64) if times is None else np.asarray(times, dtype=np.float64)


def morph_frames_stage(ctx: StageContext) -> None:
    """Stage 3 (``compute_frames``)."""
    from conformorph.pipelines.face_morph import compute_frames, frame_times_for

    options = morph_options_from_params(ctx.params)
    reg = _load(ctx, "registration.npz")
    meshes, _ = _prepared_meshes(ctx)
    times = _key_times(ctx)
    ft = (
        frame_times_for(times, options.frames)
        if options.frame_times is None
        else np.asarray(options.frame_times, dtype=np.float64)
    )
    ctx.progress(0.1)
    _save(ctx, "frames.npz", compute_frames(reg, meshes, times, ft, options.homotopy))


def _prepared_meshes(
    ctx: StageContext, loaded: list[dict[str, Any]] | None = None
) -> tuple[list[tuple[Any, Any]], list[dict[str, Any]]]:
    """Every key's prepared mesh and its meta (with the mesh id); ``loaded``: the
    ``prepared_{i}.npz`` records when the caller has read them already."""
    meshes, metas = [], []
    for i in range(len(ctx.params["meshes"])):
        prepared = _load(ctx, f"prepared_{i}.npz") if loaded is None else loaded[i]
        meshes.append((prepared["V"], prepared["F"]))
        metas.append({"mesh": ctx.params["meshes"][i]["id"], **prepared.get("meta", {})})
    return meshes, metas


def _key_name(ctx: StageContext, i: int) -> str:
    """Key i's name in the GLBs: its uploaded file's stem, else ``key{i}``."""
    m = ctx.params["meshes"][i]
    name = m.get("filename") or m.get("name")
    return Path(str(name)).stem if name else f"key{i}"


def morph_export_stage(ctx: StageContext) -> None:
    """Stage 4 (``export_outputs``): ``animation.glb`` and optional ``frames/NNN.glb``."""
    from conformorph.pipelines.face_morph import export_outputs
    from conformorph.pipelines.face_morph.export import SceneInfo
    from conformorph.pipelines.face_morph.full_resolution import output_resolution_frames

    reg = _load(ctx, "registration.npz")
    fr = _load(ctx, "frames.npz")
    prepared = [_load(ctx, f"prepared_{i}.npz") for i in range(len(ctx.params["meshes"]))]
    _, inputs = _prepared_meshes(ctx, prepared)
    scene = SceneInfo(
        metres_per_unit=float(inputs[0].get("units", {}).get("metres_per_unit", 1.0)),
        key_names=tuple(_key_name(ctx, i) for i in range(len(inputs))),
        key_times=tuple(float(t) for t in _key_times(ctx)),
    )
    options = morph_options_from_params(ctx.params).export
    reg, fr, _ = output_resolution_frames(
        reg,
        fr,
        scene.key_times[0],
        options.output_resolution,
        prepared[0],
        lambda: load_mesh_file(*_mesh_path(ctx, 0)),
    )
    with ctx.scratch_dir() as d:
        files = export_outputs(reg, fr, d, options, scene=scene)
        for name in sorted(files):
            ctx.put_file(name, d / name)


def morph_metrics_stage(ctx: StageContext) -> None:
    """Stage 5: key frames of the method and the baselines against the inputs; ``metrics.json``."""
    from conformorph.pipelines.face_morph import morph_metrics
    from conformorph.pipelines.face_morph.metrics import key_frame_metrics
    from conformorph.pipelines.face_morph.run import skipped_measures
    from conformorph.pipelines.face_morph.units import units_summary

    reg = _load(ctx, "registration.npz")
    fr = _load(ctx, "frames.npz")
    meshes, inputs = _prepared_meshes(ctx)
    times = _key_times(ctx)
    options = morph_options_from_params(ctx.params)
    curvature = options.homotopy.curvature
    frames_meta = {**fr.get("meta", {})}
    bounds: dict[str, list[float]] = {}
    frames_meta["key_frame_L2_to_inputs"] = key_frame_metrics(
        reg, meshes, times, curvature, frames=fr, bounds=bounds
    )
    frames_meta["key_frame_L2_bound"] = bounds
    files = {
        name: rec["size"]
        for name, rec in ctx.job.artifacts.items()
        if not rec.get("internal") and name.endswith(".glb")
    }
    metrics = morph_metrics(
        inputs,
        reg.get("meta", {}),
        times,
        fr["frame_times"],
        frames_meta,
        files,
        {**ctx.job.stage_seconds},
    )
    metrics["units"] = units_summary(inputs, options.units)
    # what this job left out, as the CLI says it (this stage is the job's key metrics)
    metrics["skipped"] = skipped_measures(
        replace(options, homotopy=replace(options.homotopy, key_metrics=True)), measured=True
    )
    if names.detects_landmarks(ctx.params):
        metrics["landmarks"] = detected_report(ctx)
    elif ctx.params.get("landmark_provenance"):
        from conformorph.pipelines.landmark_document import landmark_provenance_report

        metrics["landmarks"] = landmark_provenance_report(
            ctx.params["landmark_provenance"],
            reg.get("meta", {}).get("landmark_fit"),
        )
    ctx.put_json("metrics.json", metrics)


STAGE_BODIES: dict[str, StageBody] = {
    names.STAGE_MORPH_PREPARE: morph_prepare_stage,
    names.STAGE_MORPH_REGISTER: morph_register_stage,
    names.STAGE_MORPH_FRAMES: morph_frames_stage,
    names.STAGE_MORPH_EXPORT: morph_export_stage,
    names.STAGE_MORPH_METRICS: morph_metrics_stage,
}
