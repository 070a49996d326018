"""The embedded broker: Celery without any server, all state under the data folder.

kombu's filesystem transport carries messages as files in
``<data_dir>/broker/queue`` (``data_folder_in`` = ``data_folder_out``, so every
process on the machine sees the same queue) and SQLite keeps Celery's results
(``<data_dir>/celery-results.sqlite``, used only by the synchronous upload
validation). Measured on this machine (``../shared/FACTS.md``): a worker is
ready in 0.3-0.6 s and a round trip takes ~0.1 s.

Celery uses :class:`Transport` below, kombu's filesystem transport with atomic
message files. kombu 5.7 creates a message file under its final name and only
then writes it, so a consumer listing the folder in between takes an empty
file, fails to decode it and deletes it: the message is lost while its
producer goes on writing into the unlinked file (celery/kombu#1551 reports the
decode error). A job whose message was lost sat queued until the job store's
queued-lease requeue (15 minutes); the CI run of 2026-12-01 lost one this way.

While idle, each consumer looks at the queue every ``polling_interval`` (50 ms by
default: about 1% of a core per worker process). A job is a chain of stage messages
sent one after another, so for ``busy_seconds`` after a message arrived the consumer
looks every ``busy_polling_interval`` (5 ms) instead: each hop between two stages waits
2.5 ms on average instead of 25 ms, and an idle service still polls slowly
(:meth:`Transport.drain_events`).

This broker never redelivers a message whose worker was SIGKILLed; the job
store's lease and requeue (``worker/job_store/leases.py``, ``worker/requeue.py``)
provide that instead.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path
from queue import Empty
from time import monotonic, sleep
from typing import Any

from kombu.exceptions import ChannelError
from kombu.transport import filesystem
from kombu.utils.encoding import bytes_to_str, str_to_bytes
from kombu.utils.json import dumps, loads

#: ``broker_transport`` of the embedded set-up (the URL stays ``filesystem://``)
EMBEDDED_TRANSPORT = "conformorph.worker.embedded:Transport"
#: seconds between looks at the queue for ``BUSY_SECONDS`` after a message arrived
BUSY_POLLING_INTERVAL = 0.005
#: how long a consumer keeps looking every ``BUSY_POLLING_INTERVAL`` after a message
BUSY_SECONDS = 30.0


def embedded_broker_folders(broker_dir: Path) -> dict[str, Path]:
    """The folders of the filesystem transport, created if missing.

    ``staging`` holds message files while they are written and ``processed``
    those being read; both sit beside ``queue`` on the same filesystem, so the
    moves between them are atomic renames.
    """
    folders = {
        "queue": broker_dir / "queue",
        "staging": broker_dir / "staging",
        "processed": broker_dir / "processed",
        "control": broker_dir / "control",
    }
    for p in folders.values():
        p.mkdir(parents=True, exist_ok=True)
    return folders


def embedded_transport_options(broker_dir: Path, polling_interval: float) -> dict[str, Any]:
    """``broker_transport_options`` for :class:`Transport` rooted at ``broker_dir``."""
    f = embedded_broker_folders(Path(broker_dir).resolve())
    return {
        "data_folder_in": str(f["queue"]),
        "data_folder_out": str(f["queue"]),
        "staging_folder": str(f["staging"]),
        "processed_folder": str(f["processed"]),
        "store_processed": False,
        "control_folder": str(f["control"]),
        "polling_interval": float(polling_interval),
        "busy_polling_interval": min(BUSY_POLLING_INTERVAL, float(polling_interval)),
        "busy_seconds": BUSY_SECONDS,
    }


class Channel(filesystem.Channel):
    """The filesystem channel with messages that appear whole and are taken once.

    ``_put`` writes the message in the staging folder and renames it into the
    queue, so a reader never sees a partial file. ``_get`` renames a queued file
    into the processed folder before reading it: of several consumers exactly
    one rename succeeds (kombu's own ``shutil.move`` to the system temporary
    folder copies when that folder is on another filesystem, and two copies can
    both succeed).
    """

    # kombu's own base classes disagree on this signature (message vs payload, **kwargs)
    def _put(self, queue: Any, payload: Any, **kwargs: Any) -> None:  # type: ignore[override]
        name = f"{int(round(monotonic() * 1000))}_{uuid.uuid4()}.{queue}.msg"
        staging = Path(self.transport_options.get("staging_folder", self.data_folder_out))
        tmp = staging / f"{name}.part"
        try:
            tmp.write_bytes(str_to_bytes(dumps(payload)))
            os.replace(tmp, Path(self.data_folder_out) / name)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise ChannelError(f"Cannot add file {name!r} to the queue") from exc

    def _get(self, queue: Any, timeout: Any = None) -> Any:
        suffix = f"{queue}.msg"
        folder = Path(self.data_folder_in)
        processed = Path(self.processed_folder)
        for name in sorted(os.listdir(folder)):
            if name.partition(".")[2] != suffix:
                continue
            taken = processed / name
            try:
                os.rename(folder / name, taken)
            except OSError:
                continue  # another consumer took it first
            try:
                payload = taken.read_bytes()
            except OSError as exc:
                raise ChannelError(f"Cannot read file {name!r} from queue") from exc
            if not self.store_processed:
                taken.unlink(missing_ok=True)
            return loads(bytes_to_str(payload))
        raise Empty()


class Transport(filesystem.Transport):
    """kombu's filesystem transport with :class:`Channel`'s atomic message files.

    A folder has no host: no default hostname either, so kombu does not log "No
    hostname was supplied. Reverting to default 'localhost'" on every connection
    (four lines per ``conformorph serve`` start before).
    """

    Channel = Channel

    #: monotonic time of the last message this transport delivered (-inf: none yet)
    _last_delivery = float("-inf")

    @property
    def default_connection_params(self) -> dict[str, Any]:
        return {}

    def polling_interval_now(self, now: float) -> float:
        """Seconds to wait before the next look at an empty queue: the busy interval
        within ``busy_seconds`` of the last delivery, else ``polling_interval``."""
        opts: dict[str, Any] = self.client.transport_options if self.client is not None else {}
        idle = float(self.polling_interval)
        busy = min(float(opts.get("busy_polling_interval", idle)), idle)
        recent = now - self._last_delivery < float(opts.get("busy_seconds", 0.0))
        return busy if recent else idle

    # kombu's own base classes disagree on this signature (timeout vs **kwargs)
    def drain_events(self, connection: Any, timeout: Any = None) -> None:  # type: ignore[override]
        """Deliver one message, waiting up to ``timeout`` seconds (kombu's loop with
        :meth:`polling_interval_now` between the looks)."""
        start = monotonic()
        assert self.cycle is not None  # set when the transport is created
        while True:
            try:
                self.cycle.get(self._deliver, timeout=timeout)
            except Empty:
                now = monotonic()
                if timeout is not None and now - start >= timeout:
                    raise TimeoutError() from None
                wait = self.polling_interval_now(now)
                sleep(min(wait, timeout) if timeout else wait)
            else:
                self._last_delivery = monotonic()
                return
