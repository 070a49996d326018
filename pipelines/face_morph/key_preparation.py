"""Stage 1, one key at a time (section 3 of the face paper): validate, normalise by the
diameter, disk conformal map, H, Hn, λ, the landmarks on the surface and on the disk;
plus the key-mesh repairs asked for first (hole filling, ear removal)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays, KeyOptions
from conformorph.pipelines.face_morph.textures import read_texture, read_vertex_colors
from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET


def _checked_appearance(
    n: int,
    mesh_index: int,
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    texture: NDArray[np.uint8] | None,
) -> tuple[Any, Any, Any]:
    """``(tex_uv, colors, texture)`` as arrays, checked against the vertex count ``n``."""
    if tex_uv is not None:
        tex_uv = np.asarray(tex_uv, dtype=np.float64)
        if tex_uv.shape != (n, 2) or not np.all(np.isfinite(tex_uv)):
            raise ValueError(
                f"mesh {mesh_index}: tex_uv must be a finite ({n}, 2) array, got {tex_uv.shape}"
            )
    if texture is not None:
        texture = np.asarray(texture)
        if tex_uv is None:
            raise ValueError(f"mesh {mesh_index}: a texture needs texture coordinates (tex_uv)")
        if texture.dtype != np.uint8 or texture.ndim != 3 or texture.shape[2] != 3:
            raise ValueError(
                f"mesh {mesh_index}: texture must be an (h, w, 3) uint8 image, got "
                f"{texture.dtype} {texture.shape}"
            )
    if colors is not None:
        colors = np.asarray(colors, dtype=np.float64)
        if colors.shape != (n, 3) or not np.all((colors >= 0) & (colors <= 1)):
            raise ValueError(
                f"mesh {mesh_index}: colors must be ({n}, 3) in [0, 1], got {colors.shape}"
            )
    return tex_uv, colors, texture


def unfolded_disk_map(
    Vn: NDArray[np.float64], F: NDArray[np.int64], *, mesh_index: int = 0, method: str = "fast"
) -> tuple[NDArray[np.float64], Any]:
    """The disk conformal map of one key, refused when its fold repair leaves folds.

    Parameters
    ----------
    Vn : (n, 3) float64
        The diameter-normalised key.
    F : (m, 3) int64
    mesh_index : int
        Position among the inputs (error messages).
    method : str
        Passed to :func:`conformorph.geometry.disk_conformal_map`.

    Returns
    -------
    uv : (n, 2) float64
        The harmonic map itself, not the angle-refined one.
    info : DiskMapInfo
        The map's diagnostics.

    Raises
    ------
    FoldedMapError
        When the disk map keeps folded triangles after its fold repair
        (``fold_policy="repair"``): the mesh and the count are named.
    """
    from conformorph.geometry import disk_conformal_map

    # the harmonic map itself, not the angle-refined one: the frames are rebuilt
    # with the disk's cotangent Laplacian, which reproduces the surface where the
    # map is harmonic for it (flat disk: 4e-7 of its size, 2e-4 after the angle
    # refinement; see conformorph.geometry.disk_conformal_map's refine_angles)
    uv, info = disk_conformal_map(Vn, F, method=method, refine_angles=False)  # type: ignore[arg-type]
    if info.flipped:
        # never carry a folded disk map on: every later map and frame would fold with it
        from conformorph.geometry.flipped_triangles import flipped_triangles
        from conformorph.geometry.mesh_errors import FoldedMapError

        bad = np.flatnonzero(flipped_triangles(uv, F))
        raise FoldedMapError(
            f"mesh {mesh_index}: the disk map still has {int(info.flipped)} folded triangles "
            f"after the fold repair ({int(info.flipped_before_repair)} before it; faces "
            f"{bad[:8].tolist()}); the surface probably folds over itself or has "
            "near-degenerate triangles there: repair the mesh and retry"
        )
    return uv, info


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


def prepare_mesh(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    landmark_entries: list[Any],
    *,
    mesh_index: int = 0,
    disk_method: str = "fast",
    tex_uv: NDArray[np.float64] | None = None,
    colors: NDArray[np.float64] | None = None,
    texture: NDArray[np.uint8] | None = None,
    landmark_confidence: NDArray[np.float64] | None = None,
) -> Arrays:
    """Stage 1 for one mesh: validation, normalisation, disk map, H, Hn, λ, landmarks.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    landmark_entries : list
        Vertex indices or [x, y, z] points (see :mod:`conformorph.pipelines.landmarks_io`).
    mesh_index : int
        Position among the inputs (error messages).
    disk_method : str
        Passed to :func:`conformorph.geometry.disk_conformal_map`.
    tex_uv : (n, 2) float64, optional
        Texture coordinates (OBJ convention, origin bottom left), resampled
        with everything else.
    colors : (n, 3) float64, optional
        Per-vertex colours in [0, 1].
    texture : (h, w, 3) uint8, optional
        The texture image ``tex_uv`` points into (needs ``tex_uv``).
    landmark_confidence : (m,) float64, optional
        Confidence of every landmark in [0, 1] (e.g. the detector's), used by the
        ``tolerant`` landmark fit; default 1 each.

    Returns
    -------
    dict of arrays
        ``V, F, Vn, uv, lam, H, Hn, lm_tri, lm_bary, lm_uv, lm_points,
        lm_snap, lm_confidence, norm_translation, norm_scale`` (+ ``tex_uv``, ``colors``,
        ``texture``) and ``meta`` (disk-map diagnostics, seconds).

    Raises
    ------
    FoldedMapError
        When the disk map keeps folded triangles after its fold repair
        (:func:`unfolded_disk_map`): nothing folded is passed on.
    """
    from conformorph.geometry import (
        conformal_factor,
        mean_curvature,
        mean_curvature_vector,
        validate_mesh,
    )
    from conformorph.geometry.rigid_alignment import normalize_by_diameter
    from conformorph.pipelines.landmarks_io import resolve_landmarks

    t0 = time.perf_counter()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    report = validate_mesh(V, F, require_disk=True)
    tex_uv, colors, texture = _checked_appearance(V.shape[0], mesh_index, tex_uv, colors, texture)
    lms = resolve_landmarks(landmark_entries, V, F, mesh_index=mesh_index)
    confidence = checked_confidence(landmark_confidence, lms.triangle.size, mesh_index)
    Vn, N = normalize_by_diameter(V)
    t1 = time.perf_counter()
    uv, info = unfolded_disk_map(Vn, F, mesh_index=mesh_index, method=disk_method)
    t2 = time.perf_counter()
    out: Arrays = {
        "V": V,
        "F": F,
        "Vn": Vn,
        "uv": uv,
        "lam": conformal_factor(Vn, F, uv),
        "H": mean_curvature(Vn, F),
        "Hn": mean_curvature_vector(Vn, F),
        "lm_tri": lms.triangle,
        "lm_bary": lms.barycentric,
        "lm_uv": np.einsum("mj,mjk->mk", lms.barycentric, uv[F[lms.triangle]]),
        "lm_points": np.einsum("mj,mjk->mk", lms.barycentric, Vn[F[lms.triangle]]),
        "lm_snap": lms.snap_distance,
        "lm_confidence": confidence,
        "norm_translation": N.translation,
        "norm_scale": np.array(N.scale),
    }
    for name, a in (("tex_uv", tex_uv), ("colors", colors), ("texture", texture)):
        if a is not None:
            out[name] = a
    out["meta"] = {
        "mesh_index": mesh_index,
        "n_vertices": int(V.shape[0]),
        "n_faces": int(F.shape[0]),
        "boundary_loops": int(getattr(report, "boundary_loops", 1)),
        "diameter": float(N.scale),
        "disk_map": {
            "method": info.method,
            "flipped": int(info.flipped),
            "flipped_before_repair": int(info.flipped_before_repair),
            "repaired_vertices": int(info.repaired_vertices),
            "boundary_circle_error": float(info.boundary_circle_error),
        },
        "landmark_snap_distance_max": float(lms.snap_distance.max()),
        "seconds": {
            "validate_and_landmarks": t1 - t0,
            "disk_map": t2 - t1,
            "curvature": time.perf_counter() - t2,
        },
    }
    return out


def remove_key_ears(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    mesh_index: int,
) -> tuple[Any, Any, list[Any], Any, Any]:
    """Remove boundary ears and translate vertex-index landmarks."""
    from conformorph.geometry import remove_boundary_ears
    from conformorph.pipelines.landmarks_io import LandmarkIndexError

    V2, F2, kept = remove_boundary_ears(V, F)
    new: list[Any] = []
    for j, e in enumerate(entries):
        if isinstance(e, int | float) and not isinstance(e, bool):
            k = int(np.searchsorted(kept, int(e)))
            if k >= kept.size or kept[k] != int(e):
                raise LandmarkIndexError(
                    f"mesh {mesh_index + 1}, landmark {j + 1} (landmarks[{mesh_index}][{j}]): "
                    f"vertex {int(e)} is a boundary ear removed "
                    "by --remove-ears"
                )
            new.append(k)
        else:
            new.append(e)
    return (
        V2,
        F2,
        new,
        None if tex_uv is None else tex_uv[kept],
        None if colors is None else colors[kept],
    )


def fill_key_holes(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
) -> tuple[Any, Any, Any, Any]:
    """Fill holes with fans; a new centre's UV and colour average its loop's."""
    from conformorph.geometry import fill_holes

    V2, F2 = fill_holes(V, F)
    n, m = V.shape[0], F.shape[0]
    fans = F2[m:]  # (loop vertex j+1, j, centre c): each loop vertex once per centre

    def extend(a: NDArray[np.float64] | None) -> NDArray[np.float64] | None:
        if a is None or V2.shape[0] == n:
            return a
        sums = np.zeros((V2.shape[0] - n, a.shape[1]))
        np.add.at(sums, fans[:, 2] - n, a[fans[:, 1]])
        counts = np.bincount(fans[:, 2] - n, minlength=V2.shape[0] - n)
        return np.vstack([a, sums / counts[:, None]])

    return V2, F2, extend(tex_uv), extend(colors)


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


def prepare_key_arrays(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    mesh_index: int,
    vertex_budget: int | None = DEFAULT_VERTEX_BUDGET,
) -> tuple[Any, Any, list[Any], Any, Any, Any]:
    """The preparation step on one key (``--prepare auto``), its data carried over.

    Vertex-index landmarks are translated through the vertex map (one on a
    removed vertex is an error naming it); texture coordinates and colours
    are copied for kept vertices and filled by the bi-Laplacian for added
    ones. Above ``vertex_budget`` vertices the mesh is decimated, a landmark on a
    decimated mesh becoming a point landmark at its input position (projected onto
    the decimated surface by :func:`conformorph.pipelines.landmarks_io.resolve_landmarks`). Returns
    ``(V, F, entries, tex_uv, colors, prepared)``.

    Raises
    ------
    LandmarkIndexError
        A landmark on a vertex the preparation removed.
    UnpreparableMeshError
        When the prepared mesh is still not a disk (the validation's message).
    """
    from conformorph.pipelines.landmarks_io import LandmarkIndexError
    from conformorph.pipelines.preparation import (
        PrepareOptions,
        UnpreparableMeshError,
        input_landmark_ids,
        prepare_mesh_arrays,
        vertex_values,
    )

    prepared = prepare_mesh_arrays(
        V,
        F,
        PrepareOptions(vertex_budget=vertex_budget),
        landmark_ids=landmark_vertex_ids(entries, V),
    )
    if not prepared.report["disk"]:
        raise UnpreparableMeshError(
            f"mesh {mesh_index}: still not a disk after preparation: {prepared.report['problem']}"
        )
    if not prepared.changed:
        return V, F, entries, tex_uv, colors, prepared
    new: list[Any] = []
    for j, e in enumerate(entries):
        if isinstance(e, int | float) and not isinstance(e, bool):
            if not 0 <= int(e) < V.shape[0]:
                new.append(e)  # out of range: resolve_landmarks names it
                continue
            k = int(input_landmark_ids(prepared, [int(e)], V)[0])
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
    return (
        prepared.V,
        prepared.F,
        new,
        None if tex_uv is None else vertex_values(prepared, tex_uv),
        None if colors is None else np.clip(vertex_values(prepared, colors), 0.0, 1.0),
        prepared,
    )


def repair_key_mesh(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    mesh_index: int,
    *,
    fill_holes: bool,
    remove_ears: bool,
) -> tuple[Any, Any, list[Any], Any, Any]:
    """The requested repairs of one key mesh (``--fill-holes``, then ``--remove-ears``).

    Holes are filled with fans (input ids kept, centres appended, their UVs
    and colours averaged over the loop); ears are removed and vertex-index
    landmarks translated (a landmark on a removed ear is an error). Returns
    ``(V, F, entries, tex_uv, colors)``, the inputs themselves without repairs.
    """
    if fill_holes:
        V, F, tex_uv, colors = fill_key_holes(V, F, tex_uv, colors)
    if remove_ears:
        V, F, entries, tex_uv, colors = remove_key_ears(V, F, entries, tex_uv, colors, mesh_index)
    return V, F, entries, tex_uv, colors


def prepare_key_file(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    mesh_index: int,
    mesh_path: str | Path,
    *,
    texture_path: str | Path | None = None,
    file_type: str | None = None,
    options: KeyOptions | None = None,
    confidence: list[float] | None = None,
) -> Arrays:
    """Stage 1 for one key read from a file: its appearance, the repairs, :func:`prepare_mesh`.

    Parameters
    ----------
    V : (n, 3) float64
        The key as read from ``mesh_path``.
    F : (m, 3) int64
    entries : list
        The key's landmark entries.
    mesh_index : int
        Position among the inputs.
    mesh_path : path
        The key's file, for its texture coordinates or vertex colours.
    texture_path : path, optional
        The key's texture image; without it, the file's vertex colours (if any).
    file_type : str, optional
        Mesh file type when the path has no telling extension.
    options : KeyOptions, optional (default ``KeyOptions()``)
        Repairs and disk map.
    confidence : list of float, optional
        The landmarks' confidences (the landmark file's ``confidence``), default 1.

    Returns
    -------
    dict of arrays
        The stage-1 dict of :func:`prepare_mesh` (its ``V, F`` are the repaired key);
        with ``options.prepare == "auto"`` its ``meta["preparation"]`` is the
        preparation's report and, when the preparation changed the mesh,
        ``prep_vertex_map`` (n2,) int64 the input row of every key vertex (-1 added).
    """
    options = KeyOptions() if options is None else options
    tex_uv = image = None
    colors = None
    if texture_path is None:
        colors = read_vertex_colors(mesh_path, V.shape[0], file_type=file_type)
    else:
        tex_uv, image = read_texture(mesh_path, texture_path, V.shape[0], file_type=file_type)
    prepared = None
    if options.prepare == "auto":
        V, F, entries, tex_uv, colors, prepared = prepare_key_arrays(
            V, F, entries, tex_uv, colors, mesh_index, options.vertex_budget
        )
    V, F, entry, tex_uv, colors = repair_key_mesh(
        V,
        F,
        entries,
        tex_uv,
        colors,
        mesh_index,
        fill_holes=options.fill_holes,
        remove_ears=options.remove_ears,
    )
    out = prepare_mesh(
        V,
        F,
        entry,
        mesh_index=mesh_index,
        disk_method=options.disk_method,
        tex_uv=tex_uv,
        colors=colors,
        texture=image,
        landmark_confidence=None if confidence is None else np.asarray(confidence),
    )
    if prepared is not None:
        out["meta"]["preparation"] = prepared.report
        if prepared.changed:
            out["prep_vertex_map"] = prepared.vertex_map
    return out
