"""The landmarks of stage 1 (section 3 of the face paper) on a key's surface: the per-pair
part of a key (:func:`key_landmark_arrays`), the input landmarks carried onto a prepared
mesh (:func:`translated_entries`) and the landmark vertex ids the face cut uses."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays


def checked_confidence(
    confidence: NDArray[np.float64] | None, m: int, mesh_index: int
) -> NDArray[np.float64]:
    """The landmark confidences of one key as an (m,) array in [0, 1] (default all 1).

    Raises
    ------
    ValueError
        When the count differs from the landmarks' or a value is outside [0, 1]
        (or not finite).
    """
    if confidence is None:
        return np.ones(m)
    c = np.asarray(confidence, dtype=np.float64)
    if c.shape != (m,) or not np.all(np.isfinite(c)) or np.any((c < 0) | (c > 1)):
        raise ValueError(
            f"mesh {mesh_index}: landmark confidence must be {m} values in [0, 1], got "
            f"shape {c.shape}" + (f", range [{c.min():g}, {c.max():g}]" if c.size else "")
        )
    return c


def key_landmark_arrays(
    surface: Arrays,
    landmark_entries: list[Any],
    landmark_confidence: NDArray[np.float64] | None,
    mesh_index: int,
) -> Arrays:
    """Stage 1's landmarks on a key's :func:`key_surface`: the per-pair part.

    Parameters
    ----------
    surface : dict of arrays
        :func:`key_surface`'s result (not modified; its ``meta`` is copied).
    landmark_entries : list
        Vertex indices or [x, y, z] points on ``surface["V"]``.
    landmark_confidence : (k,) float64, optional
        See :func:`prepare_mesh`.
    mesh_index : int

    Returns
    -------
    dict of arrays
        ``surface``'s arrays and ``lm_tri, lm_bary, lm_uv, lm_points, lm_snap,
        lm_confidence``; ``meta`` gains ``landmark_snap_distance_max``.
    """
    from conformorph.pipelines.landmarks_io import resolve_landmarks

    t0 = time.perf_counter()
    V, F, uv, Vn = surface["V"], surface["F"], surface["uv"], surface["Vn"]
    lms = resolve_landmarks(landmark_entries, V, F, mesh_index=mesh_index)
    confidence = checked_confidence(landmark_confidence, lms.triangle.size, mesh_index)
    out: Arrays = {k: v for k, v in surface.items() if k != "meta"}
    out.update(
        lm_tri=lms.triangle,
        lm_bary=lms.barycentric,
        lm_uv=np.einsum("mj,mjk->mk", lms.barycentric, uv[F[lms.triangle]]),
        lm_points=np.einsum("mj,mjk->mk", lms.barycentric, Vn[F[lms.triangle]]),
        lm_snap=lms.snap_distance,
        lm_confidence=confidence,
    )
    meta = dict(surface["meta"], mesh_index=mesh_index)
    meta["seconds"] = dict(meta["seconds"])
    meta["seconds"]["validate_and_landmarks"] += time.perf_counter() - t0
    meta["landmark_snap_distance_max"] = float(lms.snap_distance.max())
    out["meta"] = meta
    return out


def landmark_vertex_ids(entries: list[Any], V: NDArray[np.float64]) -> NDArray[np.int64] | None:
    """Vertex ids of the landmark entries, for the face cut: the ids themselves, the nearest
    vertex of a point; entries of neither kind (or out of range) are skipped.

    Parameters
    ----------
    entries : list
        One key's landmark entries (vertex ids or ``[x, y, z]`` points).
    V : (n, 3) float64

    Returns
    -------
    (k,) int64 or None
        None when fewer than 3 entries give a vertex (the cut then finds the
        face from the surface's shape).
    """
    ids: list[int] = []
    for e in entries:
        if isinstance(e, int | float) and not isinstance(e, bool):
            if float(e).is_integer() and 0 <= int(e) < V.shape[0]:
                ids.append(int(e))
        elif isinstance(e, list | tuple) and len(e) == 3:
            p = np.asarray(e, dtype=np.float64)
            if np.all(np.isfinite(p)):
                ids.append(int(np.argmin(np.linalg.norm(V - p, axis=1))))
    return np.asarray(ids, dtype=np.int64) if len(set(ids)) >= 3 else None


def translated_entries(
    entries: list[Any], V: NDArray[np.float64], prepared: Any, mesh_index: int
) -> list[Any]:
    """One key's landmark entries carried onto its prepared mesh (``--prepare auto``).

    Parameters
    ----------
    entries : list
        Vertex ids of the input or [x, y, z] points.
    V : (n, 3) float64
        The input's vertices.
    prepared : PreparedMesh
        What :func:`conformorph.pipelines.preparation.prepare_mesh_arrays` made of it.
    mesh_index : int

    Returns
    -------
    list
        Vertex ids are translated through the vertex map; on a decimated mesh a vertex
        landmark becomes a point landmark at its input position; points are kept.

    Raises
    ------
    LandmarkIndexError
        A landmark on a vertex the preparation removed.
    """
    from conformorph.pipelines.landmarks_io import LandmarkIndexError
    from conformorph.pipelines.preparation import input_landmark_ids

    def numeric(e: Any) -> bool:
        return isinstance(e, int | float) and not isinstance(e, bool)

    # every vertex landmark's output row in one call (its vertex map pass is O(n))
    inside = [int(e) for e in entries if numeric(e) and 0 <= int(e) < V.shape[0]]
    rows = iter(input_landmark_ids(prepared, inside, V).tolist() if inside else [])
    new: list[Any] = []
    for j, e in enumerate(entries):
        if numeric(e):
            if not 0 <= int(e) < V.shape[0]:
                new.append(e)  # out of range: resolve_landmarks names it
                continue
            k = int(next(rows))
            if k >= 0 and prepared.merged_into is not None:
                # decimated: the landmark's own position, a point on the decimated surface
                # (resolve_landmarks projects it), not the nearest vertex (1.3 mm away on
                # the ICT face at 50k, and two landmarks can share it)
                new.append([float(x) for x in V[int(e)]])
                continue
            if k < 0:
                raise LandmarkIndexError(
                    f"mesh {mesh_index + 1}, landmark {j + 1} (landmarks[{mesh_index}][{j}]): "
                    f"vertex {int(e)} was removed by the "
                    "preparation (--prepare auto; see its report); pick another vertex or give "
                    "the landmark as a point"
                )
            new.append(k)
        else:
            new.append(e)
    return new
