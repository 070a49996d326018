"""The embedded broker: Celery without any server, all state under the data folder.

kombu's filesystem transport carries messages as files in
``<data_dir>/broker/queue`` (``data_folder_in`` = ``data_folder_out``, so every
process on the machine sees the same queue) and SQLite keeps Celery's results
(``<data_dir>/celery-results.sqlite``, used only by the synchronous upload
validation). Measured on this machine (``../shared/FACTS.md``): a worker is
ready in 0.3-0.6 s and a round trip takes ~0.1 s.

This broker never redelivers a message whose worker was SIGKILLed; the job
store's lease and requeue (``worker/job_store.py``, ``worker/requeue.py``)
provide that instead.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def embedded_broker_folders(broker_dir: Path) -> dict[str, Path]:
    """The folders of the filesystem transport, created if missing."""
    folders = {
        "queue": broker_dir / "queue",
        "processed": broker_dir / "processed",
        "control": broker_dir / "control",
    }
    for p in folders.values():
        p.mkdir(parents=True, exist_ok=True)
    return folders


def embedded_transport_options(broker_dir: Path, polling_interval: float) -> dict[str, Any]:
    """``broker_transport_options`` for ``filesystem://`` rooted at ``broker_dir``."""
    f = embedded_broker_folders(Path(broker_dir).resolve())
    return {
        "data_folder_in": str(f["queue"]),
        "data_folder_out": str(f["queue"]),
        "processed_folder": str(f["processed"]),
        "store_processed": False,
        "control_folder": str(f["control"]),
        "polling_interval": float(polling_interval),
    }
