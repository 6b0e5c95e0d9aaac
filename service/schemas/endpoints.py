"""What an operation declaration holds (:class:`Endpoint`), and the budgets its caps keep.

Each capability declares its operations in :mod:`plotgate.service.capabilities`, and
:mod:`plotgate.service.table` gathers them: clients read that table to call the service
without importing it, and the registry (:mod:`plotgate.service.registry`) resolves each
declaration's handler when it is first used.
"""

import copy
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel

__all__ = ["CLUSTER_BUDGET_S", "MEMORY_BUDGET_MIB", "TIME_BUDGET_S", "Endpoint", "Reference"]

MEMORY_BUDGET_MIB = 1024
"""The peak RSS, MiB, a server process stays under while it answers the largest request
its default caps accept (:attr:`Endpoint.caps`; ``bench/bench_worst_requests.py``
measures each operation's worst request in a fresh process)."""
TIME_BUDGET_S = 10.0
"""The wall time, s, on one core, that the largest request the default caps accept stays
under (``bench/bench_worst_requests.py`` searches each operation's slowest one)."""
CLUSTER_BUDGET_S = 300.0
"""The time, s, one request may keep each worker thread of a Dask cluster busy: the
default ``PLOTGATE_DASK_TIMEOUT_S``. A chunked operation's cluster cap is its one-core cap
times ``CLUSTER_BUDGET_S / TIME_BUDGET_S`` per worker thread (:meth:`Endpoint.cluster_cap`),
so a request the cluster takes can finish before the service's timeout."""


@dataclass(frozen=True)
class Reference:
    """A module attribute named, not imported: ``load`` imports it on first use, so the
    table of operations stays cheap to import (no core, no FastAPI, no foxglove-sdk)."""

    module: str
    name: str

    def load(self) -> Any:
        """The attribute, importing its module."""
        return getattr(importlib.import_module(self.module), self.name)


@dataclass(frozen=True)
class Endpoint:
    """One operation as seen from the wire.

    ``work`` names the sizes of a request an operator may cap per operation (plots per
    scan, problems per batch, Monte Carlo runs, curve points, mean clutter plots per
    simulated scan, the axis ratio of the marks' error ellipse that sets the cost of an
    unconditional gating probability...). ``slow`` marks an
    operation that may compute for seconds (unconditional
    probabilities, curves, gate design) or for more than ~50 ms at its size limits
    (the multistatic solves and bounds): the server runs it off the event loop and
    clients give it a longer timeout.
    """

    name: str
    path: str
    summary: str
    request: type[BaseModel]
    response: type[BaseModel]
    slow: bool = False
    work: dict[str, Callable[[Any], int]] = field(default_factory=dict)
    """The sizes a server may limit below the schema's own bounds (``PLOTGATE_LIMITS``):
    name (the request field it counts; ``a x b`` for a product of two) -> its value for a
    validated request."""
    caps: dict[str, int] = field(default_factory=dict)
    """Default caps on some of the ``work`` sizes: those whose memory or time grows faster
    than the body (a matrix of passive x active tracks, runs x samples, a smoothing window
    fitted at every sample), each set so that the largest request they accept keeps the
    process under :data:`MEMORY_BUDGET_MIB` (measured by ``bench/bench_worst_requests.py``).
    An operator's ``PLOTGATE_LIMITS`` lowers or raises any of them (:func:`work_caps`)."""
    cluster_caps: dict[str, int] = field(default_factory=dict)
    """For an operation whose work runs in chunks on a Dask cluster when the service has
    one: the hard ceiling of each default cap that a cluster widens
    (:meth:`cluster_cap`). A ceiling bounds what the cluster cannot spread: the results
    gathered in the service's memory and the chunks' count."""
    handler: Reference = field(kw_only=True)
    """The pure function ``(request) -> response`` that calls core, in
    :mod:`plotgate.service.operations`."""
    fields: Reference = field(kw_only=True)
    """Where core's errors point in the request (a :data:`plotgate.service.fields.FieldMap`)."""
    drawer: Reference | None = field(default=None, kw_only=True)
    """The scene drawing ``(canvas, request body, result)`` of :mod:`plotgate.service.scenes`
    (without one, ``view`` logs that it cannot draw the operation's exchanges)."""
    batch_drawer: Reference | None = field(default=None, kw_only=True)
    """A :class:`plotgate.service.scenes.batched.BatchDrawer` that draws many of the
    operation's exchanges at once from their recorded bytes, to the same bytes as
    ``drawer`` one at a time (``view``'s fast path; without one, every exchange goes
    through ``drawer``)."""
    client_method: str | None = field(default=None, kw_only=True)
    """The typed method of :class:`plotgate.clients.client.Client` that calls it (without
    one, ``Client.call`` runs the operation by name)."""
    description: str = field(kw_only=True)
    """What the operation computes, its paper and equation, its units (markdown; the OpenAPI
    document adds the example after it)."""
    example_body: dict[str, Any] = field(kw_only=True)
    """One small, valid request: the OpenAPI example and the fuzzers' seed; it answers 200 in
    a few tens of milliseconds in-process (paper's worked cases where there is one)."""

    def __post_init__(self) -> None:
        unknown = set(self.caps) - set(self.work)
        if unknown:
            raise ValueError(f"{self.name}: default caps on sizes it lacks: {sorted(unknown)}")
        if set(self.cluster_caps) - set(self.caps):
            raise ValueError(f"{self.name}: cluster ceilings on sizes without a default cap")

    def cluster_cap(self, size: str, workers: int) -> int:
        """The cap on ``size`` with a Dask cluster of ``workers`` worker threads: the one-core
        default times ``CLUSTER_BUDGET_S / TIME_BUDGET_S`` per thread, never under the
        default nor over the ceiling (:attr:`cluster_caps`)."""
        default = self.caps[size]
        widened = default * workers * round(CLUSTER_BUDGET_S / TIME_BUDGET_S)
        return min(self.cluster_caps[size], max(default, widened))

    @property
    def tag(self) -> str:
        return self.name.split(".")[0]

    @property
    def example(self) -> dict[str, Any]:
        """A small valid request body (:attr:`example_body`), a copy."""
        return copy.deepcopy(self.example_body)
