"""The conformal core as named steps: repaired disk mesh, disk map, (H, λ), reconstruction.

What ``conformorph map`` / ``reconstruct`` / ``demo`` and the API's
conformal-map and reconstruction jobs run, in the paper's order
(Yueh et al., §2.1 and Algorithm 1):

1. :func:`~conformorph.pipelines.conformal.disk_mesh.repair_disk_mesh` — the input as
   read and the repaired disk the numerics run on (``fill_holes``,
   ``remove_ears``), with the bookkeeping of vertex rows;
2. :func:`~conformorph.pipelines.conformal.disk_map.disk_map_step` — the disk conformal
   map, and :func:`~conformorph.pipelines.conformal.disk_map.map_quality_report` beside it;
3. :func:`~conformorph.pipelines.conformal.curvature.curvature_step` — mean curvature H
   and conformal factor λ;
4. :func:`~conformorph.pipelines.conformal.reconstruction.reconstruction_step` — the
   surface from (H, λ) and its boundary, with its relative errors.

Each step takes a :class:`~conformorph.pipelines.conformal.disk_mesh.DiskMesh`, arrays
and a small frozen options object, and gives arrays on the repaired mesh's
rows together with the same values on the input's rows.
"""

from conformorph.pipelines.conformal.curvature import (
    CurvatureOptions,
    CurvatureResult,
    curvature_step,
)
from conformorph.pipelines.conformal.disk_map import (
    DiskMapOptions,
    DiskMapResult,
    disk_map_step,
    map_histogram_pngs,
    map_quality_report,
)
from conformorph.pipelines.conformal.disk_mesh import (
    DiskMesh,
    RepairOptions,
    load_disk_mesh,
    prepared_disk_mesh,
    repair_disk_mesh,
    require_interior_vertex,
)
from conformorph.pipelines.conformal.reconstruction import (
    ReconstructionResult,
    ReconstructionStepOptions,
    reconstruction_step,
)

__all__ = [
    "CurvatureOptions",
    "CurvatureResult",
    "DiskMapOptions",
    "DiskMapResult",
    "DiskMesh",
    "ReconstructionResult",
    "ReconstructionStepOptions",
    "RepairOptions",
    "curvature_step",
    "disk_map_step",
    "load_disk_mesh",
    "prepared_disk_mesh",
    "map_histogram_pngs",
    "map_quality_report",
    "reconstruction_step",
    "repair_disk_mesh",
    "require_interior_vertex",
]
