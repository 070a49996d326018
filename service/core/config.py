"""API settings (pydantic-settings), read from ``CONFORMORPH_*`` environment variables.

They extend the settings shared with the workers (:class:`conformorph.worker.config.WorkerSettings`:
data folder, job store URL, broker) with the API's limits.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Annotated

from pydantic import Field

from conformorph.worker.config import WorkerSettings


class Settings(WorkerSettings):
    """Everything the API needs; each limit answers 413/422/429 with a clear body."""

    #: largest mesh upload in bytes (413 beyond). 256 MiB: a scan of about a million
    #: vertices, the largest the pipelines are sized for (the preparation decimates it to
    #: its working resolution), is 116 MB as an OBJ with 17 significant digits (1.09M
    #: vertices, 2.2M faces), more with UVs and normals; it streams to disk
    #: (service/api/uploads.py), never whole into memory
    max_upload_bytes: int = 256 * 1024 * 1024
    #: largest texture upload in bytes (413 beyond) and in pixels (422 beyond)
    max_texture_bytes: int = 16 * 1024 * 1024
    max_texture_pixels: int = 4096 * 4096
    #: a texture whose decoded size (width x height x bytes a pixel) is over
    #: ``texture_ratio_floor_bytes`` may be at most this many times its file's size
    #: (422 ``image_too_compressed`` beyond: a decompression bomb); the API reads
    #: only the header, never decodes
    max_texture_ratio: float = 200.0
    texture_ratio_floor_bytes: int = 4 * 1024 * 1024
    #: largest landmark document in bytes, POST /v1/landmarks or inline in POST /v1/morphs
    #: (413 beyond)
    max_landmark_bytes: int = 4 * 1024 * 1024
    #: largest body of any other JSON POST in bytes (413 beyond)
    max_json_bytes: int = 1024 * 1024
    #: largest mesh accepted (422 beyond): twice a million-vertex scan. Validating
    #: 1.09M vertices took 15 s (read 3 s) and morphing two with --prepare auto 27 s and
    #: 2.05 GB at load 0.7 (benchmarks/bench_scan_scale.py); was 300,000 / 600,000
    max_vertices: int = 2_000_000
    max_faces: int = 4_000_000
    #: most points in an uploaded 2D shape, all rings together (422 beyond; the
    #: compatible triangulation's memory grows with its square, see
    #: conformorph.pipelines.shape_io.DEFAULT_MAX_POINTS, which this default equals)
    max_shape_points: int = 2_000
    #: most key frames (meshes) and frames of one morph (422 beyond)
    max_key_frames: int = 8
    max_frames: int = 240
    #: most queued or running jobs per key (429 beyond)
    max_active_jobs: int = 32
    #: bytes one key may store, uploaded files plus its jobs' artifacts (an upload past
    #: it: 413 ``storage_quota_exceeded``); 0: no quota. 10 GiB: about 40 uploads at
    #: the 256 MiB upload limit (150 of 64 MiB), or some hundreds of 30-frame morphs, under the
    #: week-long retention; lower it for many keys on one disk
    storage_quota_bytes: int = 10 * 1024**3
    #: Prometheus metrics at /metrics on the API's port, never behind the API key
    #: (service/metrics.py); false: no /metrics and no request metrics
    metrics_enabled: bool = True
    #: seconds (wall clock, from the upload's arrival at the validation step) the API
    #: waits for a worker to validate an upload (503 with Retry-After beyond)
    validate_timeout: float = 60.0
    #: uploads validated at once; more wait for a thread (their wait counts in
    #: ``validate_timeout``), and never take the threads that serve other requests
    validation_threads: int = 16
    #: upload validations that run at once on the workers (``conformorph serve`` starts
    #: that many validation processes; compose's ``validation`` service has as many);
    #: one key holds at most all but one of them, so it cannot stall the others' uploads
    validation_slots: Annotated[int, Field(ge=1, le=64)] = 2
    #: seconds (wall clock) any call to the broker or result store may take (503
    #: with Retry-After beyond: sending a job, cancelling one)
    broker_timeout: float = 10.0
    #: while no API key exists, how often the API checks whether one was created
    open_mode_recheck_seconds: float = 1.0
    #: how often the event stream looks at the job
    events_poll_seconds: float = 0.2


@lru_cache
def get_settings() -> Settings:
    """Settings read once from the environment (override in tests)."""
    return Settings()
