"""The API's models: the pydantic schemas the server validates and answers with.

They live in ``conformorph_client._schemas``, a copy of the server's schema module
(it imports nothing but pydantic) written by ``tools/sync_client_models.py``, so
the client installs alone. ``tests/client/test_models_match.py`` holds the copy
to the server's module and to ``openapi/openapi.json``.
"""

from __future__ import annotations

from conformorph_client._schemas import (
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
from conformorph_client._schemas import JobError as JobErrorInfo

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
