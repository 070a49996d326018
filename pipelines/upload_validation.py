"""Upload validation: an uploaded mesh or 2D shape read and checked exactly as the CLI reads it.

The answer is a JSON-ready ``{"ok": True, "report": {...}}`` or ``{"ok":
False, "error": {"type", "message", "field", "status"}}``. Every message is
written for the person who uploaded the file: what is wrong and where, never
an exception's internal text, a storage name or an array descriptor.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from conformorph.geometry._typing import FloatArray, IntArray
from conformorph.geometry.mesh_edges import mesh_edges
from conformorph.geometry.mesh_errors import BoundaryEarError, MeshError, NotDiskError
from conformorph.geometry.shape_rings import ShapeError, validate_rings
from conformorph.geometry.validate_mesh import MeshReport, validate_mesh
from conformorph.pipelines.conformal.disk_mesh import repair_disk_mesh
from conformorph.pipelines.jsonable import jsonable
from conformorph.pipelines.mesh_io import MeshLimits, read_mesh
from conformorph.pipelines.mesh_texture_coordinates import has_texture_coordinates
from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET
from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS, parse_shape_parts

log = logging.getLogger(__name__)

#: what shape messages call the uploaded file
UPLOADED_SHAPE = "the uploaded shape"


def _refusal(error_type: str, message: str, status: int = 422) -> dict[str, Any]:
    return {
        "ok": False,
        "error": {"type": error_type, "message": message[:2000], "field": "file", "status": status},
    }


def repairable_mesh(
    V: FloatArray, F: IntArray, error: Exception
) -> tuple[MeshReport, dict[str, Any]]:
    """A mesh that is a disk once its holes are filled and/or its ears removed.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    error : Exception
        The error of the strict validation (``require_disk=True``).

    Returns
    -------
    report : MeshReport
        The lenient report.
    repairs : dict
        ``{"fill_holes": holes, "remove_ears": [ear vertex ids]}`` (only
        those needed), exactly the repairs of ``conformorph morph
        --fill-holes --remove-ears``.

    Raises
    ------
    Exception
        ``error`` again when those repairs do not give a valid disk (a
        closed surface, handles, several components, …).
    """
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


def raw_mesh_report(V: FloatArray, F: IntArray) -> MeshReport:
    """The counts of a mesh as uploaded, for one the strict validation refuses but the
    preparation step repairs (fragments, duplicate faces, …).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Face indices in range (the preparation step checked them).

    Returns
    -------
    MeshReport
        Vertex, face and edge counts, Euler characteristic, components (of the
        faces' vertices) and the boundary loops where they can be traced (none
        listed where boundary loops touch).
    """
    from conformorph.geometry.boundary_loop import boundary_loops
    from conformorph.geometry.largest_component import largest_component

    E = mesh_edges(F)
    try:
        loops = boundary_loops(F, E)
    except MeshError:
        loops = []
    sel = largest_component(F)
    return MeshReport(
        n_vertices=int(V.shape[0]),
        n_faces=int(F.shape[0]),
        n_edges=int(E.edges.shape[0]),
        boundary_loops=len(loops),
        boundary_loop_sizes=[int(lp.size) for lp in loops],
        euler_characteristic=int(V.shape[0] - E.edges.shape[0] + F.shape[0]),
        components=1 + len(sel.dropped_vertex_counts),
        boundary_ears=[],
        edges=E,
    )


def preparable_mesh(V: FloatArray, F: IntArray, error: Exception) -> dict[str, Any]:
    """What ``"prepare": "auto"`` changes in a mesh the strict validation refused.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    error : Exception
        The strict validation's error.

    Returns
    -------
    dict
        :func:`conformorph.pipelines.preparation.preparation_summary` of the preparation
        (counts, loop and component sizes, at most 20 ear ids), plus
        ``vertices`` and ``faces`` of the prepared mesh.

    Raises
    ------
    Exception
        ``error`` again when the prepared mesh is still not a disk (a closed
        surface, handles, …) or the mesh cannot be prepared at all.
    """
    from conformorph.pipelines.preparation import preparation_summary, prepare_mesh_arrays

    try:
        prepared = prepare_mesh_arrays(V, F)
    except MeshError:
        raise error from None
    if not prepared.report["disk"]:
        raise error
    out = preparation_summary(prepared.report)
    out["vertices"] = prepared.report["output"]["vertices"]
    out["faces"] = prepared.report["output"]["faces"]
    return out


def mesh_report(report: MeshReport, F: IntArray) -> dict[str, Any]:
    """The public report of a valid mesh: counts and vertex ids a person can read.

    Parameters
    ----------
    report : MeshReport
        What validation found.
    F : (m, 3) int64
        The faces validated.

    Returns
    -------
    dict
        :meth:`MeshReport.to_dict` (counts, loop sizes, ear ids) plus
        ``boundary_vertices`` and ``interior_vertices``: vertices on and off
        the boundary (a vertex is on it when an edge used by one face ends
        there). No arrays beyond short id lists.
    """
    edges = report.edges if report.edges is not None else mesh_edges(F)
    on_boundary = int(np.unique(edges.boundary).size)
    rep: dict[str, Any] = jsonable(report.to_dict())
    rep["boundary_vertices"] = on_boundary
    rep["interior_vertices"] = int(report.n_vertices) - on_boundary
    return rep


def validate_mesh_upload(data: bytes, file_type: str, limits: MeshLimits) -> dict[str, Any]:
    """Read and validate an uploaded mesh exactly as the CLI does.

    Parameters
    ----------
    data : bytes
        The uploaded file. It is read from these bytes only, so it can refer
        to nothing outside itself (a glTF's buffers must be embedded).
    file_type : str
        One of :data:`conformorph.pipelines.mesh_io.MESH_TYPES`.
    limits : MeshLimits
        Most vertices and faces, checked against the file's declared counts
        before it is parsed and against what was read.

    Returns
    -------
    dict
        ``{"ok": True, "report": {...}}`` (see :func:`mesh_report`, plus
        ``repairs_needed`` when the mesh is a disk only after the repairs of
        :func:`repairable_mesh`, and ``preparation_needed`` when it is a disk
        after the preparation step, :func:`preparable_mesh`, and
        ``working_resolution`` when it has more vertices than the preparation's default
        vertex budget) or ``{"ok": False, "error": {"type",
        "message", "field", "status"}}`` (status 422).
    """
    try:
        V, F = read_mesh(data, file_type, limits=limits)
        limits.check(f"{file_type.upper()} file", V.shape[0], F.shape[0])
        repairs: dict[str, Any] = {}
        preparation: dict[str, Any] = {}
        try:
            report = validate_mesh(V, F, require_disk=True)
        except MeshError as exc:
            preparation = preparable_mesh(V, F, exc)
            try:
                report, repairs = repairable_mesh(V, F, exc)
            except MeshError:
                report = raw_mesh_report(V, F)
    except MeshError as exc:
        return _refusal(str(getattr(exc, "code", "invalid_mesh")), str(exc))
    except Exception:  # noqa: BLE001 - a bug or a resource failure: logged, not shown
        log.exception("validating an uploaded %s mesh failed", file_type)
        return _refusal(
            "unreadable_mesh",
            f"the file cannot be read as a {file_type.upper()} mesh; check that it is a "
            "complete, valid file of that type",
        )
    rep = mesh_report(report, F)
    rep["texture_coordinates"] = has_texture_coordinates(data, file_type)
    if repairs:
        rep["repairs_needed"] = repairs
    if preparation:
        rep["preparation_needed"] = preparation
    if V.shape[0] > DEFAULT_VERTEX_BUDGET:
        rep["working_resolution"] = {
            "vertex_budget": DEFAULT_VERTEX_BUDGET,
            "message": f"jobs with prepare 'auto' decimate this mesh to about "
            f"{DEFAULT_VERTEX_BUDGET} vertices (quadric edge collapse) and their outputs are "
            "at that resolution; set vertex_budget (0: never) to change it",
        }
    return {"ok": True, "report": rep}


def validate_shape_upload(
    data: bytes, suffix: str, *, max_points: int | None = None
) -> dict[str, Any]:
    """Read and validate an uploaded 2D shape (JSON rings or SVG) like ``conformorph morph2d``.

    Parameters
    ----------
    data : bytes
        The uploaded file.
    suffix : str
        ``".json"`` or ``".svg"``.
    max_points : int, optional
        Most points (default ``conformorph.pipelines.shape_io.DEFAULT_MAX_POINTS``).

    Returns
    -------
    dict
        ``{"ok": True, "report": {...}}`` or ``{"ok": False, "error": {...}}``
        (``shape_too_large`` beyond ``max_points``). The report holds
        ``rings``, ``points``, ``fixes`` and ``bbox`` ``[xmin, ymin, xmax,
        ymax]`` (y up), which the API checks a morph's holes and anchors
        against before enqueueing. Messages call the file "the uploaded
        shape".
    """
    cap = DEFAULT_MAX_POINTS if max_points is None else int(max_points)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        return _refusal(
            "unreadable_shape",
            f"{UPLOADED_SHAPE}: not UTF-8 text ({exc.reason} at byte {exc.start})",
        )
    try:
        doc = parse_shape_parts(text, suffix, UPLOADED_SHAPE, max_points=cap)
        shapes = [validate_rings(rings) for rings in doc.parts]
    except (ShapeError, ValueError) as exc:
        return _refusal(str(getattr(exc, "code", None) or "invalid_shape"), str(exc))
    except Exception:  # noqa: BLE001 - a bug or a resource failure: logged, not shown
        log.exception("validating an uploaded shape failed")
        return _refusal(
            "unreadable_shape",
            f"the file cannot be read as a {suffix.lstrip('.').upper()} shape; check that it "
            "is a complete, valid file of that type",
        )
    rings = [np.asarray(r) for shape in shapes for r in shape.rings]
    outers = np.vstack([shape.outer for shape in shapes])
    lo, hi = outers.min(axis=0), outers.max(axis=0)
    return {
        "ok": True,
        "report": {
            "rings": len(rings),
            "parts": len(shapes),
            "points": int(sum(r.shape[0] for r in rings)),
            "fixes": [f for shape in shapes for f in shape.fixes] + list(doc.notes),
            "bbox": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])],
        },
    }
