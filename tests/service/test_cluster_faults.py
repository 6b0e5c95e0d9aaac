"""A request's work on the cluster watches the scheduler's workers (no cluster needed here:
a stand-in client): a scheduler with no worker for NO_WORKERS_S, or one that stops
answering, ends the work with ClusterUnavailable naming the cause, which the service
answers 503 and records, instead of a 504 after PLOTGATE_DASK_TIMEOUT_S."""

import asyncio
import time

import pytest

from plotgate.service import cluster
from plotgate.service.cluster import CONNECT_S, NO_WORKERS_S, ClusterUnavailable

SLOW_S = 3.0  # a busy scheduler's answer: past the 2 s a cleanup waits, within a handshake's
assert SLOW_S < CONNECT_S


class _Scheduler:
    def __init__(self, workers: list[dict[str, int]] | None) -> None:
        self.workers = workers  # what each call reports in turn; None: the scheduler died

    async def ncores(self) -> dict[str, int]:
        if self.workers is None:
            raise OSError("connection refused")
        return self.workers.pop(0) if len(self.workers) > 1 else self.workers[0]


class _SlowScheduler(_Scheduler):
    async def ncores(self) -> dict[str, int]:
        await asyncio.sleep(SLOW_S)  # busy, not dead
        return await super().ncores()


class _Client:
    def __init__(self, workers: list[dict[str, int]] | None, slow: bool = False) -> None:
        self.scheduler = (_SlowScheduler if slow else _Scheduler)(workers)


def _watch(client: _Client) -> tuple[str, float]:
    async def run() -> str:
        with pytest.raises(ClusterUnavailable) as caught:
            await cluster.while_workers(client)
        return str(caught.value)

    started = time.monotonic()
    said = asyncio.run(run())
    return said, time.monotonic() - started


def test_no_worker_ends_the_work_after_the_grace(monkeypatch):
    monkeypatch.setattr(cluster, "_WORKERS_POLL_S", 0.01)
    said, took = _watch(_Client([{}]))
    assert "has had no worker" in said and NO_WORKERS_S <= took < NO_WORKERS_S + 2


def test_a_worker_lost_for_a_moment_is_waited_for(monkeypatch):
    monkeypatch.setattr(cluster, "_WORKERS_POLL_S", 0.01)
    back = [{"w": 1}, {}, {}, {"w": 1}] * 3 + [{}]  # gone for a moment, then for good
    said, took = _watch(_Client(back))
    assert "has had no worker" in said and took >= NO_WORKERS_S


def test_a_dead_scheduler_ends_the_work_at_once():
    said, took = _watch(_Client(None))
    assert "did not report its workers" in said and took < 1


def test_a_scheduler_slow_to_answer_is_not_taken_for_dead(monkeypatch):
    monkeypatch.setattr(cluster, "_WORKERS_POLL_S", 0.01)
    monkeypatch.setattr(cluster, "NO_WORKERS_S", 0.0)
    said, took = _watch(_Client([{"w": 1}, {}], slow=True))
    assert "has had no worker" in said and took >= 2 * SLOW_S
