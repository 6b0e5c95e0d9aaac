"""Prometheus metrics of the service (``GET /metrics``; prometheus_client, text format).

Per operation: ``plotgate_requests_total{operation, status}`` and the latency histogram
``plotgate_request_duration_seconds{operation}`` (body read, operation and recording, as
the client waits). The recorder: ``plotgate_recorder_records_total`` (records handed to
the OS), ``plotgate_recorder_bytes_total``, ``plotgate_recorder_files_rotated_total``,
``plotgate_recorder_queue_depth`` (records added, waiting for their flush),
``plotgate_recorder_ready`` and the flush-latency histogram
``plotgate_recorder_flush_seconds``; with a live view (``--foxglove-port``),
``plotgate_foxglove_published_total`` and ``plotgate_foxglove_dropped_total{reason}``;
with best-effort recording, ``plotgate_unrecorded_total{operation}``. The process:
prometheus_client's default collectors, ``process_*`` (CPU seconds, resident memory, open
file descriptors, start time), ``python_info`` and ``python_gc_*`` (collections and the
objects they freed, by generation). Each app has its own registry, so several apps in one
process (tests) never share counters.
"""

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

from prometheus_client import (
    CollectorRegistry,
    Counter,
    GCCollector,
    Histogram,
    PlatformCollector,
    ProcessCollector,
    generate_latest,
)
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector

from plotgate.service.recording import Recorder

if TYPE_CHECKING:  # foxglove-sdk is imported only with a live view
    from plotgate.service.scenes.live import LiveView

__all__ = ["CONTENT_TYPE", "Metrics"]

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"
_LATENCY_BUCKETS = (
    0.0005,
    0.001,
    0.0025,
    0.005,
    0.01,
    0.02,
    0.05,
    0.1,
    0.25,
    0.5,
    1.0,
    2.5,
    5.0,
    10.0,
    30.0,
    60.0,
    300.0,
)


class _RecorderCollector(Collector):
    """Reads the recorder's counters at scrape time."""

    def __init__(self, recorder: Callable[[], Recorder | None]) -> None:
        self.recorder = recorder

    def collect(self) -> Iterator[Metric]:
        recorder = self.recorder()
        if recorder is None:
            return
        yield CounterMetricFamily(
            "plotgate_recorder_records", "Records handed to the OS.", value=recorder.records
        )
        yield CounterMetricFamily(
            "plotgate_recorder_bytes", "Bytes written to MCAP files.", value=recorder.bytes_written
        )
        yield CounterMetricFamily(
            "plotgate_recorder_files_rotated",
            "Files closed for size, age or chunk count.",
            value=recorder.rotations,
        )
        yield GaugeMetricFamily(
            "plotgate_recorder_queue_depth",
            "Records added and waiting for their flush.",
            value=recorder.pending,
        )
        yield GaugeMetricFamily(
            "plotgate_recorder_ready",
            "1 while records can be written.",
            value=float(recorder.ready),
        )


class _LiveCollector(Collector):
    """Reads the live view's counters at scrape time (nothing without one)."""

    def __init__(self, live: Callable[[], "LiveView | None"]) -> None:
        self.live = live

    def collect(self) -> Iterator[Metric]:
        live = self.live()
        if live is None:
            return
        yield CounterMetricFamily(
            "plotgate_foxglove_published",
            "Exchanges handed to the Foxglove live view's publisher.",
            value=live.published,
        )
        dropped = CounterMetricFamily(
            "plotgate_foxglove_dropped",
            "Exchanges the live view did not show, by reason: queue_full (the publisher "
            "behind), too_large (a record over 1 MiB), no_publisher (it failed or died).",
            labels=["reason"],
        )
        for reason, count in live.dropped.items():
            dropped.add_metric([reason], count)
        yield dropped
        yield from _live_clients(live)


def _live_clients(live: "LiveView") -> Iterator[Metric]:
    """The live view gate's counters: clients, refusals, scenes dropped for slow clients."""
    yield GaugeMetricFamily(
        "plotgate_foxglove_clients", "Live view clients connected now.", value=live.clients
    )
    refused = CounterMetricFamily(
        "plotgate_foxglove_refused",
        "Live view clients refused, by reason: key (no key or a wrong one), full (the "
        "connection cap, PLOTGATE_LIVE_MAX_CLIENTS).",
        labels=["reason"],
    )
    for reason, count in live.refused.items():
        refused.add_metric([reason], count)
    yield refused
    yield CounterMetricFamily(
        "plotgate_foxglove_client_dropped",
        "Scenes dropped from a slow live view client's backlog (the oldest first).",
        value=live.client_dropped,
    )


class Metrics:
    """The registry of one app, the request counters the routes update and the flush
    histogram the recorder observes (``Recorder(on_flush=metrics.flush.observe)``)."""

    def __init__(
        self,
        recorder: Callable[[], Recorder | None],
        live: Callable[[], "LiveView | None"] = lambda: None,
    ) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter(
            "plotgate_requests",
            "Requests answered, by operation and status.",
            ["operation", "status"],
            registry=self.registry,
        )
        self.latency = Histogram(
            "plotgate_request_duration_seconds",
            "Time to answer, by operation, s.",
            ["operation"],
            buckets=_LATENCY_BUCKETS,
            registry=self.registry,
        )
        self.unrecorded_total = Counter(
            "plotgate_unrecorded",
            "Exchanges answered without a complete record (best-effort recording only).",
            ["operation"],
            registry=self.registry,
        )
        self.flush = Histogram(
            "plotgate_recorder_flush_seconds",
            "Duration of a recorder flush, s.",
            buckets=_LATENCY_BUCKETS,
            registry=self.registry,
        )
        self.registry.register(_RecorderCollector(recorder))
        self.registry.register(_LiveCollector(live))
        ProcessCollector(registry=self.registry)
        PlatformCollector(registry=self.registry)
        GCCollector(registry=self.registry)
        self._answered: dict[tuple[str, int], Callable[[float], None]] = {}

    def observe(self, operation: str, status: int, seconds: float) -> None:
        """Count one answered request (the labelled children are looked up once per
        operation and status, not per request)."""
        key = (operation, status)
        if key not in self._answered:
            count = self.requests.labels(operation, str(status))
            latency = self.latency.labels(operation)

            def answered(seconds: float) -> None:
                count.inc()
                latency.observe(seconds)

            self._answered[key] = answered
        self._answered[key](seconds)

    def unrecorded(self, operation: str) -> None:
        """Count an exchange answered although its record could not be written."""
        self.unrecorded_total.labels(operation).inc()

    def render(self) -> bytes:
        """The text exposition of every metric."""
        return generate_latest(self.registry)
