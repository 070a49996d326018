"""Scan preparation: one step that turns a raw scan into the clean disk the pipelines need.

:func:`prepare_mesh_arrays` runs, in order: element clean-up (degenerate and
duplicate faces, unreferenced vertices; :func:`geometry.clean_mesh_elements`),
manifold repair (:func:`geometry.split_nonmanifold`) and consistent orientation
(:func:`conformorph.geometry.consistent_orientation`), the largest component
(:func:`conformorph.geometry.largest_component`), faired hole filling
(:func:`geometry.fill_holes_faired`) and boundary-ear removal
(:func:`geometry.remove_boundary_ears`), and, for a mesh still not a disk (a closed
head, a scan with a neck and a back, several large boundary loops, one loop too short
for its area), the face cut out as a disk
(:func:`conformorph.pipelines.preparation.face_cut.cut_face`, placed by the landmarks
when known), each under :class:`PrepareOptions`, and reports what each did with the
map from output vertices to input ones. Above ``PrepareOptions.vertex_budget`` a
quadric decimation to the working resolution runs right after the element clean-up
(:mod:`.decimation`).
"""

from conformorph.pipelines.preparation.options import (
    DEFAULT_VERTEX_BUDGET,
    PREPARE_MODES,
    PrepareOptions,
)
from conformorph.pipelines.preparation.prepare import (
    PreparedMesh,
    UnpreparableMeshError,
    preparation_summary,
    prepare_mesh_arrays,
)
from conformorph.pipelines.preparation.transfer import input_landmark_ids, vertex_values

__all__ = [
    "DEFAULT_VERTEX_BUDGET",
    "PREPARE_MODES",
    "PrepareOptions",
    "PreparedMesh",
    "UnpreparableMeshError",
    "input_landmark_ids",
    "preparation_summary",
    "prepare_mesh_arrays",
    "vertex_values",
]
