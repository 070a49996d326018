"""Upload validation: the bodies of the synchronous tasks the API calls before it stores an upload.

Each loads the staged upload by storage key and calls one step of
:mod:`conformorph.pipelines.upload_validation`, which reads the file from its bytes only.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from conformorph.worker.storage import Storage


def load_mesh_file(path: Path, file_type: str) -> tuple[np.ndarray, np.ndarray]:
    """Read a stored mesh with the project's reader (vertex order kept)."""
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(path.read_bytes(), file_type)
    return np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)


def validate_upload(
    storage: Storage,
    key: str,
    file_type: str,
    *,
    max_vertices: int,
    max_faces: int,
) -> dict[str, Any]:
    """Read and validate an uploaded mesh exactly as the CLI does
    (:func:`conformorph.pipelines.upload_validation.validate_mesh_upload`)."""
    from conformorph.pipelines.mesh_io import MeshLimits
    from conformorph.pipelines.upload_validation import validate_mesh_upload

    data = storage.local_path(key).read_bytes()
    return validate_mesh_upload(data, file_type, MeshLimits(max_vertices, max_faces))


def validate_shape_upload(
    storage: Storage, key: str, *, max_points: int | None = None
) -> dict[str, Any]:
    """Read and validate an uploaded 2D shape
    (:func:`conformorph.pipelines.upload_validation.validate_shape_upload`)."""
    from conformorph.pipelines.upload_validation import validate_shape_upload as validate

    data = storage.local_path(key).read_bytes()
    return validate(data, Path(key).suffix, max_points=max_points)


def job_vertex_budget(params: dict[str, Any]) -> int | None:
    """The preparation's working resolution from a job's ``vertex_budget`` field.

    Parameters
    ----------
    params : dict
        The job's parameters (API fields); a job submitted before the field
        existed has none and gets the preparation's default.

    Returns
    -------
    int or None
        None (never decimate) for 0.
    """
    from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET

    budget = int(params.get("vertex_budget", DEFAULT_VERTEX_BUDGET))
    return None if budget == 0 else budget
