"""The preparation step itself: raw scan in, clean disk out, with a full report."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from conformorph import geometry
from conformorph.geometry._typing import FloatArray, IntArray
from conformorph.geometry.mesh_errors import MeshError
from conformorph.pipelines.preparation.decimation import working_resolution_step
from conformorph.pipelines.preparation.face_cut import cut_face, face_cut_reason
from conformorph.pipelines.preparation.options import PrepareOptions


class UnpreparableMeshError(MeshError):
    """A mesh that is still not a disk after the preparation step."""

    code = "unpreparable_mesh"


@dataclass(frozen=True)
class PreparedMesh:
    """A prepared mesh and how it relates to the input.

    Attributes
    ----------
    V : (n2, 3) float64
    F : (m2, 3) int64
        The prepared mesh.
    vertex_map : (n2,) int64
        Input row of every output vertex; -1 for vertices the preparation
        added (hole patches). A vertex split at a pinch appears more than
        once. Where nothing was removed, ``vertex_map[:n] == arange(n)``
        (the input's order is kept and additions come after).
    report : dict
        What was removed and added (JSON-ready; see :func:`prepare_mesh_arrays`).
    merged_into : (n,) int64 or None
        When the mesh was decimated to the working resolution: for every input
        vertex, the input row of the vertex it was merged into (an output
        vertex's ``vertex_map`` entry; -1 for one the clean-up dropped). None
        without decimation (default).
    """

    V: FloatArray
    F: IntArray
    vertex_map: IntArray
    report: dict[str, Any]
    merged_into: IntArray | None = None

    @property
    def changed(self) -> bool:
        """Whether the output differs from the input (vertices or faces)."""
        return not bool(self.report["unchanged"])


def _compact(F: IntArray, src: IntArray) -> tuple[IntArray, IntArray, IntArray]:
    """Drop vertices no face uses: (F re-indexed, src of the kept, kept rows)."""
    kept = np.unique(F)
    remap = np.full(src.size, -1, dtype=np.int64)
    remap[kept] = np.arange(kept.size)
    return remap[F], src[kept], kept


def _topology_steps(
    V: FloatArray, F: IntArray, src: IntArray, options: PrepareOptions, rep: dict[str, Any]
) -> tuple[FloatArray, IntArray, IntArray]:
    """Manifold repair and the largest component, recorded in ``rep``."""
    if options.repair_nonmanifold:
        s = geometry.split_nonmanifold(F, V.shape[0])
        V, F, src = V[s.source], s.F, src[s.source]
        rep["nonmanifold_faces_dropped"] = s.dropped_faces
        rep["split_vertices"] = s.split_vertices
        o = geometry.consistent_orientation(F, V.shape[0])
        F = o.F
        rep["reoriented_faces"] = int(o.flipped.sum())
    if options.keep_largest_component:
        sel = geometry.largest_component(F)
        F = F[sel.face_mask]
        rep["dropped_components"] = [
            {"vertices": v, "faces": f}
            for v, f in zip(sel.dropped_vertex_counts, sel.dropped_face_counts, strict=True)
        ]
    F, src, kept = _compact(F, src)
    return V[kept], F, src


def _surface_steps(
    V: FloatArray, F: IntArray, src: IntArray, options: PrepareOptions, rep: dict[str, Any]
) -> tuple[FloatArray, IntArray, IntArray]:
    """Faired hole filling and ear removal, recorded in ``rep``."""
    if options.fill_holes and geometry.mesh_edges(F).boundary.size:
        filled = geometry.fill_holes_faired(V, F, max_hole_fraction=options.max_hole_fraction)
        added = filled.V.shape[0] - V.shape[0]
        V, F = filled.V, filled.F
        src = np.concatenate([src, np.full(added, -1, dtype=np.int64)])
        rep["filled_holes"] = filled.filled_loop_sizes
        rep["unfilled_holes"] = filled.unfilled_loop_sizes
        rep["added_vertices"] = int(added)
    if options.remove_ears and geometry.mesh_edges(F).boundary.size:
        V, F, kept = geometry.remove_boundary_ears(V, F)
        removed = np.setdiff1d(np.arange(src.size), kept)
        rep["removed_ear_vertex_ids"] = sorted(int(i) for i in src[removed] if i >= 0)
        src = src[kept]
    return V, F, src


def prepare_mesh_arrays(
    V: Any, F: Any, options: PrepareOptions | None = None, *, landmark_ids: Any = None
) -> PreparedMesh:
    """Prepare a raw mesh for the disk pipelines and say exactly what changed.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, 3) array_like of int
    options : PrepareOptions, optional (default ``PrepareOptions()``)
    landmark_ids : (k,) array_like of int, optional
        Input vertex ids of face landmarks: where the face cut (the last
        step, for a mesh still not a disk) places the face.

    Returns
    -------
    PreparedMesh
        Its ``report`` holds ``input`` and ``output`` counts, ``unchanged``,
        ``vertex_order_kept`` (no input vertex removed), the element
        clean-up counts (``degenerate_faces``, ``duplicate_faces``,
        ``unreferenced_vertices``), ``decimation`` (None, or what
        :func:`~conformorph.pipelines.preparation.decimation.decimate_to_budget`
        reports when the cleaned mesh had more vertices than
        ``options.vertex_budget``), ``nonmanifold_faces_dropped``,
        ``split_vertices``, ``reoriented_faces`` (flipped to agree with their
        component's majority), ``dropped_components`` (vertex and face counts,
        largest first), ``filled_holes`` and ``unfilled_holes`` (loop
        sizes), ``added_vertices``, ``removed_ear_vertex_ids`` (input ids),
        ``face_cut`` (only when the face was cut out of a mesh still not a
        disk: see :func:`conformorph.pipelines.preparation.face_cut.cut_face`),
        ``removed_vertices`` (input vertices absent from the output), and
        ``disk`` / ``problem``: whether the result is a disk the pipelines
        take, and if not, the validation's message.

    Raises
    ------
    MeshError
        Faults no preparation repairs: not triangles, face indices out of
        range, nothing left after the clean-up.

    Notes
    -----
    The steps run in the order of :mod:`conformorph.pipelines.preparation`. A step that
    finds nothing to do changes nothing, so a clean disk comes out as it
    went in (``unchanged`` True, ``vertex_map`` the identity).
    """
    options = PrepareOptions() if options is None else options
    c = geometry.clean_mesh_elements(V, F)
    n_in, m_in = int(np.asarray(V).shape[0]), int(np.asarray(F).shape[0])
    rep: dict[str, Any] = {
        "input": {"vertices": n_in, "faces": m_in},
        "degenerate_faces": c.degenerate_faces,
        "duplicate_faces": c.duplicate_faces,
        "unreferenced_vertices": c.unreferenced_vertices,
    }
    V1, F1, src, merged = working_resolution_step(
        c.V, c.F, c.kept, n_in, options.vertex_budget, rep
    )
    if merged is not None and landmark_ids is not None:  # the survivors they merged into
        lm_ids = merged[np.asarray(landmark_ids, dtype=np.int64)]
        landmark_ids = lm_ids[lm_ids >= 0]
    V2, F2, src = _topology_steps(V1, F1, src, options, rep)
    try:
        V2, F2, src = _surface_steps(V2, F2, src, options, rep)
    except MeshError as exc:  # e.g. boundary loops touching: reported, the mesh left as is
        rep["problem"] = str(exc)
    reason = face_cut_reason(V2, F2, options.min_disk_roundness) if options.cut_face else None
    if reason is not None:
        V2, F2, src = cut_face(V2, F2, src, landmark_ids, rep, reason)
        if "problem" not in rep["face_cut"]:
            rep.pop("problem", None)
    rep["output"] = {"vertices": int(V2.shape[0]), "faces": int(F2.shape[0])}
    used = np.zeros(n_in, dtype=bool)
    used[src[src >= 0]] = True
    rep["removed_vertices"] = int((~used).sum())
    rep["vertex_order_kept"] = bool(
        src.size >= n_in and np.array_equal(src[:n_in], np.arange(n_in))
    )
    rep["unchanged"] = bool(
        rep["vertex_order_kept"] and src.size == n_in and np.array_equal(F2, np.asarray(F))
    )
    if "problem" not in rep:
        try:
            geometry.validate_mesh(V2, F2, require_disk=True)
            rep["problem"] = None
        except MeshError as exc:
            rep["problem"] = str(exc)
    rep["disk"] = rep["problem"] is None
    return PreparedMesh(V2, F2, src, rep, merged)


def preparation_summary(report: dict[str, Any]) -> dict[str, Any]:
    """The non-zero entries of a preparation report: what ``auto`` would change.

    Parameters
    ----------
    report : dict
        :attr:`PreparedMesh.report`.

    Returns
    -------
    dict
        Only the steps that did something (counts, loop sizes, component
        sizes; at most 20 ear ids), for upload reports and messages.
    """
    keys = (
        "degenerate_faces",
        "duplicate_faces",
        "unreferenced_vertices",
        "nonmanifold_faces_dropped",
        "split_vertices",
        "reoriented_faces",
        "dropped_components",
        "filled_holes",
        "unfilled_holes",
        "added_vertices",
        "face_cut",
    )
    out = {k: report[k] for k in keys if report.get(k)}
    dec = report.get("decimation")
    if dec:
        out["decimated"] = {k: dec[k] for k in ("vertex_budget", "input", "output")}
    ears = report.get("removed_ear_vertex_ids") or []
    if ears:
        out["removed_ear_vertices"] = len(ears)
        out["removed_ear_vertex_ids"] = ears[:20]
    return out
