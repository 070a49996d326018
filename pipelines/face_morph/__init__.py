"""The face morphing pipeline (sections 3–5 of the face paper), one module per step.

Stages, each a function whose inputs and outputs are plain dicts of numpy
arrays (saved with :func:`save_stage` / :func:`load_stage` as ``.npz``, so
that a Celery worker can run them as separate tasks; JSON diagnostics ride in
the ``"meta_json"`` entry):

1. :mod:`.key_preparation` — :func:`prepare_mesh` (one per input mesh,
   independent): validate, normalise by diameter, disk conformal map, H, Hn,
   λ, landmarks on the surface and on the disk; the key repairs first.
2. :func:`register_meshes` (:mod:`.registration`): :mod:`.rigid_alignment`
   onto key 0; per consecutive pair :mod:`.disk_registration` (MT, DMT with
   its fold guard) and :mod:`.dense_refinement` (extra DMT correspondences);
   :mod:`.resampling` of every key onto the consistent mesh through the
   composite maps, with their fold check; E_D and E (eqs. 2, 3).
3. :func:`compute_frames` (:mod:`.frames`, :mod:`.homotopy`): the spline
   homotopy and reconstruction of every frame, the rigid part interpolated
   apart; :mod:`.metrics` at the keys and against true surfaces.
4. :func:`export_outputs` (:mod:`.export`): ``animation.glb``, optional
   ``frames/NNN.glb``.

:func:`run_face_morph` (:mod:`.run`) runs them in order; the options of each
step are frozen dataclasses in :mod:`.options`.
"""

from conformorph.pipelines.face_morph.dense_refinement import landmark_motion
from conformorph.pipelines.face_morph.export import export_outputs
from conformorph.pipelines.face_morph.frames import compute_frames
from conformorph.pipelines.face_morph.homotopy import (
    check_frame_times,
    frame_times_for,
    morph_variant_frames,
    placed_keys,
)
from conformorph.pipelines.face_morph.key_preparation import (
    prepare_key_file,
    prepare_mesh,
    repair_key_mesh,
)
from conformorph.pipelines.face_morph.metrics import (
    DMT_FALLBACKS,
    bijectivity_summary,
    morph_metrics,
)
from conformorph.pipelines.face_morph.options import (
    CURVATURE_HOMOTOPIES,
    DEFAULT_CURVATURE,
    DEFAULT_LANDMARK_FIT,
    DEFAULT_LANDMARK_FIT_CHOICE,
    DEFAULT_NORMALS,
    LANDMARK_FIT_CHOICES,
    LANDMARK_FITS,
    METHODS,
    NICP_AUTO_MAX_NODES,
    NICP_CORRESPONDENCES,
    NICP_TOL,
    ExportOptions,
    FaceMorphOptions,
    FrameOptions,
    InputMismatchError,
    KeyOptions,
    RegistrationOptions,
    resolve_landmark_fit,
)
from conformorph.pipelines.face_morph.registration import register_meshes
from conformorph.pipelines.face_morph.run import run_face_morph
from conformorph.pipelines.face_morph.stage_arrays import load_stage, save_stage
from conformorph.pipelines.face_morph.textures import (
    MAX_TEXTURE_SIZE,
    read_texture,
    read_vertex_colors,
)
from conformorph.pipelines.face_morph.units import (
    DEFAULT_UNITS,
    UNIT_CHOICES,
    UnitsMismatchError,
    keys_to_one_scale,
)

__all__ = [
    "CURVATURE_HOMOTOPIES",
    "DEFAULT_CURVATURE",
    "DEFAULT_LANDMARK_FIT",
    "DEFAULT_LANDMARK_FIT_CHOICE",
    "DEFAULT_NORMALS",
    "DEFAULT_UNITS",
    "UNIT_CHOICES",
    "UnitsMismatchError",
    "keys_to_one_scale",
    "LANDMARK_FIT_CHOICES",
    "LANDMARK_FITS",
    "DMT_FALLBACKS",
    "MAX_TEXTURE_SIZE",
    "METHODS",
    "NICP_AUTO_MAX_NODES",
    "NICP_CORRESPONDENCES",
    "NICP_TOL",
    "ExportOptions",
    "FaceMorphOptions",
    "FrameOptions",
    "InputMismatchError",
    "KeyOptions",
    "RegistrationOptions",
    "resolve_landmark_fit",
    "bijectivity_summary",
    "check_frame_times",
    "compute_frames",
    "export_outputs",
    "frame_times_for",
    "landmark_motion",
    "load_stage",
    "morph_metrics",
    "morph_variant_frames",
    "placed_keys",
    "prepare_key_file",
    "prepare_mesh",
    "read_texture",
    "read_vertex_colors",
    "register_meshes",
    "repair_key_mesh",
    "run_face_morph",
    "save_stage",
]
