"""Uploaded inputs, each scoped to its owner: meshes, 2D shapes, landmark sets, textures.
An upload's id is its content's, so the same upload again keeps the first record."""

from __future__ import annotations

import time
from dataclasses import asdict
from typing import Any

from sqlalchemy import Text, cast, select

from conformorph.worker.job_store.base import StoreBase, newest_first, present
from conformorph.worker.job_store.tables import (
    ExpiredUpload,
    LandmarkSetRecord,
    MeshRecord,
    ShapeRecord,
    TextureRecord,
)
from conformorph.worker.job_store.views import MeshView, TextureView


class UploadStore(StoreBase):
    """The uploaded inputs of a job store."""

    # -------------------------------------------------------------- meshes
    def get_mesh(self, owner: str, mesh_id: str) -> MeshView | None:
        return self._get_owned(MeshRecord, MeshView, owner, mesh_id)

    def add_mesh(self, view: MeshView) -> MeshView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(MeshRecord(**asdict(view)))
        return present(self.get_mesh(view.owner, view.id))

    def list_meshes(self, owner: str, *, limit: int = 50, offset: int = 0) -> list[MeshView]:
        with self.session() as s:
            stmt = select(MeshRecord).where(MeshRecord.owner == owner)
            rows = s.scalars(newest_first(stmt, MeshRecord, limit, offset))
            return [MeshView.of(r) for r in rows]

    # -------------------------------------------------------------- shapes
    def get_shape(self, owner: str, shape_id: str) -> MeshView | None:
        return self._get_owned(ShapeRecord, MeshView, owner, shape_id)

    def add_shape(self, view: MeshView) -> MeshView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(ShapeRecord(**asdict(view)))
        return present(self.get_shape(view.owner, view.id))

    # ------------------------------------------------------------ landmarks
    def get_landmarks(self, owner: str, set_id: str) -> tuple[dict[str, Any], float] | None:
        """(document, created_at) of an uploaded landmark set, or None."""
        with self.session() as s:
            r = s.get(LandmarkSetRecord, (owner, set_id))
            return (dict(r.data), r.created_at) if r else None

    def get_landmarks_json(self, owner: str, set_id: str) -> str | None:
        """The stored landmark document as JSON text, never parsed here (None: no such set).

        Serving a document needs only its text: parsing and re-serialising a
        150k-point document took seconds of CPU per request (issue 30).
        """
        with self.session() as s:
            text = s.scalar(
                select(cast(LandmarkSetRecord.data, Text)).where(
                    LandmarkSetRecord.owner == owner, LandmarkSetRecord.id == set_id
                )
            )
            return None if text is None else str(text)

    def add_landmarks(
        self, owner: str, set_id: str, data: dict[str, Any], *, created_at: float | None = None
    ) -> float:
        """Store a landmark document (same id again: kept); returns the stored record's
        creation time, which differs from ``created_at`` when another insert came first."""
        stamp = time.time() if created_at is None else float(created_at)
        self._insert_once(LandmarkSetRecord(owner=owner, id=set_id, data=data, created_at=stamp))
        with self.session() as s:  # the stored record's time, without reading its document
            return float(
                present(
                    s.scalar(
                        select(LandmarkSetRecord.created_at).where(
                            LandmarkSetRecord.owner == owner, LandmarkSetRecord.id == set_id
                        )
                    )
                )
            )

    # ------------------------------------------------------------ expired
    def upload_expired(self, owner: str, upload_id: str) -> bool:
        """True when the retention cleanup deleted ``owner``'s upload ``upload_id``
        (and it was not uploaded again since)."""
        with self.session() as s:
            return s.get(ExpiredUpload, (owner, upload_id)) is not None

    # ------------------------------------------------------------ textures
    def get_texture(self, owner: str, tex_id: str) -> TextureView | None:
        return self._get_owned(TextureRecord, TextureView, owner, tex_id)

    def add_texture(self, view: TextureView) -> TextureView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(TextureRecord(**asdict(view)))
        return present(self.get_texture(view.owner, view.id))
