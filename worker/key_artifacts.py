"""Key artifacts in the service: each uploaded mesh's per-mesh work (preparation, disk map,
H, Hn, λ) stored once under ``keys/<owner>/<mesh id>/<artifact key>.npz`` and reused by
every morph of the mesh.

After an upload is validated the API sends ``conformorph.precompute_key`` (on the jobs
queue, by name) for the new mesh; the task computes the artifact for the options a
default job on that mesh uses. A morph's ``prepare`` stage finds it ready, or computes
and stores it (another option set, or the task not done yet). Every stored artifact has
a row in the job store (:mod:`conformorph.worker.job_store.key_artifacts`), so the
storage quota counts it and the retention cleanup deletes it with its mesh.
"""

from __future__ import annotations

import logging
from typing import Any

from conformorph.worker.job_store import JobStore
from conformorph.worker.storage import ArtifactNotFound, Storage

log = logging.getLogger(__name__)


def key_artifact_prefix(owner: str, mesh_id: str) -> str:
    """The storage prefix of ``owner``'s mesh ``mesh_id``'s key artifacts."""
    return f"keys/{owner}/{mesh_id}"


class StorageArtifactStore:
    """A :class:`~conformorph.pipelines.face_morph.key_cache.KeyArtifactStore` over the job
    storage: ``get``/``put`` by artifact key under the mesh's prefix, each write
    (atomic in every :class:`Storage`) recorded for the quota and the cleanup.

    Parameters
    ----------
    storage : Storage
    store : JobStore
    owner, mesh_id : str
        The uploaded mesh the artifacts belong to.
    """

    def __init__(self, storage: Storage, store: JobStore, owner: str, mesh_id: str) -> None:
        self.storage, self.store, self.owner, self.mesh_id = storage, store, owner, mesh_id

    def _key(self, key: str) -> str:
        return f"{key_artifact_prefix(self.owner, self.mesh_id)}/{key}.npz"

    def get(self, key: str) -> bytes | None:
        try:
            return self.storage.read_bytes(self._key(key))
        except (ArtifactNotFound, FileNotFoundError):
            return None

    def put(self, key: str, data: bytes) -> None:
        obj = self.storage.put_bytes(self._key(key), data)
        self.store.add_key_artifact(self.owner, self.mesh_id, obj.key, obj.size)


def precompute_key_artifact(
    storage: Storage, store: JobStore, owner: str, mesh_id: str, options: Any
) -> dict[str, Any]:
    """The body of ``conformorph.precompute_key``: the key artifact of ``owner``'s mesh
    ``mesh_id`` for the key options ``options`` (a default job's:
    :func:`conformorph.worker.stages.face_morph.default_key_options`), computed and stored
    unless present.

    Returns
    -------
    dict
        ``mesh``, ``state`` (``hit``, ``stored``, ``replaced``, ``gone`` for a mesh deleted
        meanwhile, ``failed`` with ``detail`` for a mesh whose per-mesh work fails: the
        job that uses it reports that in its own words) and ``key``.
    """
    from conformorph.pipelines.face_morph.key_cache import cached_artifact

    mesh = store.get_mesh(owner, mesh_id)
    if mesh is None:
        return {"mesh": mesh_id, "state": "gone"}
    cache = StorageArtifactStore(storage, store, owner, mesh_id)
    try:
        _, info = cached_artifact(
            cache,
            storage.local_path(mesh.storage_key),
            [],
            0,
            file_type=mesh.file_type,
            options=options,
        )
    except (ValueError, ArithmeticError) as exc:  # numerical or topological: final
        log.info("precompute of mesh %s failed: %s", mesh_id, exc)
        return {"mesh": mesh_id, "state": "failed", "detail": str(exc)}
    return {"mesh": mesh_id, "state": info["state"], "key": info["key"]}
