"""Dependencies as ``Annotated`` aliases: settings, job store, storage, task client, owner."""

from __future__ import annotations

import hmac
import ipaddress
import threading
import time
from typing import Annotated

from fastapi import Depends, Request
from fastapi.concurrency import run_in_threadpool

from conformorph.service.core.config import Settings
from conformorph.service.errors import ApiError
from conformorph.service.task_client import AsyncTasks
from conformorph.worker.job_store import JobStore
from conformorph.worker.storage import Storage

#: owner of everything made while no API key exists (loopback-only open mode)
OPEN_OWNER = "open"


async def get_app_settings(request: Request) -> Settings:
    settings: Settings = request.app.state.settings
    return settings


async def get_store(request: Request) -> JobStore:
    store: JobStore = request.app.state.store
    return store


async def get_storage(request: Request) -> Storage:
    storage: Storage = request.app.state.storage
    return storage


async def get_task_client(request: Request) -> AsyncTasks:
    client: AsyncTasks = request.app.state.tasks
    return client


SettingsDep = Annotated[Settings, Depends(get_app_settings)]
StoreDep = Annotated[JobStore, Depends(get_store)]
StorageDep = Annotated[Storage, Depends(get_storage)]
TaskClientDep = Annotated[AsyncTasks, Depends(get_task_client)]


def _is_remote_ip(host: str) -> bool:
    """True for an IP address that is not loopback (names such as test clients are not IPs)."""
    try:
        return not ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class KeyCache:
    """Caches "do keys exist" (keys are never deleted, so True is final; False
    is re-checked after ``open_ttl`` seconds, so a first key created while the
    server runs open is enforced within that time) and recent successful key
    look-ups for ``ttl`` seconds: the job-status hot path then costs one query
    instead of three."""

    def __init__(self, store: JobStore, ttl: float = 30.0, open_ttl: float = 1.0) -> None:
        self.store, self.ttl, self.open_ttl = store, ttl, open_ttl
        self._has_keys = False
        self._checked_at = -1e9
        self._ids: dict[str, tuple[str, float]] = {}
        self._lock = threading.Lock()

    async def any_keys(self) -> bool:
        now = time.monotonic()
        if not self._has_keys and now - self._checked_at >= self.open_ttl:
            self._has_keys = await run_in_threadpool(self.store.count_keys) > 0
            self._checked_at = now
        return self._has_keys

    async def key_id(self, token: str) -> str | None:
        now = time.monotonic()
        hit = self._ids.get(token)
        if hit is not None and hit[1] > now:
            return hit[0]
        kid = await run_in_threadpool(self.store.key_id_for, token)
        if kid is not None:
            with self._lock:
                if len(self._ids) > 10_000:
                    self._ids.clear()
                self._ids[token] = (kid, now + self.ttl)
        return kid


async def get_key_cache(request: Request) -> KeyCache:
    cache: KeyCache = request.app.state.key_cache
    return cache


async def authenticate(authorization: str, client_host: str, keys: KeyCache) -> str:
    """The caller: ``key-<id>`` for a valid Bearer key, ``open`` when no key exists.

    401 when keys exist and none (or an unknown one) is given. With no key at
    all the server is open, to loopback clients only (403 for others), however
    it was started (``conformorph serve`` also refuses a non-loopback address).
    Needs only the request's headers and peer: :class:`conformorph.service.auth_first.AuthFirst`
    calls it before any body is read.
    """
    if not await keys.any_keys():
        if _is_remote_ip(client_host):
            raise ApiError(
                403,
                "forbidden",
                "the server has no API keys and so serves loopback clients only; "
                "create a key with 'conformorph keys create NAME'",
            )
        return OPEN_OWNER
    scheme, _, token = authorization.partition(" ")
    token = token.strip()
    if not hmac.compare_digest(scheme.lower(), "bearer") or not token:
        raise ApiError(
            401,
            "unauthorized",
            "an API key is required: send 'Authorization: Bearer <key>'",
            headers={"WWW-Authenticate": "Bearer"},
        )
    kid = await keys.key_id(token)
    if kid is None:
        raise ApiError(
            401, "unauthorized", "unknown API key", headers={"WWW-Authenticate": "Bearer"}
        )
    return f"key-{kid}"


async def get_owner(request: Request, keys: Annotated[KeyCache, Depends(get_key_cache)]) -> str:
    """The caller (see :func:`authenticate`), as found before the body was read."""
    known = getattr(request.state, "owner", None)
    if isinstance(known, str):
        return known
    host = request.client.host if request.client else ""
    return await authenticate(request.headers.get("authorization", ""), host, keys)


OwnerDep = Annotated[str, Depends(get_owner)]
