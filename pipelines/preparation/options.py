"""Options of the preparation step (:func:`conformorph.pipelines.preparation.prepare_mesh_arrays`)."""

from __future__ import annotations

from dataclasses import dataclass

from conformorph.pipelines import job_fields

#: values of ``--prepare`` and of the jobs' ``"prepare"`` field
PREPARE_MODES = job_fields.PREPARE_CHOICES

#: default working resolution (vertices) of ``--prepare auto``: above it the mesh is
#: decimated. Chosen from ``benchmarks/bench_scan_scale.py --budgets`` (the figures and
#: the reason are in :mod:`conformorph.pipelines.preparation.decimation`): the frames'
#: error is flat from 25,000 up and doubles (or the registration folds) at 15,000;
#: 50,000 keeps a 2x margin above that. Two 50k-vertex faces morph in about 15 s with
#: default settings on a 2-core machine, within the 40 s and 60 s targets of the 270k
#: and 1M pairs once their reading and decimation are added (defined, for every entry
#: point, in :mod:`conformorph.job_fields`)
DEFAULT_VERTEX_BUDGET = job_fields.VERTEX_BUDGET_DEFAULT

#: smallest budget accepted (the disk map and registration need a few hundred vertices)
MIN_VERTEX_BUDGET = job_fields.MIN_VERTEX_BUDGET


@dataclass(frozen=True)
class PrepareOptions:
    """What the preparation step may do (all on for ``--prepare auto``).

    Attributes
    ----------
    keep_largest_component : bool
        Drop every component but the largest (by vertex count). Default True.
    repair_nonmanifold : bool
        Drop the faces beyond two on an edge and split pinched vertices
        (:func:`geometry.split_nonmanifold`), then orient every component's
        faces consistently (:func:`conformorph.geometry.consistent_orientation`). Default True.
    fill_holes : bool
        Fill inner boundary loops with faired patches
        (:func:`geometry.fill_holes_faired`). Default True.
    max_hole_fraction : float
        Fill a loop only when its length is at most this fraction of the
        outer loop's. Default 0.5.
    remove_ears : bool
        Remove boundary ears (vertices in a single triangle). Default True.
    vertex_budget : int or None
        The working resolution: a cleaned mesh with more vertices is decimated to
        about this many by quadric edge collapse
        (:mod:`conformorph.pipelines.preparation.decimation`); every output is then
        at that resolution. None never decimates. Default
        :data:`DEFAULT_VERTEX_BUDGET`.
    cut_face : bool
        When the mesh is still not a disk after the other steps (a closed
        head, a scan with a neck and a back, several large boundary loops),
        cut the face out as a disk (:func:`conformorph.geometry.face_region`,
        placed by the landmarks when known). Default True.
    min_disk_roundness : float
        With ``cut_face``, a mesh whose boundary loops' total length L and
        area A give ``L² / (4π A)`` below this is cut too, its loops filled
        first: they are the rims of a closed surface's openings (a head open
        at the neck, about 0.03), not a face's outline (0.63 and more on the
        shared faces). Default 0.25 (a spherical cap of 120°).
    """

    keep_largest_component: bool = True
    repair_nonmanifold: bool = True
    fill_holes: bool = True
    max_hole_fraction: float = 0.5
    remove_ears: bool = True
    vertex_budget: int | None = DEFAULT_VERTEX_BUDGET
    cut_face: bool = True
    min_disk_roundness: float = 0.25

    def __post_init__(self) -> None:
        if not 0.0 < float(self.max_hole_fraction) <= 1.0:
            raise ValueError(f"max_hole_fraction must be in (0, 1], got {self.max_hole_fraction}")
        if self.vertex_budget is not None and (
            isinstance(self.vertex_budget, bool) or int(self.vertex_budget) < MIN_VERTEX_BUDGET
        ):
            raise ValueError(
                f"vertex_budget must be an integer of at least {MIN_VERTEX_BUDGET} or None, "
                f"got {self.vertex_budget!r}"
            )
        if not 0.0 <= float(self.min_disk_roundness) < 1.0:
            raise ValueError(f"min_disk_roundness must be in [0, 1), got {self.min_disk_roundness}")
