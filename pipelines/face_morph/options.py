"""Options of the face morph's steps: small frozen dataclasses with documented defaults.

:class:`FaceMorphOptions` groups them for :func:`conformorph.pipelines.face_morph.run.run_face_morph`;
CLI flags map onto them in :func:`conformorph.cli.cmd_morph.morph_options_from_args`, job parameters
in :func:`conformorph.worker.stages.face_morph.morph_options_from_params`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from conformorph.pipelines import job_fields
from conformorph.pipelines.face_morph.units import DEFAULT_UNITS, check_units
from conformorph.pipelines.gltf_compression import DEFAULT_COMPRESS, check_compress
from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET

Arrays = dict[str, Any]
ProgressFn = Callable[[float, str], None]

METHODS = ("dmt", "mt", "identity", "linear")
CURVATURE_HOMOTOPIES = ("vector", "scalar", "metric", "screened")
#: the default curvature homotopy, chosen by measurement (benchmarks/bench_face_tables.py)
DEFAULT_CURVATURE = "screened"
#: Dense correspondences per pair taken from the non-rigid ICP of ``refine="nicp"``
#: (halved while the DMT fit through them folds).
NICP_CORRESPONDENCES = 1000
#: Largest distance (diameters) of an ICP-deformed node to the target surface for its
#: closest point to be used as a correspondence.
NICP_TOL = 2e-3
#: Largest consistent mesh (nodes) on which ``refine="auto"`` (the default) runs the
#: non-rigid ICP; above it, the guided closest points. Measured with
#: ``benchmarks/bench_face_speed.py``: two ICT faces (7k nodes) 2.2 s end to end with
#: "nicp" (median of 5), 1.0 s with "guided"; two 68k-node faces 55 s with "nicp"
#: (registration 34 s, most of it the ICP's bi-Laplacian factorisations; the frames'
#: solves 17 s, slower on its dense correspondences), 11.7 s with "guided".
NICP_AUTO_MAX_NODES = 20_000
#: How the registration treats the landmarks: ``exact`` (the paper's DMT interpolates
#: them) or ``tolerant`` (weighted by confidence, corrected by the dense correspondence).
LANDMARK_FITS = ("exact", "tolerant")
#: What the entry points (``--landmark-fit``, the job field) also accept: ``auto`` is
#: ``tolerant`` for detected landmarks (``--landmarks auto``) and ``exact`` for a given file.
LANDMARK_FIT_CHOICES = job_fields.LANDMARK_FIT_CHOICES
#: The default landmark fit, chosen by measurement (benchmarks/bench_face_tables.py
#: --landmark-variants, Table 3 curved path, screened): with exact landmarks "tolerant"
#: is 1.02–1.18× worse than "exact" (9.0e-4, 9.1e-4, 4.6e-4, 6.5e-4 → 1.02e-3, 1.07e-3,
#: 5.2e-4, 6.6e-4 at t = 0.3, 0.5, 1.3, 1.5); with 5 landmarks it is 1.3–4.3× better,
#: with 3 mm perturbed or auto-detected ones 2.8–5.8×.
DEFAULT_LANDMARK_FIT = "exact"
#: The landmark fit the CLI and the job field default to: see :func:`resolve_landmark_fit`.
#: Detected landmarks are 2.6–3.3 mm off (issue 16); with them "tolerant" is 1.07–1.85× the
#: exact-landmark tolerant morph where "exact" is 3.7–7.4× (--landmark-variants).
DEFAULT_LANDMARK_FIT_CHOICE = job_fields.LANDMARK_FIT_DEFAULT


def resolve_landmark_fit(choice: str, detected: bool) -> str:
    """The registration's landmark fit for an entry point's choice.

    Parameters
    ----------
    choice : {"auto", "exact", "tolerant"}
        ``"auto"`` picks by where the landmarks come from; the others are kept.
    detected : bool
        The landmarks are detected (``"landmarks": "auto"``), not given by a person.

    Returns
    -------
    str
        ``"tolerant"`` for ``auto`` with detected landmarks, ``"exact"`` for ``auto``
        with given ones (the paper's DMT), else ``choice``.

    Raises
    ------
    ValueError
        ``choice`` is none of :data:`LANDMARK_FIT_CHOICES`.
    """
    if choice not in LANDMARK_FIT_CHOICES:
        raise ValueError(
            f"landmark_fit must be one of {', '.join(LANDMARK_FIT_CHOICES)}, got {choice!r}"
        )
    if choice != "auto":
        return choice
    return "tolerant" if detected else "exact"


#: Landmark noise (diameters, rms per axis) the ``tolerant`` fit assumes for a landmark of
#: confidence 1: 3 mm on a 205 mm ICT face.
LANDMARK_NOISE = 0.015


#: NORMAL morph targets by default (``--normals/--no-normals``, the job field ``normals``)
DEFAULT_NORMALS = True


class InputMismatchError(ValueError):
    """Inputs that cannot be combined (e.g. ``identity`` with different connectivity)."""

    code = "input_mismatch"


@dataclass(frozen=True)
class KeyOptions:
    """Repairs and disk map of every key mesh (:mod:`conformorph.pipelines.face_morph.key_preparation`).

    Attributes
    ----------
    fill_holes : bool
        Close every boundary loop but the outer one with a fan to its centroid
        first (:func:`geometry.fill_holes`; before ``remove_ears``): the input
        vertices keep their ids (landmarks still apply), the hole centres are
        appended and carry the mean UV and colour of their loop. Default False.
    remove_ears : bool
        Remove boundary "ear" vertices (in a single triangle) first
        (:func:`geometry.remove_boundary_ears`); landmark vertex indices are
        translated, and a landmark on a removed vertex is an error. Default False.
    disk_method : str
        Passed to :func:`conformorph.geometry.disk_conformal_map`. Default ``"fast"``.
    prepare : str
        ``"auto"``: the preparation step first
        (:func:`conformorph.pipelines.preparation.prepare_mesh_arrays`: clean-up, largest
        component, manifold repair, faired hole filling, ear removal), the
        landmark ids, UVs and colours carried over by its vertex map, its
        report in the key's ``meta["preparation"]``; ``"none"`` (default
        here; ``conformorph morph`` defaults to ``"auto"``): the mesh as read.
    vertex_budget : int or None
        With ``prepare="auto"``: the working resolution
        (:attr:`conformorph.pipelines.preparation.PrepareOptions.vertex_budget`; None never
        decimates). Default ``DEFAULT_VERTEX_BUDGET`` (50,000).
    """

    fill_holes: bool = False
    remove_ears: bool = False
    disk_method: str = "fast"
    prepare: str = "none"
    vertex_budget: int | None = DEFAULT_VERTEX_BUDGET

    def __post_init__(self) -> None:
        from conformorph.pipelines.preparation import PREPARE_MODES

        if self.prepare not in PREPARE_MODES:
            raise ValueError(
                f"prepare must be one of {', '.join(PREPARE_MODES)}, got {self.prepare!r}"
            )


@dataclass(frozen=True)
class RegistrationOptions:
    """Options of stage 2 (:func:`conformorph.pipelines.face_morph.registration.register_meshes`).

    Attributes
    ----------
    method : {"dmt", "mt", "identity", "linear"}
        Registration of the homotopy (``linear`` registers by DMT). Default ``"dmt"``.
    consistent : {"source", "landmarks"}
        Consistent mesh: the first input's own mesh (default), or the paper's
        refined landmark mesh.
    target_vertices : int, optional
        Resolution of the landmark mesh (default: first input's vertex count).
    icp_iterations : int
        ICP refinement of the rigid alignment (and of the nicp similarity). Default 10.
    baselines : bool
        Also build the MT keys (for the MT-only baseline). Default True.
    curvature_source : {"consistent", "resampled"}
        Key curvature and conformal factor computed on each key's consistent
        mesh (default), or resampled from the input's per-vertex values.
    refine : {"auto", "nicp", "guided", "static", "none"}
        Extra DMT correspondences beyond the landmarks (an extension of the
        paper, whose DMT uses the landmarks only: ``"none"``); see
        :mod:`conformorph.pipelines.face_morph.dense_refinement`. ``"auto"`` (default):
        ``"nicp"`` on consistent meshes of at most ``nicp_max_nodes`` nodes,
        ``"guided"`` on larger ones, where the ICP costs more than the rest of
        the morph (see :data:`NICP_AUTO_MAX_NODES`); the preset used is
        reported as ``meta["refine"]["used"]``. ``"nicp"``: dense
        correspondences from a non-rigid ICP of the consistent nodes onto the
        next key (measured on the ICT Table 3 sequence, curved path, screened
        homotopy, ``benchmarks/bench_nicp_variants.py``: DMT/identity error
        0.98, 1.01, 1.18, 1.21 at t = 0.3, 0.5, 1.3, 1.5 against 1.15, 1.28,
        2.07, 1.78 for "guided"; two ICT faces end to end 2.2 s, against 1.0 s
        with "guided", ``benchmarks/bench_face_speed.py``, medians).
        ``"guided"``: one round of closest points sought from where the
        landmarks' interpolated 3D motion predicts each sample (tolerance
        5e-3 diameters); ``"static"``: one round of plain closest points
        (tolerance 3e-3), i.e. only where the surfaces coincide. Measured on
        the ICT Table 3 sequence (``benchmarks/bench_face_tables.py``):
        "guided" lowers DMT's error against the true in-between surfaces from
        5.0e-3–1.3e-2 to 3.4e-3–4.7e-3 (curved path, metric homotopy;
        screened homotopy: 1.2e-3–3.1e-3 to 0.7e-3–1.2e-3) and from
        0.8e-3–1.9e-3 to 3–4e-4 (linear path, metric). Its dense
        correspondence error against the known one is 3.6e-3 (key 1) and
        7.7e-3 (key 2, composite) diameters rms, against 3.2e-3 and 1.2e-2
        for landmarks only. The ``static_*`` fields override the preset.
    static_refinement : int, optional
        Rounds of extra DMT correspondences on the parts of the aligned
        surfaces that coincide (:mod:`conformorph.geometry.static_correspondences`);
        0 = the paper's landmark-only DMT. Default: the preset's.
    static_tol : float, optional
        Their distance tolerance (in diameters). Default: the preset's.
    static_samples : int
        Sample count. Default 400.
    static_max_disk_offset : float
        Disk consistency bound. Default 0.05.
    static_min_separation : float
        Minimum disk separation of extra landmarks. Default 0.02.
    static_guided : bool, optional
        Look for the closest point from where the landmarks' interpolated 3D
        motion predicts the sample to be (deformation-guided closest points),
        instead of from the sample itself. Default: the preset's.
    extra_regularization : float
        Tikhonov ε of the fit with extra correspondences (and with the
        ``"nicp"`` ones: that fit does not interpolate the landmarks exactly;
        measured E_D 1e-6–1e-5 on the test faces, 1.8e-3 on ICT
        neutral→jawOpen). Default 1e-8.
    nicp_correspondences : int
        Most extra correspondences per pair taken from the non-rigid ICP.
        Default :data:`NICP_CORRESPONDENCES`.
    nicp_tol : float
        Largest distance (diameters) of a deformed node to the target surface
        for it to give a correspondence. Default :data:`NICP_TOL`.
    nicp_max_nodes : int
        Largest consistent mesh on which ``refine="auto"`` uses ``"nicp"``.
        Default :data:`NICP_AUTO_MAX_NODES`.
    landmark_fit : {"exact", "tolerant"}
        ``"exact"``: the paper's DMT, which interpolates the landmarks (and pins the
        non-rigid ICP to them). ``"tolerant"``: the landmarks are weighted by their
        confidence (stage-1 ``lm_confidence``) instead: the Möbius part is a weighted
        least-squares fit, the thin-plate part a smoothing spline whose regularisation
        per landmark grows with ``landmark_noise`` / confidence, the non-rigid ICP's
        landmark pull fades as it becomes supple, and the dense fit goes through the
        *corrected* landmarks (where the ICP carried each source landmark on the
        target), reported per pair. Default :data:`DEFAULT_LANDMARK_FIT`.
    landmark_noise : float
        Landmark error (diameters, rms per axis) assumed by ``"tolerant"`` for a
        landmark of confidence 1. Default :data:`LANDMARK_NOISE`.
    consistency_check : bool
        Also register every pair backwards (key i → key i − 1, same options) and
        report, per pair, how far the backward map carries each consistent node from
        where it started (``pairs[].correspondence_estimate``): a lower estimate of the
        per-vertex correspondence error, which surface distance does not see (on ICT
        neutral → smile, exact landmarks: 0.16 mm mean where the truth is 0.44 mm).
        Costs a second registration of every pair. Default False.
    """

    method: str = "dmt"
    consistent: str = "source"
    target_vertices: int | None = None
    icp_iterations: int = 10
    baselines: bool = True
    curvature_source: str = "consistent"
    refine: str = "auto"
    static_refinement: int | None = None
    static_tol: float | None = None
    static_samples: int = 400
    static_max_disk_offset: float = 0.05
    static_min_separation: float = 0.02
    static_guided: bool | None = None
    extra_regularization: float = 1e-8
    nicp_correspondences: int = NICP_CORRESPONDENCES
    nicp_tol: float = NICP_TOL
    nicp_max_nodes: int = NICP_AUTO_MAX_NODES
    landmark_fit: str = DEFAULT_LANDMARK_FIT
    landmark_noise: float = LANDMARK_NOISE
    consistency_check: bool = False


@dataclass(frozen=True)
class FrameOptions:
    """Options of stage 3 (:func:`conformorph.pipelines.face_morph.frames.compute_frames`).

    Attributes
    ----------
    curvature : {"screened", "metric", "vector", "scalar"}
        Homotopy of the curvature (see :mod:`conformorph.geometry.morph_frames`):
        ``screened`` (default) — ``metric`` screened towards the cubic spline of
        the key positions (:data:`conformorph.geometry.morph_frames.SCREEN_WEIGHT`);
        ``metric`` — mean-curvature vector with the Laplacian of the
        interpolated metric; ``vector`` — mean-curvature vector with the disk
        Laplacian; ``scalar`` — the paper's scalar H with Algorithm 1. The
        default was chosen by measurement (``benchmarks/bench_face_tables.py``,
        DMT keys of different connectivity, relative L2 distance to the true
        in-between ICT surfaces at t = 0.3, 0.5, 1.3, 1.5): screened
        1.1e-3, 1.2e-3, 0.7e-3, 0.9e-3 against metric 3.4e-3, 4.2e-3, 3.9e-3,
        4.7e-3 on the curved path; 2.8e-3–3.0e-3 against 4.3e-3–5.9e-3 on a
        path with sinusoidal blend weights; lower on the linear path too.
    key_metrics : bool
        Reconstruct the key frames and measure their distance to the inputs.
        Default True.
    """

    curvature: str = DEFAULT_CURVATURE
    key_metrics: bool = True


@dataclass(frozen=True)
class ExportOptions:
    """Options of stage 4 (:func:`conformorph.pipelines.face_morph.export.export_outputs`).

    Attributes
    ----------
    per_frame : bool
        Also write ``frames/NNN.glb`` (frame k with its rigid motion applied).
        Default False.
    sparse : bool
        Sparse morph targets. Default False.
    normals : bool
        Write a ``NORMAL`` delta per morph target in ``animation.glb`` where the
        morph changes the normals. Default :data:`DEFAULT_NORMALS` (True): with
        static normals three.js and Babylon light an opened mouth as if closed
        (95th percentile 78° off on ICT neutral → jawOpen). The base mesh's smooth
        vertex normals are always written; Blender ignores normal targets; the
        glTF spec guarantees viewers 8 morphed attributes and with normal targets
        each active target uses two (at most two targets are active at once here,
        so 4 of the 8, 6 with colour targets too).
    compress : {"auto", "meshopt", "none"}
        ``EXT_meshopt_compression`` of the GLBs (:mod:`conformorph.pipelines.gltf_compression`):
        ``auto`` (default :data:`DEFAULT_COMPRESS`) when a file would exceed 16 MiB
        uncompressed, ``meshopt`` always, ``none`` never (for tools without a meshopt
        decoder: Blender, trimesh).
    output_resolution : {"auto", "input", "working"}
        ``auto`` (default): ``input`` up to ``full_resolution.AUTO_MAX_VERTICES`` (300k)
        input vertices, ``working`` above. ``input``: when key 0 was decimated to the
        working resolution, the GLBs
        carry key 0 as read, following the working mesh's deformation with its detail
        (:mod:`conformorph.pipelines.face_morph.full_resolution`); ``working``: the
        decimated consistent mesh.
    """

    per_frame: bool = False
    sparse: bool = False
    normals: bool = DEFAULT_NORMALS
    compress: str = DEFAULT_COMPRESS
    output_resolution: str = "auto"

    def __post_init__(self) -> None:
        check_compress(self.compress)
        if self.output_resolution not in ("auto", "input", "working"):
            raise ValueError(
                f"output_resolution must be auto, input or working, got {self.output_resolution!r}"
            )


@dataclass(frozen=True)
class FaceMorphOptions:
    """Everything :func:`conformorph.pipelines.face_morph.run.run_face_morph` is told besides its files.

    Attributes
    ----------
    times : tuple of float, optional
        Key times, strictly increasing; default 0 … N.
    frames : int
        Frames evenly spaced from t0 to tN inclusive. Default 30.
    frame_times : tuple of float, optional
        Explicit frame times instead of ``frames``, strictly increasing; they
        may lie outside [t0, tN], where the homotopy extrapolates (the end
        cubic pieces are continued, Table 4 of the paper). The animation's
        clock starts at the first one.
    keys : KeyOptions
        Repairs and disk map of every key.
    registration : RegistrationOptions
        Stage 2; its MT baseline is built only when ``baselines`` and something
        measures it (``homotopy.key_metrics`` or truths).
    homotopy : FrameOptions
        Stage 3.
    export : ExportOptions
        Stage 4.
    write_glb : bool
        Write the GLB files (off for benchmarks). Default True.
    units : {"auto", "mm", "cm", "m"}
        The keys' length unit, or ``"auto"`` (default :data:`DEFAULT_UNITS`) to infer each
        key's from its landmarks or size (:mod:`conformorph.pipelines.face_morph.units`);
        the keys are brought to key 0's unit before the morph and the GLBs are in metres.
    key_processes : bool
        Prepare key files that reach ``PROCESS_KEYS_MIN_BYTES`` together in spawned
        processes, one a key, rather than on threads (reading and decimating a big scan
        hold the GIL). A spawned process imports the caller's ``__main__``, so a script
        that sets this needs an ``if __name__ == "__main__":`` guard; ``conformorph
        morph`` sets it, the default False keeps library calls safe. Default False.
    key_cache : str or None
        Folder of the key cache (:mod:`conformorph.pipelines.face_morph.key_cache`): each
        key's per-mesh work (preparation, disk map, H, Hn, λ) is looked up there by the
        file's bytes and the key options, and stored after it is computed. None
        (default) computes every key afresh; ``conformorph morph`` defaults to
        :func:`~conformorph.pipelines.face_morph.key_cache.default_cache_dir`.
    """

    times: tuple[float, ...] | None = None
    frames: int = 30
    frame_times: tuple[float, ...] | None = None
    keys: KeyOptions = field(default_factory=KeyOptions)
    registration: RegistrationOptions = field(default_factory=RegistrationOptions)
    homotopy: FrameOptions = field(default_factory=FrameOptions)
    export: ExportOptions = field(default_factory=ExportOptions)
    write_glb: bool = True
    key_processes: bool = False
    key_cache: str | None = None
    units: str = DEFAULT_UNITS

    def __post_init__(self) -> None:
        check_units(self.units)
