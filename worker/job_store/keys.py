"""API keys: created as random tokens, stored as their SHA-256 only."""

from __future__ import annotations

import hashlib
import secrets
import time
import uuid

from sqlalchemy import select

from conformorph.worker.job_store.base import StoreBase, count_rows
from conformorph.worker.job_store.tables import ApiKey

KEY_PREFIX = "cm_"


def hash_api_key(key: str) -> str:
    """SHA-256 of an API key (keys are 256-bit random tokens, so no slow hash is needed)."""
    return hashlib.sha256(key.encode()).hexdigest()


class KeyStore(StoreBase):
    """The API keys of a job store."""

    def create_key(self, name: str) -> tuple[str, str]:
        """Create an API key; returns (key id, the plaintext key, shown once)."""
        if not name or len(name) > 200:
            raise ValueError("key name must be 1-200 characters")
        plain = KEY_PREFIX + secrets.token_urlsafe(32)
        kid = uuid.uuid4().hex[:16]
        with self.session() as s:
            s.add(ApiKey(id=kid, name=name, key_hash=hash_api_key(plain), created_at=time.time()))
        return kid, plain

    def count_keys(self) -> int:
        with self.session() as s:
            return count_rows(s, ApiKey)

    def key_id_for(self, plain: str) -> str | None:
        """The id of the key whose hash matches ``plain``, or None."""
        with self.session() as s:
            return s.scalar(select(ApiKey.id).where(ApiKey.key_hash == hash_api_key(plain)))
