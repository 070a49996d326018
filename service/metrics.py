"""Prometheus metrics at ``/metrics`` on the API's own port (never behind the API key).

* ``conformorph_http_requests_total{method, route, status}`` and
  ``conformorph_http_request_duration_seconds{method, route}``: every request,
  by route template (``/v1/jobs/{job_id}``, ``<unmatched>`` for no route), timed
  until its response ends (an event stream: until it closes). Every label takes
  a bounded set of values whatever clients send: a non-standard method is
  ``OTHER``.
* Read from the job store at scrape time, so they cover every worker on every
  host without any metrics state in the workers: ``conformorph_jobs{kind, state}``,
  ``conformorph_stage_duration_seconds{kind, stage}`` (each stage's last run,
  written by the worker when the stage ends) and
  ``conformorph_stage_failures_total{kind, stage, type}`` (failed jobs by the
  stage and error type of their ``error``), over the jobs on record: deleting
  jobs lowers them, which Prometheus reads as a counter reset;
  ``conformorph_job_store_up`` is 0 when the store did not answer.
* ``conformorph_cleanup_freed_total{what}``: jobs, uploads and bytes the
  retention cleanup deleted (``worker/retention.py``), summed in the job store.
* ``conformorph_queue_depth{queue}``: messages waiting on the Redis or RabbitMQ
  queues (not for the embedded broker).

``CONFORMORPH_METRICS_ENABLED=false`` turns all of it off (``/metrics`` is then
an ordinary unknown path).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

import anyio
from kombu.exceptions import ChannelError
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram
from prometheus_client.core import (
    CounterMetricFamily,
    GaugeMetricFamily,
    HistogramMetricFamily,
    Metric,
)
from prometheus_client.exposition import generate_latest
from prometheus_client.registry import Collector
from starlette.routing import Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from conformorph.worker.job_store import JobStore

log = logging.getLogger(__name__)

METRICS_PATH = "/metrics"
UNMATCHED = "<unmatched>"
#: request latency buckets in seconds (uploads and validations take seconds)
HTTP_BUCKETS = (0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0)
#: stage duration buckets in seconds (up to the default hard time limit, 960 s)
STAGE_BUCKETS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 960.0)

QueueDepths = Callable[[], dict[str, int]]

#: the request methods counted by name; any other token a client sends is counted as OTHER
HTTP_METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS", "TRACE"})
OTHER_METHOD = "OTHER"


def method_label(method: str) -> str:
    """The ``method`` label: a standard method as it is, anything else ``OTHER``.

    The method token is the client's choice (``FOO``, a random string per
    request): used as a label as it is, 5,000 random tokens grew ``/metrics``
    from 96 KB to 11 MB (issue 30). Every label here takes a bounded set of values.
    """
    return method if method in HTTP_METHODS else OTHER_METHOD


def status_label(status: int) -> str:
    """The ``status`` label: the code when it is an HTTP status (100-599), else ``other``."""
    return str(status) if 100 <= status <= 599 else "other"


def broker_queue_depths(celery_app: Any, queues: Sequence[str]) -> dict[str, int]:
    """Messages waiting on each queue, asked of the broker (Redis or RabbitMQ).

    A passive declare answers the ready-message count on both (kombu sums
    Redis's priority lists); a queue the broker does not know (never declared
    on RabbitMQ; empty on Redis, which deletes empty lists) has none waiting.

    Parameters
    ----------
    celery_app : celery.Celery
        The API's Celery app (its broker connection settings).
    queues : sequence of str

    Returns
    -------
    dict
        Queue name → waiting messages.
    """
    out: dict[str, int] = {}
    with celery_app.connection_for_read() as conn:
        conn.ensure_connection(max_retries=1, timeout=2.0)
        for queue in queues:
            try:
                with conn.channel() as channel:
                    ok = channel.queue_declare(queue=queue, passive=True)
                    out[queue] = int(ok.message_count)
            except ChannelError:  # NOT_FOUND: nothing waits there
                out[queue] = 0
    return out


def _bucket_counts(values: list[float]) -> list[tuple[str, float]]:
    """Cumulative histogram buckets of ``values`` over :data:`STAGE_BUCKETS` and +Inf."""
    counts = [(str(b), float(sum(v <= b for v in values))) for b in STAGE_BUCKETS]
    return [*counts, ("+Inf", float(len(values)))]


class JobStoreCollector(Collector):
    """Job, stage and queue metrics read at scrape time (see the module docstring)."""

    def __init__(self, store: JobStore, depths: QueueDepths | None = None) -> None:
        self.store, self.depths = store, depths

    def collect(self) -> Iterable[Metric]:
        up = GaugeMetricFamily("conformorph_job_store_up", "1 when the job store answered")
        try:
            stats = self.store.job_stats()
        except Exception:  # noqa: BLE001 - a scrape reports the outage instead of failing
            log.warning("metrics: the job store did not answer", exc_info=True)
            up.add_metric([], 0.0)
            yield up
        else:
            up.add_metric([], 1.0)
            yield up
            jobs = GaugeMetricFamily(
                "conformorph_jobs", "Jobs on record by kind and state", labels=["kind", "state"]
            )
            for (kind, state), n in sorted(stats.by_kind_state.items()):
                jobs.add_metric([kind, state], float(n))
            yield jobs
            stages = HistogramMetricFamily(
                "conformorph_stage_duration_seconds",
                "Duration of each job's last run of a stage, by kind and stage",
                labels=["kind", "stage"],
            )
            for (kind, stage), secs in sorted(stats.stage_seconds.items()):
                stages.add_metric([kind, stage], _bucket_counts(secs), sum_value=sum(secs))
            yield stages
            failures = CounterMetricFamily(
                "conformorph_stage_failures",
                "Failed jobs by kind, failing stage and error type",
                labels=["kind", "stage", "type"],
            )
            for (kind, stage, etype), n in sorted(stats.failures.items()):
                failures.add_metric([kind, stage, etype], float(n))
            yield failures
            yield from self._cleanup_totals()
        if self.depths is not None:
            yield from self._queue_depths()

    def _cleanup_totals(self) -> Iterable[Metric]:
        try:
            totals = self.store.cleanup_totals()
        except Exception:  # noqa: BLE001 - a scrape reports what it can
            log.warning("metrics: could not read the cleanup totals", exc_info=True)
            return
        freed = CounterMetricFamily(
            "conformorph_cleanup_freed",
            "What the retention cleanup deleted since the job store was created "
            "(what: jobs, uploads, bytes)",
            labels=["what"],
        )
        for what in ("jobs", "uploads", "bytes"):
            freed.add_metric([what], float(totals.get(what, 0)))
        yield freed

    def _queue_depths(self) -> Iterable[Metric]:
        assert self.depths is not None
        try:
            depths = self.depths()
        except Exception:  # noqa: BLE001 - broker unreachable: no depth samples
            log.warning("metrics: the broker did not answer", exc_info=True)
            return
        depth = GaugeMetricFamily(
            "conformorph_queue_depth", "Messages waiting on a broker queue", labels=["queue"]
        )
        for queue, n in sorted(depths.items()):
            depth.add_metric([queue], float(n))
        yield depth


class ServiceMetrics:
    """The API's registry: request metrics plus :class:`JobStoreCollector`."""

    def __init__(self, store: JobStore, depths: QueueDepths | None = None) -> None:
        self.registry = CollectorRegistry(auto_describe=False)
        self.requests = Counter(
            "conformorph_http_requests",
            "HTTP requests by method, route template and status",
            ["method", "route", "status"],
            registry=self.registry,
        )
        self.latency = Histogram(
            "conformorph_http_request_duration_seconds",
            "HTTP request latency by method and route template, until the response ends",
            ["method", "route"],
            buckets=HTTP_BUCKETS,
            registry=self.registry,
        )
        self.registry.register(JobStoreCollector(store, depths))

    def observe(self, method: str, route: str, status: int, seconds: float) -> None:
        """Count and time one request under bounded labels (:func:`method_label`,
        :func:`status_label`; ``route`` is a template of ours or ``<unmatched>``)."""
        method = method_label(method)
        self.requests.labels(method, route, status_label(status)).inc()
        self.latency.labels(method, route).observe(seconds)

    def exposition(self) -> bytes:
        """The text exposition format of every metric."""
        return generate_latest(self.registry)


def _leaf_routes(routes: Iterable[Any]) -> Iterator[Any]:
    """The routes themselves, looking into included routers (FastAPI wraps them)."""
    for route in routes:
        inner = getattr(route, "original_router", None)
        if inner is not None:
            yield from _leaf_routes(inner.routes)
        else:
            yield route


def route_template(app: Any, scope: Scope) -> str:
    """The template of the route that served (or would serve) ``scope``."""
    route = scope.get("route")
    if route is None:  # answered before routing (authentication, body limit): match it
        for candidate in _leaf_routes(app.router.routes):
            match, _ = candidate.matches(scope)
            if match == Match.FULL:
                route = candidate
                break
    path = getattr(route, "path_format", None) or getattr(route, "path", None)
    return str(path) if path else UNMATCHED


class MetricsMiddleware:
    """ASGI middleware, outermost: serves ``/metrics`` and times every other request."""

    def __init__(self, app: ASGIApp, *, metrics: ServiceMetrics, fastapi_app: Any) -> None:
        self.app, self.metrics, self.fastapi_app = app, metrics, fastapi_app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        method = str(scope.get("method", ""))
        if scope.get("path") == METRICS_PATH:
            await self._serve(method, send)
            return
        start, status = time.perf_counter(), 500

        async def timed_send(msg: Message) -> None:
            nonlocal status
            if msg["type"] == "http.response.start":
                status = int(msg["status"])
            await send(msg)

        try:
            await self.app(scope, receive, timed_send)
        finally:
            route = route_template(self.fastapi_app, scope)
            self.metrics.observe(method, route, status, time.perf_counter() - start)

    async def _serve(self, method: str, send: Send) -> None:
        if method not in ("GET", "HEAD"):
            status, body, ctype = 405, b"method not allowed\n", "text/plain; charset=utf-8"
        else:  # the collector queries the job store and the broker: off the event loop
            status, body, ctype = (
                200,
                await anyio.to_thread.run_sync(self.metrics.exposition),
                (CONTENT_TYPE_LATEST),
            )
        headers = [(b"content-type", ctype.encode()), (b"content-length", str(len(body)).encode())]
        if status == 405:
            headers.append((b"allow", b"GET, HEAD"))
        await send({"type": "http.response.start", "status": status, "headers": headers})
        await send({"type": "http.response.body", "body": b"" if method == "HEAD" else body})
