"""``conformorph serve``: the API plus real Celery worker processes, no server needed.

With no ``CONFORMORPH_BROKER_URL`` everything lives under one data folder
(``--data-dir`` or ``CONFORMORPH_DATA_DIR``): the job store (SQLite), the
embedded filesystem broker, Celery's results and the artifacts. Three worker
processes are started and restarted if they die: one for jobs; one for the
short upload validations with ``CONFORMORPH_VALIDATION_SLOTS`` pool processes
(so an upload is not stuck behind a long morph, nor behind another key's slow
validation), which also runs the retention cleanup that a timer here sends
every ``CONFORMORPH_CLEANUP_INTERVAL_SECONDS``; and one that sends webhooks
(so a slow receiver never holds a validation) (Celery beat's job on Redis
or RabbitMQ: ``conformorph worker --beat``). With no API key the server runs open, and then only on a loopback address.
"""

from __future__ import annotations

import argparse
import ipaddress
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from conformorph.cli.cmd_worker import ROOT_EXPLAINED_ENV, ROOT_NOTE, SUPERVISOR_ENV

LOOPBACK_NAMES = ("localhost",)


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class WorkerSupervisor:
    """Starts worker subprocesses and restarts any that exits while serving."""

    def __init__(self, commands: list[list[str]], env: dict[str, str]) -> None:
        self.commands, self.env = commands, env
        self.procs: list[subprocess.Popen[bytes] | None] = [None] * len(commands)
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._watch, daemon=True, name="worker-supervisor")

    def _start(self, i: int) -> None:
        self.procs[i] = subprocess.Popen(self.commands[i], env=self.env, start_new_session=True)

    def start(self) -> None:
        for i in range(len(self.commands)):
            self._start(i)
        self.thread.start()

    def _watch(self) -> None:
        while not self.stopping.wait(1.0):
            for i, p in enumerate(self.procs):
                if p is not None and p.poll() is not None and not self.stopping.is_set():
                    print(
                        f"conformorph serve: worker {p.pid} exited with {p.returncode}; restarting",
                        file=sys.stderr,
                    )
                    self._start(i)

    def stop(self, timeout: float = 10.0) -> None:
        self.stopping.set()
        live = [p for p in self.procs if p is not None and p.poll() is None]
        for p in live:
            p.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + timeout
        for p in live:
            try:
                p.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


class CleanupTimer(threading.Thread):
    """Sends the retention cleanup task (``conformorph.cleanup``) every ``interval``
    seconds, the first time ``first`` seconds after start: the embedded set-up's
    stand-in for Celery beat (a worker runs the task, as on Redis or RabbitMQ)."""

    def __init__(self, send: Any, interval: float, first: float = 30.0) -> None:
        super().__init__(daemon=True, name="cleanup-timer")
        self.send, self.interval, self.first = send, float(interval), float(first)
        self.stopping = threading.Event()

    def run(self) -> None:
        wait = min(self.first, self.interval)
        while not self.stopping.wait(wait):
            wait = self.interval
            try:
                self.send()
            except Exception as exc:  # noqa: BLE001 - the broker may be down: try next time
                print(f"conformorph serve: could not send the cleanup: {exc}", file=sys.stderr)


def cleanup_sender(settings: Any) -> Any:
    """A function sending one ``conformorph.cleanup`` task through a thin client app."""
    from conformorph.worker import names
    from conformorph.worker.celery_app import create_celery_app

    app = create_celery_app(settings)
    return lambda: app.send_task(names.CLEANUP, queue=names.QUEUE_INTERACTIVE)


#: how long an idle keep-alive connection stays open. Longer than clients' own idle
#: expiry (httpx: 5 s) and than a load balancer's (60 s is common), so that the client
#: side closes first: uvicorn's 5 s default equals httpx's, and a request sent after a
#: 5 s pause (a 429's Retry-After) could meet a socket the server was just closing.
KEEP_ALIVE_SECONDS = 65

#: the embedded workers' niceness: on the machine they share with the API, their
#: numerics yield the CPU to its requests (issue 30: /healthz p99 under a neighbour's
#: validations; measured by benchmarks/bench_slow_neighbour.py)
WORKER_NICE = 10


def run_serve(args: argparse.Namespace) -> int:
    if args.data_dir:
        os.environ["CONFORMORPH_DATA_DIR"] = str(Path(args.data_dir).expanduser().resolve())
    if not (1 <= args.port <= 65535):
        raise ValueError(f"--port must be 1-65535, got {args.port}")
    if args.worker_nice < 0:
        raise ValueError(f"--worker-nice must be 0 or more, got {args.worker_nice}")
    import uvicorn

    from conformorph.service.core.config import Settings
    from conformorph.service.http_limits import MAX_HEAD_BYTES, LimitedH11Protocol
    from conformorph.service.main import create_app
    from conformorph.worker.job_store import JobStore
    from conformorph.worker.open_storage import describe_storage

    settings = Settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    store = JobStore(settings.resolved_database_url)
    keys = store.count_keys()
    if keys == 0 and not is_loopback(args.host):
        raise ValueError(
            f"no API keys exist, so the server would run open; refusing to listen on {args.host}. "
            "Create one with 'conformorph keys create NAME' or use --host 127.0.0.1"
        )
    env = {
        **os.environ,
        "CONFORMORPH_DATA_DIR": str(settings.data_dir),
        SUPERVISOR_ENV: str(os.getpid()),
        ROOT_EXPLAINED_ENV: "1",  # said once below, not by each worker
    }
    base = [
        *[sys.executable, "-m", "conformorph.cli", "worker", "--loglevel", args.loglevel],
        *["--nice", str(args.worker_nice)],
    ]
    commands = []
    if args.workers > 0:
        commands = [
            [*base, "--queues", "jobs", "--concurrency", str(args.workers), "--name", "jobs"],
            [
                *base,
                "--queues",
                "interactive",
                "--concurrency",
                str(settings.validation_slots),
                "--name",
                "interactive",
            ],
            [*base, "--queues", "webhooks", "--concurrency", "2", "--name", "webhooks"],
        ]
    supervisor = WorkerSupervisor(commands, env)
    print(f"conformorph serve: data in {settings.data_dir}", file=sys.stderr)
    print(
        "conformorph serve: broker "
        + ("embedded (filesystem)" if settings.is_embedded else str(settings.broker_url)),
        file=sys.stderr,
    )
    print(f"conformorph serve: artifacts in {describe_storage(settings)}", file=sys.stderr)
    if keys == 0:
        print(
            "conformorph serve: no API keys exist: running OPEN (no authentication), "
            f"on the loopback address {args.host} only",
            file=sys.stderr,
        )
    if args.workers > 0 and hasattr(os, "geteuid") and os.geteuid() == 0:
        print(f"conformorph serve: {ROOT_NOTE}", file=sys.stderr)
    supervisor.start()
    timer = CleanupTimer(cleanup_sender(settings), settings.cleanup_interval_seconds)
    timer.start()
    try:
        app = create_app(settings, store=store)
        uvicorn.run(
            app,
            host=args.host,
            port=args.port,
            log_level=args.loglevel.lower(),
            access_log=False,
            timeout_keep_alive=KEEP_ALIVE_SECONDS,
            # a limit on the request line and headers (431 beyond; httptools has none)
            http=LimitedH11Protocol,
            h11_max_incomplete_event_size=MAX_HEAD_BYTES,
        )
    finally:
        timer.stopping.set()
        supervisor.stop()
    return 0


def register(sub: Any) -> None:
    """Add the ``serve`` command."""
    p = sub.add_parser("serve", help="run the REST API with embedded workers")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    p.add_argument("--data-dir", help="data folder (default $CONFORMORPH_DATA_DIR)")
    p.add_argument("--loglevel", default="WARNING", help="log level (default WARNING)")
    p.add_argument(
        "--workers",
        type=int,
        default=1,
        help="processes of the job worker (default 1; 0 starts none: run 'conformorph worker')",
    )
    p.add_argument(
        "--worker-nice",
        type=int,
        default=WORKER_NICE,
        help=f"lower the embedded workers' CPU priority by N so the API stays responsive "
        f"while they compute (default {WORKER_NICE}; 0 keeps the API's priority)",
    )
    p.set_defaults(handler=run_serve)
