"""Step 2 of :mod:`conformorph.pipelines.conformal`: the disk conformal map and its quality report."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from conformorph import geometry
from conformorph.geometry.disk_conformal_map import DiskMapInfo, FoldPolicy
from conformorph.pipelines.conformal.disk_mesh import DiskMesh
from conformorph.pipelines.histogram_png import histogram_png
from conformorph.pipelines.jsonable import jsonable


@dataclass(frozen=True)
class DiskMapOptions:
    """Options of :func:`disk_map_step`.

    Attributes
    ----------
    method : {"fast", "qiem"}
        Of :func:`conformorph.geometry.disk_conformal_map`. Default ``"fast"``.
    fold_policy : {"repair", "report", "raise"}
        Of :func:`conformorph.geometry.disk_conformal_map`. Default ``"repair"``.
    refine_angles : bool
        Finish the fast map with the angle refinement. Default True.
    center_vertex : int, optional
        Input vertex id sent to 0 (the Möbius normalisation). Default None.
    angle_vertex : int, optional
        Input boundary vertex id sent to angle 0. Default None.
    """

    method: Literal["fast", "qiem"] = "fast"
    fold_policy: FoldPolicy = "repair"
    refine_angles: bool = True
    center_vertex: int | None = None
    angle_vertex: int | None = None


@dataclass(frozen=True)
class DiskMapResult:
    """What :func:`disk_map_step` gives.

    Attributes
    ----------
    uv : (n2, 2) float64
        The map of the repaired mesh (rows of ``mesh.V``).
    uv_input : (n, 2) float64
        The same on the input's rows; removed ears on the unit circle.
    kept : (n,) bool
        Input vertices the numerics ran on (False: a removed ear).
    info : DiskMapInfo
    """

    uv: np.ndarray
    uv_input: np.ndarray
    kept: np.ndarray
    info: DiskMapInfo


def disk_map_step(mesh: DiskMesh, options: DiskMapOptions) -> DiskMapResult:
    """Disk conformal map of the repaired mesh (:func:`conformorph.geometry.disk_conformal_map`).

    Parameters
    ----------
    mesh : DiskMesh
    options : DiskMapOptions
        ``center_vertex``/``angle_vertex`` are input vertex ids (ValueError
        for a removed ear).

    Returns
    -------
    DiskMapResult
    """
    moved = {}
    for name in ("center_vertex", "angle_vertex"):
        index = getattr(options, name)
        if index is not None:
            moved[name] = mesh.vertex(index)
    uv, info = geometry.disk_conformal_map(
        mesh.V,
        mesh.F,
        method=options.method,
        center_vertex=moved.get("center_vertex"),
        angle_vertex=moved.get("angle_vertex"),
        fold_policy=options.fold_policy,
        refine_angles=options.refine_angles,
    )
    return DiskMapResult(uv, mesh.input_uv(uv), mesh.kept_mask(), info)


def map_quality_report(mesh: DiskMesh, result: DiskMapResult, method: str) -> dict[str, Any]:
    """The JSON report of a map (``quality.json``): sizes, repairs, the measures of
    :func:`conformorph.geometry.map_quality` (angle distortion, Beltrami coefficient, flips, boundary,
    histograms) and the map's diagnostics.

    Parameters
    ----------
    mesh : DiskMesh
    result : DiskMapResult
    method : str
        The map method, reported.

    Returns
    -------
    dict
        JSON-ready.
    """
    V, F = mesh.V, mesh.F
    b = np.asarray(geometry.boundary_loop(F), dtype=np.int64)
    measures: dict[str, Any] = jsonable(geometry.map_quality(V, F, result.uv, b).to_dict())
    return {
        "method": method,
        "vertices": int(mesh.V_in.shape[0]),
        "faces": int(mesh.F_in.shape[0]),
        "mapped_vertices": int(V.shape[0]),
        "mapped_faces": int(F.shape[0]),
        **mesh.done,
        **measures,
        "info": jsonable(result.info.to_dict()),
    }


#: the report's histograms and the PNG files drawn from them
HISTOGRAM_FILES = (
    ("angle_histogram", "angle_distortion_histogram.png", "angle distortion (degrees)"),
    ("beltrami_histogram", "beltrami_histogram.png", "Beltrami coefficient |mu|"),
)


def map_histogram_pngs(report: dict[str, Any]) -> list[tuple[str, bytes]]:
    """The histograms of a :func:`map_quality_report` as PNG files: (file name, bytes)."""
    out = []
    for key, name, label in HISTOGRAM_FILES:
        hist = report.get(key)
        if isinstance(hist, dict) and "counts" in hist and "edges" in hist:
            out.append((name, histogram_png(hist["counts"], hist["edges"], label)))
    return out
