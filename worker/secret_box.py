"""Webhook secrets encrypted at rest in the job store.

A job's ``callback_secret`` signs its webhook (HMAC-SHA256), so the worker that
delivers it needs the secret itself, not a hash of it. It is kept encrypted
(Fernet: AES-128-CBC with an HMAC-SHA256 tag, from ``cryptography``) with a server
key, so that a copy of the job store (a backup, a read-only database user) does
not hand out every receiver's signing key.

The key: ``CONFORMORPH_SECRET_KEY`` (a Fernet key, or any passphrase, which is
hashed into one), the same on the API and every worker; without it, a key file
``<data dir>/secret.key`` made on first use (mode 0600), which serves one host
(``conformorph serve``, the embedded set-up). Stored values carry the prefix
``fernet:``; a value without it is a row written before encryption (plaintext):
it is still read, and :func:`seal_plaintext_secrets` (run when a worker starts)
encrypts such rows in place.
"""

from __future__ import annotations

import base64
import binascii
import functools
import hashlib
import logging
import os
from pathlib import Path

from cryptography.fernet import Fernet, InvalidToken
from sqlalchemy import select

from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_store import JobStore
from conformorph.worker.job_store.tables import CallbackRecord

log = logging.getLogger(__name__)

#: prefix of an encrypted stored secret
SEALED_PREFIX = "fernet:"
#: the key file's name in the data directory
KEY_FILE = "secret.key"


class SecretUnreadable(ValueError):
    """A stored secret this server's key cannot decrypt (another key sealed it)."""

    code = "callback_secret_unreadable"


def _fernet_key(text: str) -> bytes:
    """``text`` as a Fernet key: itself when it is one, else its SHA-256, encoded."""
    raw = text.strip().encode()
    try:
        if len(base64.urlsafe_b64decode(raw)) == 32:
            return raw
    except (binascii.Error, ValueError):
        pass
    return base64.urlsafe_b64encode(hashlib.sha256(raw).digest())


def _key_file(data_dir: Path) -> bytes:
    """The data directory's key, made (0600, atomically: one writer wins) when absent."""
    path = data_dir / KEY_FILE
    data_dir.mkdir(parents=True, exist_ok=True)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return path.read_bytes().strip()
    key = Fernet.generate_key()
    with os.fdopen(fd, "wb") as f:
        f.write(key + b"\n")
    return key


class SecretBox:
    """Seals and opens stored webhook secrets with the server key.

    Parameters
    ----------
    key : bytes
        A Fernet key (32 bytes, url-safe base64).
    """

    def __init__(self, key: bytes) -> None:
        self._fernet = Fernet(key)

    @classmethod
    def for_settings(cls, settings: WorkerSettings) -> SecretBox:
        """The box of ``CONFORMORPH_SECRET_KEY``, else of the data directory's key file."""
        return _box(settings.secret_key, str(settings.data_dir))

    def seal(self, secret: str | None) -> str | None:
        """The stored form of ``secret`` (None stays None)."""
        if secret is None:
            return None
        return SEALED_PREFIX + self._fernet.encrypt(secret.encode()).decode()

    def open(self, stored: str | None) -> str | None:
        """The secret of a stored value (a plaintext value of an older row as it is).

        Raises
        ------
        SecretUnreadable
            A sealed value this key cannot open.
        """
        if stored is None or not stored.startswith(SEALED_PREFIX):
            return stored
        try:
            return self._fernet.decrypt(stored[len(SEALED_PREFIX) :].encode()).decode()
        except InvalidToken as exc:
            raise SecretUnreadable(
                "the callback secret was sealed with another server key: set the same "
                "CONFORMORPH_SECRET_KEY on the API and every worker"
            ) from exc


@functools.lru_cache(maxsize=8)
def _box(secret_key: str | None, data_dir: str) -> SecretBox:
    if secret_key:
        return SecretBox(_fernet_key(secret_key))
    return SecretBox(_key_file(Path(data_dir)))


def box_for(settings: WorkerSettings) -> SecretBox:
    """:meth:`SecretBox.for_settings`, made once per key and data directory."""
    return _box(settings.secret_key, str(settings.data_dir))


def seal_plaintext_secrets(store: JobStore, box: SecretBox) -> int:
    """Encrypt every webhook secret still stored in plaintext (rows written before
    encryption); returns how many. Safe to run on several workers at once."""
    sealed = 0
    with store.session() as s:
        rows = s.scalars(
            select(CallbackRecord).where(
                CallbackRecord.secret.is_not(None),
                CallbackRecord.secret.not_like(f"{SEALED_PREFIX}%"),
            )
        )
        for r in rows:
            r.secret = box.seal(r.secret)
            sealed += 1
    if sealed:
        log.warning("encrypted %d webhook secret(s) stored in plaintext", sealed)
    return sealed
