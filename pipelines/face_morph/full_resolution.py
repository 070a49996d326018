"""Full-resolution output: the morph computed on the decimated working mesh, written at the
first key's input resolution (``--output-resolution input``).

Above the vertex budget the keys are decimated for the numerics (``--prepare auto``). The
deformation of the working mesh is transferred back to key 0 as read: every input vertex
is embedded on the working mesh's frame at key 0 (closest point plus its detail offset,
:func:`conformorph.geometry.detail_transfer.detail_embedding`) and follows that place at
every frame (:func:`conformorph.geometry.detail_transfer.transferred_frames`), so the
scan's detail rides on the morph. Frame k's rigid placement is the working mesh's; the
export's rig places the frames from ``frames_V``
(:func:`conformorph.pipelines.face_morph.export.rest_pose_rig`), so no shape-space copy
of the dense frames is made.

Appearance (vertex colours, textures) is resampled onto the consistent mesh, not the
input: a morph with appearance keeps the working resolution (reported).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays

#: ``--output-resolution`` choices: the first key's ``input`` resolution, the ``working``
#: one, or ``auto``: input up to :data:`AUTO_MAX_VERTICES` input vertices, working above
OUTPUT_RESOLUTIONS = ("auto", "input", "working")
#: the one default of ``--output-resolution``, the job field and the batch key
DEFAULT_OUTPUT_RESOLUTION = "auto"
#: ``auto`` writes key 0 at its input resolution up to this many vertices. Measured
#: (two 273k-vertex faces, 30 frames, 2-core machine): input 27.7 s, 1.84 GB peak, a 57 MB
#: GLB against working 12.2 s, 465 MB, 12 MB; two 1.09M-vertex faces at input resolution
#: 40-42 s cold and 4.4-4.5 GB peak against 24 s and 2.2 GB at the working one (December
#: 2026), past the default path's budget of 30 s and 3 GB (issue 32)
AUTO_MAX_VERTICES = 300_000


def over_cap_reason(n_input: int, max_vertices: int) -> str:
    """Why ``auto`` keeps the working resolution for a key 0 of ``n_input`` vertices."""
    return (
        f"key 0 has {n_input:,} vertices, more than output_resolution auto writes "
        f"({max_vertices:,}); --output-resolution input asks for them"
    )


def _input_vertex_count(prepared0: Arrays) -> int | None:
    """Key 0's vertex count as read, from its preparation report (None: not recorded)."""
    n = prepared0.get("meta", {}).get("preparation", {}).get("input", {}).get("vertices")
    return None if n is None else int(n)


def output_resolution_frames(
    reg: Arrays,
    frames: Arrays,
    key0_time: float,
    choice: str,
    prepared0: Arrays,
    read_key0: Callable[[], tuple[NDArray[np.float64], NDArray[np.int64]]],
) -> tuple[Arrays, Arrays, dict[str, Any]]:
    """The stage-2 and stage-3 dicts at the output resolution ``choice`` asks for, and
    ``metrics.json``'s ``output_resolution`` report (the CLI's run and the worker's
    export stage alike).

    Key 0 as read is needed only when it was decimated (``prep_vertex_map`` in
    ``prepared0``) and, under ``auto``, when its input vertex count (``prepared0``'s
    preparation report) is within :data:`AUTO_MAX_VERTICES`; only then is ``read_key0``
    called (a 1M-vertex OBJ is 3-4 s of parsing) and :func:`full_resolution_frames` run.

    Parameters
    ----------
    reg, frames : stage-2 and stage-3 dicts
    key0_time : float
    choice : {"auto", "input", "working"}
    prepared0 : stage-1 dict of key 0
    read_key0 : callable
        Returns key 0 as read, ``(V (p, 3), F (q, 3))`` in the working unit.

    Returns
    -------
    reg_out, frames_out, report
        As :func:`full_resolution_frames`; the inputs themselves with
        ``{"output_resolution": "working"}`` (and a ``reason`` above the cap) otherwise.
    """
    keep: dict[str, Any] = {"output_resolution": "working"}
    if choice == "working" or "prep_vertex_map" not in prepared0:
        return reg, frames, keep
    cap = AUTO_MAX_VERTICES if choice == "auto" else None
    n_in = _input_vertex_count(prepared0)
    if cap is not None and n_in is not None and n_in > cap:  # known without reading it
        return reg, frames, {**keep, "reason": over_cap_reason(n_in, cap)}
    return full_resolution_frames(reg, frames, key0_time, read_key0(), cap)


def full_resolution_frames(
    reg: Arrays,
    frames: Arrays,
    key0_time: float,
    dense: tuple[NDArray[np.float64], NDArray[np.int64]],
    max_vertices: int | None = None,
) -> tuple[Arrays, Arrays, dict[str, Any]]:
    """Stage-2 and stage-3 dicts whose mesh is the dense key 0, and a report.

    Parameters
    ----------
    reg : stage-2 dict
        ``cm_F`` (m, 3): the working (consistent) mesh.
    frames : stage-3 dict
        ``frames_V (T, n, 3)``, ``frame_R``, ``frame_t``, ``frame_s``, ``frame_times``.
    key0_time : float
        Key 0's time: the frame there is the working mesh the input is embedded on.
    dense : (V (p, 3), F (q, 3))
        Key 0 as read, in the working unit.
    max_vertices : int, optional
        Keep the working mesh when key 0 has more vertices than this (``auto``).

    Returns
    -------
    reg_out, frames_out : dicts
        ``cm_F`` the dense faces; ``frames_V`` (T, p, 3) and no ``frames_aligned``; no
        appearance. Unchanged (the inputs themselves) when the report says why not.
    report : dict
        ``{"output_resolution", "vertices", "working_vertices", "seconds"}`` or, when the
        working resolution is kept, ``{"output_resolution": "working", "reason"}``.
    """
    from conformorph.geometry.detail_transfer import detail_embedding, transferred_frames

    t0 = time.perf_counter()
    ft = np.asarray(frames["frame_times"], dtype=np.float64)
    at_key = np.flatnonzero(np.abs(ft - key0_time) <= 1e-9 * max(1.0, abs(float(ft[-1] - ft[0]))))
    keep = {"output_resolution": "working"}
    if "key_textures" in reg or "frames_colors" in frames:
        return reg, frames, {**keep, "reason": "appearance lives on the working mesh"}
    if at_key.size == 0:
        return reg, frames, {**keep, "reason": "no frame at key 0's time to embed the input on"}
    V, F = (np.asarray(dense[0], dtype=np.float64), np.asarray(dense[1], dtype=np.int64))
    n = int(frames["frames_V"].shape[1])
    if V.shape[0] <= n:
        return reg, frames, {**keep, "reason": "key 0 was not decimated"}
    if max_vertices is not None and V.shape[0] > max_vertices:
        return reg, frames, {**keep, "reason": over_cap_reason(V.shape[0], max_vertices)}
    cm_F = np.asarray(reg["cm_F"], dtype=np.int64)
    emb = detail_embedding(V, frames["frames_V"][int(at_key[0])], cm_F)
    placed = transferred_frames(emb, np.asarray(frames["frames_V"]), cm_F)
    reg_out = {k: v for k, v in reg.items() if k not in ("cm_tex_uv",)}
    reg_out["cm_F"] = F
    # the export places the frames from frames_V (rest_pose_rig); the working mesh's
    # shape-space frames do not fit the dense mesh and are left out
    frames_out = {k: v for k, v in frames.items() if k != "frames_aligned"}
    frames_out["frames_V"] = placed
    report = {
        "output_resolution": "input",
        "vertices": int(V.shape[0]),
        "working_vertices": n,
        "seconds": time.perf_counter() - t0,
    }
    return reg_out, frames_out, report
