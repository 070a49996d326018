"""The 2D strain-field morph (Yan, Hu and Martin 2004) as the paper's steps, one module each.

* :mod:`~conformorph.pipelines.morph2d.inputs`: reading and pairing the inputs (shapes,
  anchors, dissection paths, texture);
* :mod:`~conformorph.pipelines.morph2d.correspondence`: anchors found automatically when
  none or only a few are given, holes paired, the working resolution;
* :mod:`~conformorph.pipelines.morph2d.compatible_meshes`: compatible meshes (given,
  constructed, dissected into patches, with seeded holes);
* :mod:`~conformorph.pipelines.morph2d.rigid_motion`: the reference points A, B of the
  rigid-motion removal (steps 1 and 5);
* :mod:`~conformorph.pipelines.morph2d.strain_interpolation`: strain interpolation (eq. 2 / eq. 3)
  and the frame solve (eq. 9–12) by :func:`conformorph.geometry.strain_morph.strain_morph`,
  with the fallbacks between schemes; :mod:`~conformorph.pipelines.morph2d.strain_metrics`
  judges each attempt;
* :mod:`~conformorph.pipelines.morph2d.pacing`: the path re-timed to move evenly;
* shapes of several parts: :mod:`~conformorph.pipelines.morph2d.part_matching` (parts
  paired), :mod:`~conformorph.pipelines.morph2d.part_morph` (each pair morphed, the rest
  grown or shrunk, crossings checked and resolved),
  :mod:`~conformorph.pipelines.morph2d.run_parts` (the run and its ``metrics.json``);
  :mod:`~conformorph.pipelines.morph2d.frame_parts`: every frame as parts of rings
  (:class:`FrameParts`), what the writers read;
* :mod:`~conformorph.pipelines.morph2d.outputs`: ``animation.glb``, ``frames/NNN.glb``,
  ``strip.svg``, ``animation.svg``, ``frames.json``, ``metrics.json``;
* :mod:`~conformorph.pipelines.morph2d.metrics`: the baselines and ``metrics.json``'s content;
* :mod:`~conformorph.pipelines.morph2d.run`: :func:`run_morph2d`, the steps in order;
* :mod:`~conformorph.pipelines.morph2d.options`: :class:`Morph2DOptions`.
"""

from conformorph.pipelines.morph2d.compatible_meshes import (
    ANCHOR_PAIRING_RTOL,
    SEED_PAIRINGS_TRIED,
    CompatibleMeshes,
    compatible_meshes,
    morph2d_meshes,
)
from conformorph.pipelines.morph2d.correspondence import (
    DEFAULT_POINT_BUDGET,
    Correspondence,
    corresponding_anchors,
    working_resolution,
)
from conformorph.pipelines.morph2d.errors import MorphNotConvergedError, TextureError, tag_field
from conformorph.pipelines.morph2d.frame_crossings import crossing_frames
from conformorph.pipelines.morph2d.frame_parts import FrameParts, frame_parts
from conformorph.pipelines.morph2d.inputs import (
    Morph2DInputs,
    read_morph2d_inputs,
    read_texture_png,
)
from conformorph.pipelines.morph2d.metrics import (
    baseline_metrics,
    morph2d_metrics,
    not_converged_reason,
)
from conformorph.pipelines.morph2d.options import (
    ANCHORLESS_FALLBACKS,
    DEFAULT_INTERP,
    FALLBACKS,
    Morph2DOptions,
    ProgressFn,
    check_morph2d_options,
)
from conformorph.pipelines.morph2d.outputs import (
    FPS,
    STRIP_FRAMES,
    frame_rings,
    strip_svg,
    texture_uv,
    write_metrics_json,
    write_morph2d_outputs,
    write_web_outputs,
)
from conformorph.pipelines.morph2d.pacing import PACE_SAMPLES_PER_FRAME, even_paced_frames
from conformorph.pipelines.morph2d.part_matching import PartMatching, match_parts
from conformorph.pipelines.morph2d.part_morph import PartsMorph, morph_parts
from conformorph.pipelines.morph2d.rigid_motion import reference_points
from conformorph.pipelines.morph2d.run import STAGES, run_morph2d
from conformorph.pipelines.morph2d.strain_interpolation import (
    STRAIN_ITERATIONS_PER_STEP,
    StrainFrames,
    iteration_budget,
    scale_separated_strain_morph,
    solver_steps,
    strain_frames,
)
from conformorph.pipelines.morph2d.strain_metrics import TARGET_MATCH_RTOL, strain_metrics

__all__ = [
    "ANCHOR_PAIRING_RTOL",
    "DEFAULT_INTERP",
    "DEFAULT_POINT_BUDGET",
    "ANCHORLESS_FALLBACKS",
    "FALLBACKS",
    "FPS",
    "PACE_SAMPLES_PER_FRAME",
    "SEED_PAIRINGS_TRIED",
    "STAGES",
    "STRAIN_ITERATIONS_PER_STEP",
    "STRIP_FRAMES",
    "TARGET_MATCH_RTOL",
    "CompatibleMeshes",
    "FrameParts",
    "PartMatching",
    "PartsMorph",
    "Correspondence",
    "Morph2DInputs",
    "Morph2DOptions",
    "MorphNotConvergedError",
    "ProgressFn",
    "StrainFrames",
    "TextureError",
    "baseline_metrics",
    "check_morph2d_options",
    "compatible_meshes",
    "corresponding_anchors",
    "crossing_frames",
    "frame_parts",
    "match_parts",
    "morph_parts",
    "even_paced_frames",
    "frame_rings",
    "iteration_budget",
    "morph2d_meshes",
    "morph2d_metrics",
    "not_converged_reason",
    "read_morph2d_inputs",
    "read_texture_png",
    "reference_points",
    "run_morph2d",
    "scale_separated_strain_morph",
    "solver_steps",
    "strain_frames",
    "strain_metrics",
    "strip_svg",
    "tag_field",
    "texture_uv",
    "write_metrics_json",
    "write_morph2d_outputs",
    "working_resolution",
    "write_web_outputs",
]
