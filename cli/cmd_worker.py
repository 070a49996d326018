"""``conformorph worker``: a Celery worker for conformorph's jobs.

All settings come from ``CONFORMORPH_*`` environment variables (broker, job
store, data folder); the options here override the common ones. With no
``CONFORMORPH_BROKER_URL`` it joins the embedded filesystem broker of the data
folder, so several workers on one machine share one queue.
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import sys
import threading
import time
from typing import Any

from conformorph.worker import names

QUEUE_ALIASES = {
    "jobs": names.QUEUE_JOBS,
    "interactive": names.QUEUE_INTERACTIVE,
    "webhooks": names.QUEUE_WEBHOOKS,
}


def worker_argv(args: argparse.Namespace) -> list[str]:
    """The ``celery worker`` arguments for these options."""
    queues = [QUEUE_ALIASES.get(q.strip(), q.strip()) for q in args.queues.split(",") if q.strip()]
    if not queues:
        raise ValueError("--queues must name at least one queue (jobs, interactive, webhooks)")
    if args.concurrency < 1:
        raise ValueError("--concurrency must be at least 1")
    name = args.name or f"conformorph-{'-'.join(q.split('-')[-1] for q in queues)}-{os.getpid()}"
    return [
        "worker",
        "--queues",
        ",".join(queues),
        "--concurrency",
        str(args.concurrency),
        "--prefetch-multiplier",
        "1",
        "--without-mingle",
        "--without-gossip",
        "--loglevel",
        args.loglevel,
        "--hostname",
        f"{name}@{socket.gethostname()}",
        *(["--beat"] if getattr(args, "beat", False) else []),
    ]


def lower_priority(nice: int) -> None:
    """Raise this process's niceness by ``nice`` (0: unchanged; negative is refused).

    Inherited by the Celery pool's processes and the validation subprocesses they
    start, so that on a machine shared with the API (``conformorph serve``) the
    workers' numerics yield the CPU to the API's requests: the API answers while
    the workers compute (issue 30: ``/healthz`` and status reads stay fast while a
    neighbour's uploads are validated).
    """
    if nice < 0:
        raise ValueError(f"--nice must be 0 or more (a lower priority), got {nice}")
    if nice and hasattr(os, "nice"):
        os.nice(nice)


def run_worker(args: argparse.Namespace) -> int:
    argv = worker_argv(args)
    lower_priority(args.nice)
    if args.data_dir:
        os.environ["CONFORMORPH_DATA_DIR"] = str(args.data_dir)
    # BLAS threads are limited by conformorph.cli.main before numpy is imported (limit_blas_threads)
    supervisor = os.environ.pop(SUPERVISOR_ENV, "")
    if supervisor.isdigit():
        _exit_with_supervisor(int(supervisor))
    explain_superuser()
    from conformorph.worker.celery_app import get_app

    app = get_app()
    app.worker_main(argv)
    return 0


#: set by ``conformorph serve`` once it has said the worker runs as root
ROOT_EXPLAINED_ENV = "CONFORMORPH_ROOT_EXPLAINED"
ROOT_NOTE = (
    "running as root: the workers accept JSON messages only (never pickle), so Celery allows "
    "it, but a service should run as an unprivileged user (in the container image it does)"
)


def explain_superuser() -> None:
    """Replace Celery's superuser ``SecurityWarning`` (ten lines per worker) by one line.

    Celery warns when a worker runs as root; its danger is executing pickled messages,
    which this app never accepts (``accept_content=["json"]``). The warning is filtered
    for this process and, unless ``conformorph serve`` has said it already
    (:data:`ROOT_EXPLAINED_ENV`), :data:`ROOT_NOTE` is printed once instead.
    """
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return
    import warnings

    warnings.filterwarnings(
        "ignore", message=r"You're running the worker with superuser privileges"
    )
    if os.environ.get(ROOT_EXPLAINED_ENV) != "1":
        print(f"conformorph worker: {ROOT_NOTE}", file=sys.stderr)


#: set by ``conformorph serve``: the worker shuts down when that process is gone
SUPERVISOR_ENV = "CONFORMORPH_SUPERVISOR_PID"


def _exit_with_supervisor(pid: int) -> None:
    """Warm-shut this worker down (SIGTERM to itself) once process ``pid`` has died,
    so a ``serve`` that is SIGKILLed leaves no orphaned workers behind."""

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != pid:
                os.kill(os.getpid(), signal.SIGTERM)
                return

    threading.Thread(target=watch, daemon=True, name="supervisor-watch").start()


def add_worker_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data-dir", help="data folder (default $CONFORMORPH_DATA_DIR)")
    p.add_argument(
        "--queues",
        default="jobs,interactive,webhooks",
        help="comma-separated: jobs, interactive, webhooks (default all three)",
    )
    p.add_argument("--concurrency", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--loglevel", default="INFO", help="log level (default INFO)")
    p.add_argument("--name", help="worker name (default derived from queues and pid)")
    p.add_argument(
        "--nice",
        type=int,
        default=0,
        help="lower this worker's CPU priority by N (os.nice; default 0, unchanged); "
        "'conformorph serve' starts its workers with --nice 10",
    )
    p.add_argument(
        "--beat",
        action="store_true",
        help="also run Celery beat in this worker, which sends the retention cleanup every "
        "CONFORMORPH_CLEANUP_INTERVAL_SECONDS (exactly one process of a deployment should)",
    )


def register(sub: Any) -> None:
    """Add the ``worker`` command."""
    p = sub.add_parser("worker", help="run a Celery worker (embedded broker or Redis)")
    add_worker_options(p)
    p.set_defaults(handler=run_worker)
