"""The face morph from files to files (sections 3–5 of the face paper), step by step."""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from concurrent.futures import Future
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.export import SceneInfo, export_outputs
from conformorph.pipelines.face_morph.frames import compute_frames
from conformorph.pipelines.face_morph.full_resolution import output_resolution_frames
from conformorph.pipelines.face_morph.homotopy import check_frame_times, frame_times_for
from conformorph.pipelines.face_morph.key_artifact import cacheable
from conformorph.pipelines.face_morph.key_cache import DirectoryArtifactStore, prepare_key_cached
from conformorph.pipelines.face_morph.key_preparation import prepare_key_file
from conformorph.pipelines.face_morph.metrics import key_frame_metrics, morph_metrics
from conformorph.pipelines.face_morph.options import METHODS, Arrays, FaceMorphOptions, ProgressFn
from conformorph.pipelines.face_morph.registration import register_meshes
from conformorph.pipelines.face_morph.units import keys_to_one_scale


def key_and_frame_times(
    n_keys: int, options: FaceMorphOptions
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Key times (N + 1,) (default 0 … N) and frame times (T,) of ``options``, checked
    (also against the ranges every entry point shares: :mod:`conformorph.pipelines.job_fields`)."""
    from conformorph.pipelines.job_fields import check_morph_times

    times = options.times
    if times is not None and len(times) == n_keys:
        check_morph_times(times, options.frame_times, n_keys)
    elif times is None:
        check_morph_times(None, options.frame_times, n_keys)
    key_times = (
        np.arange(n_keys, dtype=np.float64)
        if times is None
        else np.asarray(times, dtype=np.float64)
    )
    if key_times.shape != (n_keys,):
        raise ValueError(f"--times needs {n_keys} values (one per mesh), got {key_times.size}")
    if np.any(np.diff(key_times) <= 0) or not np.all(np.isfinite(key_times)):
        raise ValueError(f"--times must be strictly increasing, got {key_times.tolist()}")
    if options.frame_times is None:
        return key_times, frame_times_for(key_times, options.frames)
    return key_times, check_frame_times(options.frame_times)


def skipped_measures(options: FaceMorphOptions, *, measured: bool) -> dict[str, str]:
    """What ``metrics.json`` leaves out for ``options``, and how to ask for it.

    Parameters
    ----------
    options : FaceMorphOptions
    measured : bool
        Whether anything measures the keys (key-frame metrics or truths).

    Returns
    -------
    dict
        ``key_frame_metrics`` and ``mt_baseline`` → why each was not computed;
        empty when nothing was left out.
    """
    out: dict[str, str] = {}
    if not options.homotopy.key_metrics:
        out["key_frame_metrics"] = (
            "not computed (conformorph morph --no-metrics, FrameOptions.key_metrics=False)"
        )
    if options.registration.method != "mt" and not (options.registration.baselines and measured):
        out["mt_baseline"] = (
            "the MT-only baseline was not built, so nothing measures it (conformorph morph "
            '--baselines, the job field "baselines": true or RegistrationOptions.baselines=True '
            "builds and measures it)"
        )
    return out


#: key files of at least this many bytes together are prepared in processes, one a key
#: (spawned), not threads, when FaceMorphOptions.key_processes allows it (the CLI does):
#: reading and decimating a big scan hold the GIL (numpy's text reader,
#: fast-simplification), so threads prepare such keys one after the other
PROCESS_KEYS_MIN_BYTES = 40 << 20
#: ``auto`` output resolution reads key 0 ahead (:func:`_key0_read_ahead`) up to this file
#: size: a plain OBJ face holds about 100-110 bytes a vertex (the 1.09M-vertex key of
#: bench_scan_scale: 116 MB), so 300,000 vertices is about 32 MB; the margin errs towards
#: reading ahead
AUTO_READ_AHEAD_MAX_BYTES = 48 << 20


def _prepare_key_from_path(
    path: str | Path,
    entries: Any,
    index: int,
    texture: str | Path | None,
    key_options: Any,
    confidence: Any,
    cache: str | None = None,
) -> Arrays:
    """Stage 1 for one key file (module level: a process pool calls it), through the key
    cache in folder ``cache`` when one is given and the key is :func:`cacheable`."""
    from conformorph.pipelines.mesh_io import read_mesh

    bypass = None if cache is None else cacheable(key_options, texture)
    if cache is not None and bypass is None:
        return prepare_key_cached(
            DirectoryArtifactStore(cache),
            path,
            entries,
            index,
            options=key_options,
            confidence=confidence,
        )
    V, F = read_mesh(path)
    out = prepare_key_file(
        V,
        F,
        entries,
        index,
        path,
        texture_path=texture,
        options=key_options,
        confidence=confidence,
    )
    if bypass is not None:
        out["meta"]["cache"] = {"state": "bypassed", "detail": bypass}
    return out


def _prepare_keys(
    paths: Sequence[Path],
    landmarks_path: str | Path,
    textures: Sequence[str | Path] | None,
    options: FaceMorphOptions,
) -> list[Arrays]:
    """Stage 1 for every key file, side by side (the first failing key raising): on
    threads, or in processes when ``options.key_processes`` is set and the files reach
    :data:`PROCESS_KEYS_MIN_BYTES`."""
    return _prepare_keys_reading_ahead(paths, landmarks_path, textures, options, False)[0]


def _prepare_keys_reading_ahead(
    paths: Sequence[Path],
    landmarks_path: str | Path,
    textures: Sequence[str | Path] | None,
    options: FaceMorphOptions,
    read_key0: bool,
) -> tuple[list[Arrays], Future[tuple[NDArray[np.float64], NDArray[np.int64]]] | None]:
    """:func:`_prepare_keys`, and with ``read_key0`` key 0 as read (``read_mesh``) when
    the keys are prepared in processes: one more job of the same pool, which runs once a
    key is done, on the core that key leaves idle, and goes on while the registration
    runs (None otherwise: the export reads it; numpy's text reader holds the GIL, so a
    thread would stall the registration instead). The export of a decimated key at its
    input resolution needs it: a 1M-vertex OBJ is 3-4 s of parsing."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from conformorph.geometry.threads import available_threads, map_in_threads
    from conformorph.pipelines.landmark_document import read_landmark_confidence
    from conformorph.pipelines.landmarks_io import read_landmark_file
    from conformorph.pipelines.mesh_io import read_mesh

    entries = read_landmark_file(landmarks_path, len(paths))
    confidence = read_landmark_confidence(landmarks_path, len(paths))
    jobs = [
        (
            paths[i],
            entries[i],
            i,
            textures[i] if textures else None,
            options.keys,
            confidence[i],
            options.key_cache,
        )
        for i in range(len(paths))
    ]
    workers = min(len(paths), available_threads())
    big = sum(Path(p).stat().st_size for p in paths) >= PROCESS_KEYS_MIN_BYTES
    if not (big and workers > 1 and options.key_processes):
        return map_in_threads(lambda job: _prepare_key_from_path(*job), jobs), None
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
    try:
        keys = [pool.submit(_prepare_key_from_path, *job) for job in jobs]
        dense = pool.submit(read_mesh, paths[0]) if read_key0 else None
        return [f.result() for f in keys], dense
    except BaseException:
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    finally:
        pool.shutdown(wait=False)  # the read of key 0 goes on; its future has the result


def _key0_read_ahead(path: Path, options: FaceMorphOptions) -> bool:
    """Whether the export will likely want key 0 as read: ``input`` resolution, or
    ``auto`` for a file small enough to hold at most about
    :data:`~conformorph.pipelines.face_morph.full_resolution.AUTO_MAX_VERTICES` vertices
    (:data:`AUTO_READ_AHEAD_MAX_BYTES`; a wrong guess costs one parse on an idle core,
    never the result)."""
    choice = options.export.output_resolution
    if not options.write_glb or choice == "working":
        return False
    return choice == "input" or path.stat().st_size <= AUTO_READ_AHEAD_MAX_BYTES


def _write_vertex_maps(prepared: list[Arrays], out: Path) -> dict[str, int]:
    """``OUTDIR/preparation.json`` when ``--prepare auto`` changed a key: per key its
    ``vertex_map`` (the input row of every key vertex, -1 for added ones; ``null`` for a
    key left as read). Returns ``{"preparation.json": bytes}`` or ``{}``."""
    if not any("prep_vertex_map" in p for p in prepared):
        return {}
    maps = [
        np.asarray(p["prep_vertex_map"]).tolist() if "prep_vertex_map" in p else None
        for p in prepared
    ]
    tmp = out / "preparation.json.tmp"
    tmp.write_text(json.dumps({"vertex_maps": maps}))
    tmp.replace(out / "preparation.json")
    return {"preparation.json": (out / "preparation.json").stat().st_size}


def corrected_landmark_document(
    prepared: Sequence[Arrays], reg_meta: dict[str, Any]
) -> dict[str, Any] | None:
    """The landmark file of the ``tolerant`` fit's corrected landmarks, or None.

    One list of [x, y, z] points per key in its input coordinates (the layout
    ``--landmarks`` reads): key 0's as given, key i's where the non-rigid ICP carried
    key i − 1's landmarks (a pair without one keeps key i's given landmarks).
    """
    pairs = reg_meta.get("pairs", [])
    got = [(p.get("nicp") or {}).get("corrected_landmarks") for p in pairs]
    if not any(g is not None for g in got):
        return None

    def factor(p: Arrays) -> float:  # key unit per working unit (keys_to_one_scale)
        return 1.0 / float(p["meta"].get("units", {}).get("factor_to_working_unit", 1.0))

    def given(p: Arrays) -> Any:
        P = np.einsum("mj,mjk->mk", p["lm_bary"], p["V"][p["F"][p["lm_tri"]]])
        return (P * factor(p)).tolist()

    rows = [given(prepared[0])]
    rows += [
        given(prepared[i]) if g is None else (np.asarray(g) * factor(prepared[i])).tolist()
        for i, g in enumerate(got, start=1)
    ]
    return {"landmarks": rows, "corrected_from": "landmark_fit=tolerant, non-rigid ICP"}


def run_face_morph(
    mesh_paths: Sequence[str | Path],
    landmarks_path: str | Path,
    outdir: str | Path,
    options: FaceMorphOptions | None = None,
    *,
    textures: Sequence[str | Path] | None = None,
    truths: Sequence[tuple[float, str | Path]] = (),
    progress: ProgressFn | None = None,
) -> dict[str, Any]:
    """Morph two or more face meshes with landmarks; write the GLB(s) and ``metrics.json``.

    Parameters
    ----------
    mesh_paths : sequence of paths
        Key meshes M0 … MN (N ≥ 1), disks, any connectivity each.
    landmarks_path : path
        Landmark JSON (see :mod:`conformorph.pipelines.landmarks_io`).
    outdir : path
        Output folder (created).
    options : FaceMorphOptions, optional (default ``FaceMorphOptions()``)
        Times, repairs, registration, homotopy, export.
    textures : sequence of paths, optional
        One image per mesh (meshes must carry per-vertex UVs).
    truths : sequence of (t, mesh path)
        Known surfaces for error metrics.
    progress : callable(fraction, stage), optional

    Returns
    -------
    dict
        The metrics also written to ``metrics.json``.
    """
    options = FaceMorphOptions() if options is None else options
    from conformorph.pipelines.mesh_io import read_mesh

    t_start = time.perf_counter()
    method = options.registration.method
    if method not in METHODS:
        raise ValueError(f"--method must be one of {', '.join(METHODS)}, got {method!r}")
    paths = [Path(p) for p in mesh_paths]
    if len(paths) < 2:
        raise ValueError(f"need at least 2 meshes, got {len(paths)}")
    key_times, ft = key_and_frame_times(len(paths), options)
    if textures is not None and len(textures) not in (0, len(paths)):
        raise ValueError(f"--texture needs one image per mesh ({len(paths)}), got {len(textures)}")
    report = progress if progress is not None else (lambda f, stage: None)
    seconds: dict[str, float] = {}

    t = time.perf_counter()  # section 3: disk maps, curvature, conformal factor per key
    prepared, dense_key0 = _prepare_keys_reading_ahead(
        paths, landmarks_path, textures, options, _key0_read_ahead(paths[0], options)
    )
    prepared, units = keys_to_one_scale(prepared, options.units)
    report(0.4, "maps")
    seconds["maps"] = time.perf_counter() - t

    t = time.perf_counter()  # section 4: alignment, MT/DMT, consistent mesh
    measured = options.homotopy.key_metrics or bool(truths)
    reg_options = replace(
        options.registration, baselines=options.registration.baselines and measured
    )
    reg = register_meshes(prepared, reg_options)
    seconds["registration"] = time.perf_counter() - t
    report(0.55, "registration")

    truth_meshes = [(float(tt), *read_mesh(pp)) for tt, pp in truths]  # section 5: homotopy
    meshes = [(p["V"], p["F"]) for p in prepared]
    # the key-frame metrics wait until the GLB is written (a viewer can open it first)
    frame_options = replace(options.homotopy, key_metrics=False)
    fr = compute_frames(reg, meshes, key_times, ft, frame_options, truths=truth_meshes)
    seconds["frames"] = fr["meta"]["seconds"]["frames"]
    report(0.8, "frames")

    t = time.perf_counter()
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Any] = {}
    resolution: dict[str, Any] = {"output_resolution": "working"}
    if options.write_glb:
        files, resolution = _export(
            reg, fr, prepared, paths, key_times, units, out, options, dense_key0
        )
    seconds["export"] = time.perf_counter() - t
    report(0.85, "export")

    t = time.perf_counter()
    if options.homotopy.key_metrics:
        bounds: dict[str, list[float]] = {}
        fr["meta"]["key_frame_L2_to_inputs"] = key_frame_metrics(
            reg, meshes, key_times, options.homotopy.curvature, frames=fr, bounds=bounds
        )
        fr["meta"]["key_frame_L2_bound"] = bounds
    fr["meta"]["seconds"]["metrics"] += time.perf_counter() - t
    seconds["frame_metrics"] = fr["meta"]["seconds"]["metrics"]
    seconds["total"] = time.perf_counter() - t_start
    inputs = [p["meta"] for p in prepared]
    files.update(_write_vertex_maps(prepared, out))
    metrics = morph_metrics(inputs, reg["meta"], key_times, ft, fr["meta"], files, seconds)
    metrics["skipped"] = skipped_measures(options, measured=measured)
    metrics["units"] = units
    metrics["output_resolution"] = resolution
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    corrected = corrected_landmark_document(prepared, reg["meta"])
    if corrected is not None:
        (out / "landmarks_corrected.json").write_text(json.dumps(corrected, indent=1))
    report(1.0, "done")
    return metrics


def _export(
    reg: dict[str, Any],
    fr: dict[str, Any],
    prepared: list[dict[str, Any]],
    paths: list[Path],
    key_times: NDArray[np.float64],
    units: dict[str, Any],
    out: Path,
    options: FaceMorphOptions,
    dense_key0: Future[tuple[NDArray[np.float64], NDArray[np.int64]]] | None = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Write the GLBs at the output resolution ``options.export`` asks for: key 0's input
    resolution (:func:`full_resolution_frames`) when it was decimated, else the working mesh.

    ``dense_key0`` is the read of key 0 started by :func:`_prepare_keys_reading_ahead`
    (None: key 0 is read here, when it is needed).

    Returns
    -------
    files : dict
        The written files, as in ``metrics.json``.
    resolution : dict
        ``metrics.json``'s ``output_resolution``: which was written and why.
    """
    from conformorph.pipelines.mesh_io import read_mesh

    reg_out, fr_out, resolution = output_resolution_frames(
        reg,
        fr,
        float(key_times[0]),
        options.export.output_resolution,
        prepared[0],
        lambda: read_mesh(paths[0]) if dense_key0 is None else dense_key0.result(),
    )
    files = export_outputs(
        reg_out,
        fr_out,
        out,
        options.export,
        scene=SceneInfo(
            metres_per_unit=units["metres_per_working_unit"],
            key_names=tuple(p.stem for p in paths),
            key_times=tuple(float(x) for x in key_times),
        ),
    )
    return files, resolution
