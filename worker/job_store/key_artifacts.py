"""Rows of the stored key artifacts: each uploaded mesh's per-mesh work, by owner and mesh,
so that the quota counts them (:meth:`RetentionStore.storage_used`) and the retention
cleanup deletes them with their mesh."""

from __future__ import annotations

import time

from sqlalchemy import delete, select, update
from sqlalchemy.exc import IntegrityError

from conformorph.worker.job_store.base import StoreBase
from conformorph.worker.job_store.tables import KeyArtifactRecord


class KeyArtifactRows(StoreBase):
    """The key-artifact rows of a job store."""

    def add_key_artifact(self, owner: str, mesh_id: str, storage_key: str, size: int) -> None:
        """Record (or update the size of) the artifact stored under ``storage_key``.

        Two processes may store the same artifact at once (the upload's precompute and a
        job that did not find it yet): the one whose insert loses the race updates the
        row the other wrote."""
        try:
            with self.session() as s:
                row = s.get(KeyArtifactRecord, (owner, storage_key))
                if row is None:
                    s.add(
                        KeyArtifactRecord(
                            owner=owner,
                            storage_key=storage_key,
                            mesh_id=mesh_id,
                            size_bytes=int(size),
                            created_at=time.time(),
                        )
                    )
                else:
                    row.size_bytes = int(size)
        except IntegrityError:
            with self.session() as s:
                s.execute(
                    update(KeyArtifactRecord)
                    .where(
                        KeyArtifactRecord.owner == owner,
                        KeyArtifactRecord.storage_key == storage_key,
                    )
                    .values(size_bytes=int(size))
                )

    def key_artifacts_of(self, owner: str, mesh_id: str) -> list[tuple[str, int]]:
        """``(storage key, bytes)`` of every artifact of ``owner``'s mesh ``mesh_id``."""
        with self.session() as s:
            rows = s.execute(
                select(KeyArtifactRecord.storage_key, KeyArtifactRecord.size_bytes).where(
                    KeyArtifactRecord.owner == owner, KeyArtifactRecord.mesh_id == mesh_id
                )
            )
            return [(str(k), int(n)) for k, n in rows]

    def remove_key_artifacts(self, owner: str, mesh_id: str) -> list[tuple[str, int]]:
        """Delete the rows of ``owner``'s mesh ``mesh_id``'s artifacts; returns them (the
        caller deletes the files)."""
        gone = self.key_artifacts_of(owner, mesh_id)
        with self.session() as s:
            s.execute(
                delete(KeyArtifactRecord).where(
                    KeyArtifactRecord.owner == owner, KeyArtifactRecord.mesh_id == mesh_id
                )
            )
        return gone

    def key_artifact_bytes(self, owner: str) -> int:
        """Bytes of ``owner``'s stored key artifacts."""
        with self.session() as s:
            sizes = s.scalars(
                select(KeyArtifactRecord.size_bytes).where(KeyArtifactRecord.owner == owner)
            )
            return sum(int(n) for n in sizes)
