"""The API's models, shared with the server: the pydantic schemas of ``service.schemas``.

``service.schemas`` imports nothing but pydantic, so the client gets the very
models the server validates and answers with (no numerics are imported).
"""

from __future__ import annotations

from service.schemas import (
    ArtifactLink,
    ConformalMapCreate,
    ErrorBody,
    ErrorInfo,
    Health,
    JobLinks,
    JobList,
    JobPublic,
    JobState,
    LandmarkSetPublic,
    MeshPublic,
    Morph2dCreate,
    MorphCreate,
    Readiness,
    ReconstructionCreate,
    ShapePublic,
    StageInfo,
    TexturePublic,
)
from service.schemas import JobError as JobErrorInfo

#: states after which a job changes no more
TERMINAL_STATES: tuple[str, ...] = ("succeeded", "failed", "cancelled")

__all__ = [
    "ArtifactLink",
    "ConformalMapCreate",
    "ErrorBody",
    "ErrorInfo",
    "Health",
    "JobErrorInfo",
    "JobLinks",
    "JobList",
    "JobPublic",
    "JobState",
    "LandmarkSetPublic",
    "MeshPublic",
    "Morph2dCreate",
    "MorphCreate",
    "Readiness",
    "ReconstructionCreate",
    "ShapePublic",
    "StageInfo",
    "TERMINAL_STATES",
    "TexturePublic",
]
