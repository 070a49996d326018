# A copy of the server's service/schemas.py, written by tools/sync_client_models.py:
# edit the server's module and run that script, never this file.
"""Request and response bodies (pydantic v2), split into Create and Public variants."""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

# the defaults and ranges every entry point shares (pure Python; the client's copy of this
# module imports the client's copy of it, both written by tools/sync_client_models.py)
from ._job_fields import (
    EXTRAPOLATION_SPANS,
    LANDMARK_FIT_DEFAULT,
    MAP_PREPARE_DEFAULT,
    MIN_TIME_SPAN,
    MIN_VERTEX_BUDGET,
    MORPH_BASELINES_DEFAULT,
    MORPH_PREPARE_DEFAULT,
    TIME_LIMIT,
    TIME_MAGNITUDE_RTOL,
    TIME_SPACING_RTOL,
    VERTEX_BUDGET_DEFAULT,
)

#: ``MorphCreate.units``'s choices and default: the face morph's UNIT_CHOICES and
#: DEFAULT_UNITS (tests/service check they agree)
Units = Literal["auto", "mm", "cm", "m"]
UNITS_DEFAULT: Units = "auto"
#: ``MorphCreate.normals``'s default: the face morph's DEFAULT_NORMALS
NORMALS_DEFAULT = True
#: ``Morph2dCreate.loop``'s default and values: conformorph.pipelines.animation_loop's
#: DEFAULT_LOOP and LOOP_MODES (tests/service check the two agree)
LoopMode = Literal["once", "repeat", "alternate"]
LOOP_DEFAULT: LoopMode = "once"

#: where a landmark the viewer sends came from (``MorphCreate.landmark_provenance``)
LandmarkProvenance = Literal["detected", "moved", "picked", "file"]

JobState = Literal["queued", "running", "succeeded", "failed", "cancelled"]

#: every id this service makes: uploads get a content hash, jobs a random UUID,
#: both as 32 lower-case hex digits (``uploads.content_id``, ``JobStore.create_job``)
ID_PATTERN = r"^[0-9a-f]{32}$"
_ID_RE = re.compile(ID_PATTERN)

#: an id in a request body: anything else is answered 422 before the job store is asked
ItemId = Annotated[
    str, Field(pattern=ID_PATTERN, description="an id this service gave (32 hex digits)")
]
MeshId = ItemId


def is_item_id(value: str) -> bool:
    """True for a string that can be one of our ids (32 lower-case hex digits).

    Path ids failing this are answered 404 without a database look-up: a NUL
    or any other odd character never reaches the job store (PostgreSQL
    rejects NUL in text).
    """
    return _ID_RE.fullmatch(value) is not None


class ErrorInfo(BaseModel):
    type: str = Field(description="machine-readable error type")
    message: str
    field: str | None = Field(None, description="the input concerned, if any")


class ErrorBody(BaseModel):
    error: ErrorInfo


class JobError(ErrorInfo):
    stage: str | None = None


class MeshPublic(BaseModel):
    id: str = Field(description="content-addressed per owner: same bytes, same id")
    filename: str
    file_type: str
    size_bytes: int
    vertices: int
    faces: int
    boundary_loops: int | None = None
    euler_characteristic: int | None = None
    report: dict[str, Any] = Field(default_factory=dict, description="the validator's report")
    created_at: float


class TexturePublic(BaseModel):
    id: str
    filename: str
    content_type: str
    size_bytes: int
    width: int
    height: int
    created_at: float


#: what ``prepare: auto`` does (the field's description; its default differs by job kind)
PREPARE_HELP = (
    "'auto': run the preparation step on each mesh first (drop unreferenced "
    "vertices, degenerate and duplicate faces and fragments, repair non-manifold spots, "
    "fill holes with faired patches, remove ears, decimate to vertex_budget; as the CLI's "
    "--prepare auto): needed by meshes whose report lists preparation_needed, and it also "
    "grants repairs_needed; outputs are then on the prepared mesh, whose report says what "
    "changed; a clean disk within the budget is left as read"
)


class MeshRepairs(BaseModel):
    """The repairs an upload's ``report.repairs_needed`` may call for (as the CLI's
    ``--fill-holes`` and ``--remove-ears``)."""

    fill_holes: bool = Field(
        False,
        description="close inner boundary loops (eyes, mouth) with a fan first; vertex ids are "
        "kept, hole centres appended (needed by meshes whose report lists "
        "repairs_needed.fill_holes)",
    )
    remove_ears: bool = Field(
        False,
        description="remove boundary vertices that lie in a single triangle first (needed by "
        "meshes whose report lists repairs_needed.remove_ears); outputs keep every input "
        "vertex",
    )

    prepare: Literal["auto", "none"] = Field(
        MAP_PREPARE_DEFAULT,
        description=PREPARE_HELP + f" (default {MAP_PREPARE_DEFAULT!r}, as 'conformorph map')",
    )
    vertex_budget: int = Field(
        VERTEX_BUDGET_DEFAULT,
        ge=0,
        description="with prepare 'auto': the working resolution; a mesh with more vertices "
        "is decimated to about this many (quadric edge collapse) and every output is at "
        "that resolution; 0 never decimates; otherwise at least 1000 (as the CLI's "
        "--vertex-budget)",
    )

    @field_validator("vertex_budget")
    @classmethod
    def _budget_floor(cls, v: int) -> int:
        if 0 < v < MIN_VERTEX_BUDGET:
            raise ValueError(
                f"vertex_budget must be 0 (never decimate) or at least {MIN_VERTEX_BUDGET}"
            )
        return v

    def repairs(self) -> set[str]:
        """The repairs asked for (names as in ``repairs_needed``; ``prepare`` for auto)."""
        asked = {r for r in ("fill_holes", "remove_ears") if getattr(self, r)}
        return asked | ({"prepare"} if self.prepare == "auto" else set())


class CallbackFields(BaseModel):
    """The webhook of a job-creating request (every ``POST`` that answers a job)."""

    callback_url: str | None = Field(
        None,
        max_length=2048,
        description="http(s) URL a worker POSTs the job record to (the body of GET "
        "/v1/jobs/{id}, as JSON) once the job ends (succeeded, failed or cancelled). "
        "Retried with exponential back-off on connection errors, time-outs, 408, 425, 429 "
        "and 5xx; never redirected; every attempt is listed in the job's callback.attempts. "
        "The destination must be allowed by the server's CONFORMORPH_CALLBACK_ALLOW (by "
        "default public addresses only: private, loopback, link-local, multicast and "
        "unspecified ones are refused with 422, and checked again at delivery). Headers: "
        "X-Conformorph-Event (job.<state>), X-Conformorph-Delivery (<job id>.<state>, the "
        "same on retries) and, with callback_secret, X-Conformorph-Timestamp and "
        "X-Conformorph-Signature",
    )
    callback_secret: str | None = Field(
        None,
        min_length=16,
        max_length=512,
        description="signs every callback POST: X-Conformorph-Timestamp: <unix seconds> and "
        "X-Conformorph-Signature: sha256=<hex HMAC-SHA256 keyed with this secret over the "
        "timestamp, a '.' and the raw body>. Never shown in job records",
    )

    def callback(self) -> tuple[str, str | None] | None:
        """``(url, secret)`` when a callback is asked for."""
        return None if self.callback_url is None else (self.callback_url, self.callback_secret)


class ConformalMapCreate(MeshRepairs, CallbackFields):
    model_config = ConfigDict(extra="forbid")

    mesh: MeshId = Field(description="id from POST /v1/meshes")
    method: Literal["fast", "qiem"] = "fast"
    center_vertex: int | None = Field(None, ge=0, description="vertex sent to the disk's centre")
    angle_vertex: int | None = Field(None, ge=0, description="boundary vertex sent to angle 0")
    refine_angles: bool = Field(
        True,
        description="fast method: finish with the angle refinement (lower mean angle "
        "distortion); false returns the discrete harmonic map",
    )


class ReconstructionCreate(MeshRepairs, CallbackFields):
    model_config = ConfigDict(extra="forbid")

    mesh: MeshId = Field(description="id from POST /v1/meshes")
    method: Literal["fast", "qiem"] = "fast"
    curvature: Literal["vector", "scalar"] = Field(
        "vector",
        description="mean-curvature vector (one solve) or the paper's scalar H (Algorithm 1's iteration)",
    )
    fold_correction: bool = Field(
        True,
        description="vector curvature: where the disk map folds, solve the surface's own Laplace "
        "equations instead of keeping the disk Laplacian's solve (errors.json "
        "reconstruction.fold_correction says what moved)",
    )


class ArtifactLink(BaseModel):
    name: str
    url: str
    content_type: str
    size: int
    etag: str


class StageInfo(BaseModel):
    name: str
    state: Literal["pending", "running", "done", "failed", "cancelled"]
    seconds: float | None = None


class JobLinks(BaseModel):
    self: str
    events: str


class CallbackAttempt(BaseModel):
    attempt: int = Field(description="1 for the first POST")
    at: float = Field(description="when it was made (unix seconds)")
    state: JobState = Field(description="the job state it reported")
    outcome: Literal["delivered", "retry", "refused"] = Field(
        description="delivered (2xx), retry (transient failure: retried later unless it was "
        "the last attempt), refused (final: another status, a redirect, or a destination "
        "no longer allowed)"
    )
    status_code: int | None = Field(None, description="the receiver's HTTP status, if any")
    error: str | None = None
    seconds: float


class CallbackPublic(BaseModel):
    url: str
    signed: bool = Field(description="true when a callback_secret signs the POSTs")
    status: Literal["pending", "delivered", "failed"]
    attempts: list[CallbackAttempt]


class JobPublic(BaseModel):
    id: str
    kind: str
    state: JobState
    stage: str | None
    progress: float = Field(ge=0.0, le=1.0)
    stages: list[StageInfo]
    created_at: float
    started_at: float | None
    finished_at: float | None
    error: JobError | None
    artifacts: list[ArtifactLink]
    params: dict[str, Any] = Field(
        description="the job's parameters (uploads by id); a value whose JSON exceeds 4 KB "
        '(e.g. a long anchor paths list) is shown by reference, {"ref": '
        '"/v1/jobs/{id}/params#/<key>", "entries": <its length>}: GET /v1/jobs/{id}/params '
        "returns every value whole"
    )
    callback: CallbackPublic | None = Field(
        None, description="the job's webhook (callback_url): status and every attempt"
    )
    links: JobLinks


class JobList(BaseModel):
    items: list[JobPublic]
    total: int
    limit: int
    offset: int


class Health(BaseModel):
    status: str


class Readiness(BaseModel):
    status: Literal["ready", "not_ready"]
    checks: dict[str, bool]
    embedded: bool


class ShapePublic(BaseModel):
    id: str = Field(description="content-addressed per owner: same bytes, same id")
    filename: str
    file_type: str
    size_bytes: int
    rings: int
    points: int
    report: dict[str, Any] = Field(default_factory=dict)
    created_at: float


#: a landmark: a vertex index, or an [x, y, z] point snapped to the surface
Landmark = int | list[float]


class LandmarkDetectionCreate(CallbackFields):
    model_config = ConfigDict(extra="forbid")

    meshes: list[MeshId] = Field(min_length=1, description="face meshes, ids from POST /v1/meshes")
    min_score: float = Field(
        0.5, ge=0.0, le=1.0, description="face-detector score below which detection fails"
    )


class MorphCreate(MeshRepairs, CallbackFields):
    # frames or frame_times, not both (422 otherwise); landmarks or landmarks_id
    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "not": {
                "required": ["frames", "frame_times"],
                "properties": {"frame_times": {"type": "array"}},
            },
            "oneOf": [
                {
                    "required": ["landmarks"],
                    "properties": {"landmarks": {"anyOf": [{"type": "array"}, {"const": "auto"}]}},
                },
                {"required": ["landmarks_id"], "properties": {"landmarks_id": {"type": "string"}}},
            ],
        },
    )

    meshes: list[MeshId] = Field(
        min_length=2, description="key meshes M0 … MN, ids from POST /v1/meshes"
    )
    times: list[float] | None = Field(
        None,
        description=f"key times, strictly increasing; default 0 … N. Finite, within "
        f"±{TIME_LIMIT:g}, spanning at least {MIN_TIME_SPAN:g} (and {TIME_MAGNITUDE_RTOL:g} of "
        f"their magnitude), consecutive ones at least {TIME_SPACING_RTOL:g} of the span apart "
        "(422 out_of_range otherwise)",
    )
    landmarks: list[list[Landmark]] | Literal["auto"] | None = Field(
        None,
        description="one list per mesh, same length ≥ 3: vertex indices or [x, y, z] points "
        '(or give landmarks_id); or "auto": the 68 Multi-PIE landmarks are detected on every '
        "mesh first (stage detect_landmarks; the job's landmarks.json holds them, with "
        "confidences, and their landmarks_id)",
    )
    landmarks_id: ItemId | None = Field(
        None, description="id from POST /v1/landmarks (instead of landmarks)"
    )
    landmark_provenance: list[list[LandmarkProvenance]] | None = Field(
        None,
        description="optional: where each given landmark came from, one list per mesh in the "
        "order of the landmarks: 'detected' (by a detection job, unchanged), 'moved' (detected, "
        "then moved by a person), 'picked' (placed by a person) or 'file' (read from a file); "
        "metrics.json's landmarks entry then says so, with the fit the registration used",
    )
    frames: int = Field(30, ge=2, description="frames evenly spaced from t0 to tN inclusive")
    frame_times: list[float] | None = Field(
        None,
        min_length=1,
        description="explicit frame times, finite and strictly increasing (consecutive ones at "
        f"least {TIME_SPACING_RTOL:g} of the key span apart), instead of frames; times outside "
        "[t0, tN] extrapolate the homotopy (the paper's Table 4), at most "
        f"{EXTRAPOLATION_SPANS:g} key span(s) beyond either end (422 out_of_range otherwise)",
    )
    method: Literal["dmt", "mt", "identity", "linear"] = "dmt"
    refine: Literal["auto", "guided", "nicp", "static", "none"] = Field(
        "auto",
        description="extra DMT correspondences beyond the landmarks: 'auto' (default: nicp on "
        "consistent meshes of at most 20,000 nodes, guided above), dense ones from a non-rigid "
        "ICP ('nicp', nearest the oracle registration, costly on large meshes), "
        "deformation-guided closest points ('guided'), closest points where the surfaces "
        "coincide ('static'), or none (the paper's DMT)",
    )
    landmark_fit: Literal["auto", "exact", "tolerant"] = Field(
        LANDMARK_FIT_DEFAULT,
        description="how the registration treats the landmarks: 'exact' (the paper's DMT "
        "interpolates them), 'tolerant' (weighted by the landmark file's confidence, "
        "smoothed, and corrected by the non-rigid ICP: for imprecise landmarks, e.g. 5 points "
        "or detected ones), or 'auto' (default: 'tolerant' with \"landmarks\": \"auto\", "
        "'exact' with given landmarks)",
    )
    curvature: Literal["screened", "metric", "vector", "scalar"] = Field(
        "screened",
        description="curvature homotopy of the frames: 'screened' (default, measured best: "
        "metric homotopy screened towards the spline of key positions), 'metric' (mean-curvature "
        "vector on the interpolated metric's Laplacian), 'vector' (on the disk Laplacian) or "
        "the paper's 'scalar' H with Algorithm 1",
    )
    consistent: Literal["source", "landmarks"] = "source"
    prepare: Literal["auto", "none"] = Field(
        MORPH_PREPARE_DEFAULT,
        description=PREPARE_HELP
        + f" (default {MORPH_PREPARE_DEFAULT!r}, as 'conformorph morph', 'submit' and batch "
        "manifests)",
    )
    textures: list[ItemId] | None = Field(
        None, description="one texture id per mesh (meshes need UVs)"
    )
    per_frame: bool = Field(False, description="also write frames/NNN.glb")
    baselines: bool = Field(
        MORPH_BASELINES_DEFAULT,
        description="also build the MT-only registration baseline and measure its key frames "
        "(metrics.json frames.key_frame_L2_to_inputs.mt); default "
        f"{str(MORPH_BASELINES_DEFAULT).lower()}, as 'conformorph morph' (--baselines)",
    )
    normals: bool = Field(
        NORMALS_DEFAULT,
        description="write NORMAL morph deltas where the morph changes the normals (default "
        "true: three.js and Babylon then light an opening mouth right; Blender ignores them); "
        "false leaves them out (smaller file; the base mesh's smooth normals are always "
        "written)",
    )
    compress: Literal["auto", "meshopt", "none"] = Field(
        "auto",
        description="compact GLBs (three.js and Babylon decode them): morph targets quantized "
        "(KHR_mesh_quantization, every vertex within 1e-4 of the diagonal) and packed with "
        "EXT_meshopt_compression; 'auto' (default) when a file would exceed 16 MiB "
        "uncompressed, 'meshopt' always, 'none' (plain float) for tools without a meshopt "
        "decoder (Blender, trimesh)",
    )
    output_resolution: Literal["auto", "input", "working"] = Field(
        "auto",
        description="'input': when the first mesh was decimated to the working resolution "
        "(prepare auto, vertex_budget), the GLBs carry it as uploaded, following the morph "
        "with its detail; 'working': the decimated mesh the morph was computed on; 'auto' "
        "(default): input up to 300,000 vertices, working above",
    )
    units: Units = Field(
        UNITS_DEFAULT,
        description="the meshes' length unit ('mm', 'cm', 'm'), or 'auto' (default): each "
        "mesh's inferred from its outer eye corners (landmarks 36 and 45, 8.5–10 cm apart on "
        "adults) when it has the 68 landmarks, else from its size (a face about 20 cm "
        "across). The meshes are brought to one scale before the morph, the GLBs are in "
        "metres, metrics.json says each mesh's units, source and factor; meshes whose sizes "
        "still differ by more than 2× fail the job (error units_mismatch)",
    )


class Morph2dCreate(CallbackFields):
    model_config = ConfigDict(extra="forbid")

    source: ItemId = Field(description="shape id from POST /v1/shapes")
    target: ItemId = Field(description="shape id from POST /v1/shapes")
    anchors: list[list[list[float]]] | None = Field(
        None,
        max_length=1000,
        description="[[[xs, ys], [xt, yt]], …]: point pairs in the source and target shapes; "
        "absent (or fewer than 2 pairs): corresponding points are found automatically (seeded "
        "by the pairs given, kept first) and written to the job's anchors.json artifact",
        # documents what the route checks (422 anchor_format): a pair of 2D points
        json_schema_extra={
            "items": {
                "type": "array",
                "minItems": 2,
                "maxItems": 2,
                "items": {
                    "type": "array",
                    "minItems": 2,
                    "maxItems": 2,
                    "items": {"type": "number"},
                },
            }
        },
    )
    paths: list[list[int]] | None = Field(
        None,
        max_length=1000,
        description="[[i, …, j], …]: dissection paths, anchor indices from a boundary anchor "
        "through interior anchors to a boundary anchor, straight between consecutive ones; "
        "each cuts both shapes, and the patches are triangulated apart and glued",
    )
    frames: int = Field(60, ge=2)
    interp: Literal["principal", "modified", "linear"] = Field(
        "principal",
        description="strain interpolation: 'principal' (eq. 3 in each triangle's principal "
        "frame, frame independent), 'modified' (the paper's eq. 3 in the x/y frame) or "
        "'linear' (eq. 2); the others are tried when it does not reach the target",
    )
    pace: Literal["strain", "even"] = Field(
        "strain",
        description="'strain': frame k at t = k/(frames−1) of the strain scheme (the paper); "
        "'even': the same path re-timed to move evenly (metrics.json: frame_t)",
    )
    loop: LoopMode = Field(
        LOOP_DEFAULT,
        description="how animation.svg plays: 'once' (holding the last frame), 'repeat' "
        "(again and again) or 'alternate' (there and back, again and again)",
    )
    per_frame: bool = False
    units: Literal["px", "pt", "in", "mm", "cm", "m"] = Field(
        "px",
        description="what one SVG user unit is in the GLBs, which are in metres, centred at "
        "the origin, Y up: 'px' (default: CSS pixels at 96 dpi, 0.2646 mm), 'pt', 'in', "
        "'mm', 'cm' or 'm' (animation.svg and strip.svg keep SVG units)",
    )
    size: float | None = Field(
        None,
        gt=0,
        le=1e6,
        description="the GLBs' larger side in metres (all frames together), instead of units",
    )
    point_budget: int | None = Field(
        None,
        ge=0,
        le=100000,
        description="working resolution: each shape simplified to at most this many points "
        "keeping its features and the anchors (0: none; absent: 100, except none with 2 or more "
        "anchors on shapes whose rings have equal lengths); 1 and 2 are refused",
    )
    texture: ItemId | None = Field(None, description="texture id (PNG) spread over the source")


class LandmarkSetPublic(BaseModel):
    id: str = Field(description="content-addressed per owner")
    meshes: int | None = Field(None, description="lists in the document (None: one shared list)")
    landmarks_per_mesh: int
    created_at: float
