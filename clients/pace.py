"""Replay at the recorded pace (``plotgate replay --server URL --pace 1x|2x|max``): a load
test from real traffic. Open loop: each exchange is sent at its recorded arrival time, from
the first one's, divided by the speed (``max``: at once), whether or not earlier answers have
come back, from a pool of :data:`MAX_IN_FLIGHT` sending threads. The outcomes are handed on
in the order the exchanges were read, so the tally is the serial replay's.

Exchanges come in the order their answers were recorded, so one that took long is sent
after those answered before it: its lateness is counted like any other. An exchange sent
more than :data:`LATE_S` after its time is *behind*: the report says how many and the worst
lag, since a load test whose sender fell behind did not send the load it claims.
"""

import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

__all__ = ["LATE_S", "MAX_IN_FLIGHT", "Pacing", "paced", "speed_of"]

MAX_IN_FLIGHT = 64
"""Exchanges sent and not yet answered, at most (the bound of the open loop)."""
LATE_S = 0.05
"""An exchange sent later than this after its time is counted behind."""


def speed_of(text: str) -> float:
    """``1x``, ``2x``, ``0.5x`` ... or ``max`` (infinite) as a speed; ValueError otherwise."""
    if text == "max":
        return float("inf")
    speed = float(text.removesuffix("x")) if text.endswith("x") else 0.0
    if not 0 < speed < float("inf"):
        raise ValueError(f"--pace takes 1x, 2x, ... or max, got {text!r}")
    return speed


@dataclass
class Pacing:
    """How the sending kept to the recorded pace."""

    speed: float
    sent: int = 0
    behind: int = 0
    worst_lag_s: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "speed": "max" if self.speed == float("inf") else self.speed,
            "sent": self.sent,
            "behind": self.behind,
            "worst_lag_s": self.worst_lag_s,
        }

    def text(self) -> str:
        speed = "max" if self.speed == float("inf") else f"{self.speed:g}x"
        if self.speed == float("inf"):
            return f"pace max: {self.sent} sent as fast as {MAX_IN_FLIGHT} senders could"
        verdict = (
            f"the sender fell behind: {self.behind} sent over {LATE_S * 1e3:g} ms late "
            f"(worst {self.worst_lag_s:.3g} s)"
            if self.behind
            else "kept to the recorded pace"
        )
        return f"pace {speed}: {self.sent} sent; {verdict}"


def paced(
    exchanges: Iterable[Any], work: Callable[[Any], Any], pacing: Pacing
) -> Iterator[tuple[Any, Any]]:
    """``(exchange, work(exchange))`` in the order read, each started at its time."""
    pending: deque[tuple[Any, Future[Any]]] = deque()
    first: int | None = None
    start = 0.0
    with ThreadPoolExecutor(MAX_IN_FLIGHT, thread_name_prefix="pace") as pool:
        for exchange in exchanges:
            if first is None:
                first, start = exchange.log_time, time.monotonic()
            while len(pending) >= MAX_IN_FLIGHT:
                done, future = pending.popleft()
                yield done, future.result()
            due = start + (exchange.log_time - first) / 1e9 / pacing.speed
            lag = time.monotonic() - due
            if lag < 0:
                time.sleep(-lag)
            elif lag > LATE_S and pacing.speed != float("inf"):
                pacing.behind += 1
                pacing.worst_lag_s = max(pacing.worst_lag_s, lag)
            pending.append((exchange, pool.submit(work, exchange)))
            pacing.sent += 1
            while pending and pending[0][1].done():
                done, future = pending.popleft()
                yield done, future.result()
        while pending:
            done, future = pending.popleft()
            yield done, future.result()
