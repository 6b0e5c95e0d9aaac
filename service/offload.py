"""Large bodies, parsed, run and answered in a worker process, off the event loop.

Moving a large body's work to a thread does not free the event loop: pydantic-core's
``validate_json``, ``json.loads`` and ``model_dump_json`` hold the interpreter for the
whole call, and the garbage collector, walking the millions of objects a large request
builds, holds it again between them. Measured on this machine, with ``/healthz`` polled
every 10 ms during ``gates.pairs`` with 100,000 pairs (22 MiB) handled in a thread: the
loop stalled 2 to 6 s at a time; with a Python validator on each pair, so the interpreter
could switch threads between pairs, still 0.3 s (jiter's parse of the whole body and the
collector's passes), and parsing alone, with ``json.loads`` or ``pydantic_core.from_json``,
0.2 to 1 s in one call. So a body over :data:`INLINE_BODY_BYTES` is handed, as bytes, to
a worker process (:class:`LargeBodies`) that parses it once, runs the operation and
encodes the answer, exactly as the route does for a small body (:func:`outcome`), and
hands back bytes. The server's own interpreter only copies bytes: the body out, the
answer in, the body into its request record. Those copies are what is left of the
stall: /healthz answered within 37 ms (p99 9 ms) during the heaviest ``gates.pairs``
body, measured by ``tests/service/test_large_bodies.py`` on a quiet machine.

Decisions where the issue is silent:

- Two worker processes per server process, two lanes: bodies up to
  :data:`SMALL_LANE_BYTES` go to one, larger ones to the other, so a small body never waits
  behind a large one's parse (before, a 169 KB body waited 9.5 s behind six 17 MB ones in
  one worker's queue). Each lane's worker starts on the first large body of either lane
  (about 4 s and 240 MB each to import the service, which a server that never sees one
  does not pay; the other lane's starts beside it, so a small body does not pay the start
  behind a large one). In a lane, bodies queue: their parse and encoding held the
  interpreter one at a time before.
- Each lane holds at most :data:`LANE_BODIES` bodies (running or waiting); one more is
  answered 503 ``workers-busy`` with ``Retry-After``, recorded. The lane's bodies are held
  in the server until the worker takes them, so the bound is also a memory bound (the large
  lane's 8 bodies of at most ``PLOTGATE_MAX_BODY_BYTES`` each).
- The worker is spawned, not forked: a fork of the running server would copy its
  threads' locks and its listening socket.
- A large body's request record is added when its answer comes back from the worker,
  then its response record, and the answer waits for both to be flushed, as always: a
  server killed meanwhile leaves no record of an exchange that nobody saw answered.
- A worker that dies (killed, out of memory) with requests in it answers them 503
  ``worker-lost`` with ``Retry-After``, recorded: a fault of the server, not an answer to
  the input, which replay sets aside. One that died idle costs no answer. The next large
  body of its lane starts a new worker.
"""

import asyncio
import contextlib
import ctypes
import gc
import logging
import multiprocessing
import os
import signal
from collections.abc import Mapping
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from plotgate.service.cluster import configure
from plotgate.service.problems import ProblemError
from plotgate.service.registry import (
    OPERATIONS,
    Operation,
    Outcome,
    Parsed,
    failed,
    internal_error,
    load_all,
    parse,
    run,
)

__all__ = ["INLINE_BODY_BYTES", "LANE_BODIES", "SMALL_LANE_BYTES", "LargeBodies", "outcome"]

log = logging.getLogger("plotgate")

INLINE_BODY_BYTES = 64 * 1024
"""Bodies up to this size are parsed, run and answered on the event loop; larger ones in
a worker process. Measured on this machine (``gates.test``, the median of 15): a 39 KiB
body (330 candidates) holds the loop 0.9 ms, a 79 KiB one (660) 1.8 ms, and the worker
answers either in 0.3 to 0.4 ms more wall time. So no body below the threshold holds the
loop more than about 1.5 ms, and a small request, the hot path, never pays a hop."""
SMALL_LANE_BYTES = 2 * 2**20
"""Bodies over :data:`INLINE_BODY_BYTES` and up to this size go to the small lane's worker,
larger ones to the large lane's. A 2 MiB body (about 7,000 pairs) takes tenths of a
second in the worker; the largest legal ones take seconds each."""
LANE_BODIES = {"small": 32, "large": 8}
"""Most bodies in each lane's queue, the one in its worker included; one more is answered
503 ``workers-busy``. 8 large bodies of the 64 MiB default limit hold 512 MiB."""


def outcome(
    op: Operation, parsed: Parsed, request_id: str, limits: Mapping[str, int] | None
) -> Outcome:
    """The answer to a parsed body: its problem, or the operation's answer; anything an
    operation raises unexpectedly is a bug, logged and answered 500."""
    if parsed.request is None:
        assert parsed.problem is not None
        return failed(op, parsed.problem, request_id)
    try:
        return run(op, parsed.request, request_id, limits)
    except Exception:
        log.exception("operation %s failed on request %s", op.name, request_id)
        return internal_error(op, request_id)


Answer = tuple[bool, int, bytes]
"""What the worker hands back: whether the body is strict JSON, and the answer's status
and content."""


def _answer(name: str, body: bytes, request_id: str, limits: dict[str, int] | None) -> Answer:
    """In the worker: parse ``body`` once (it was sized up as it arrived) and answer it."""
    op = OPERATIONS[name]
    try:
        parsed = parse(op, body, sized_up=True)
    except Exception:
        log.exception("parsing a body of %s failed on request %s", name, request_id)
        return False, *_content(internal_error(op, request_id))
    return parsed.json, *_content(outcome(op, parsed, request_id, limits))


def _content(answer: Outcome) -> tuple[int, bytes]:
    return answer.status, answer.content


PR_SET_PDEATHSIG = 1
"""Linux's prctl option: the signal a process gets when the thread that started it ends."""


def _start(server: int, scheduler: str | None, timeout_s: float | None) -> None:
    """In the worker, once: dying with the server, no Ctrl-C of its own (the server stops
    it), the server's cluster, every operation imported (as the server does) and what the
    imports built kept out of every collection, as in the server."""
    _die_with(server)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    configure(scheduler, timeout_s)
    load_all()
    gc.collect()
    gc.freeze()


def _die_with(server: int) -> None:
    """Have the kernel kill this worker when the server's event loop thread, which started
    it, ends, even by SIGKILL. Without it, a worker orphaned with a body in it ran the body
    to the end and then blocked for ever writing its answer to the pipe (seen: still
    blocked 16 minutes after its server was killed). Linux only, as the image is."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        return
    if os.getppid() != server:  # the server died before the prctl: follow it
        os.kill(os.getpid(), signal.SIGKILL)


class LargeBodies:
    """The two lanes of worker processes that answer large bodies, started on first use."""

    def __init__(self, scheduler: str | None, timeout_s: float | None) -> None:
        self.lanes = {
            name: _Lane(name, most, (scheduler, timeout_s)) for name, most in LANE_BODIES.items()
        }
        self._starting: set[asyncio.Task[None]] = set()

    async def answer(
        self, op: Operation, body: bytes, request_id: str, limits: Mapping[str, int] | None
    ) -> tuple[bool, Outcome]:
        """Parse ``body`` and answer it in its lane's worker: whether it is strict JSON (how
        its request record keeps it) and the outcome."""
        lane = self.lanes["small" if len(body) <= SMALL_LANE_BYTES else "large"]
        if lane.busy >= lane.most:
            detail = (
                f"the {lane.name} bodies' worker has {lane.busy} bodies in its queue, "
                f"its bound: send the request again later"
            )
            return False, _fault(op, request_id, "workers-busy", detail)
        for other in self.lanes.values():
            if other.pool is None and other is not lane:  # starts beside this one
                task = asyncio.ensure_future(_warm(other))
                self._starting.add(task)
                task.add_done_callback(self._starting.discard)
        return await lane.answer(op, body, request_id, dict(limits or {}))

    def close(self) -> None:
        """Stop the workers: after their work when idle, at once when a request is still in
        one (the server's graceful shutdown has given up on that request)."""
        for lane in self.lanes.values():
            lane.close()


async def _warm(lane: "_Lane") -> None:
    """Start ``lane``'s worker ahead of its first body; a failure waits for that body."""
    try:
        await lane.started()
    except Exception:  # noqa: BLE001 - its first body starts it again, and answers the fault
        log.warning("the %s bodies' worker did not start ahead of its bodies", lane.name)


def _fault(op: Operation, request_id: str, kind: str, detail: str) -> Outcome:
    """A 503 for a fault of the server (the route adds ``Retry-After``), never an answer."""
    return failed(op, ProblemError(kind, 503, detail), request_id)


class _Lane:
    """One worker process, started on first use, and the bodies queued for it."""

    def __init__(self, name: str, most: int, cluster: tuple[str | None, float | None]) -> None:
        self.name, self.most, self.cluster = name, most, cluster
        self.pool: ProcessPoolExecutor | None = None
        self.pid: int | None = None
        self.busy = 0

    async def answer(
        self, op: Operation, body: bytes, request_id: str, limits: dict[str, int]
    ) -> tuple[bool, Outcome]:
        self.busy += 1
        pool = None
        try:
            pool, future = await self._submit(op.name, body, request_id, limits)
            strict, status, content = await asyncio.wrap_future(future)
        except BrokenProcessPool:
            log.error("the %s bodies' worker died on request %s", self.name, request_id)
            self._drop(pool)  # the next body of this lane starts a new one
            detail = (
                f"the worker process answering {self.name} bodies died (killed, or out of "
                "memory) during this request: send it again"
            )
            return False, _fault(op, request_id, "worker-lost", detail)
        except Exception as exc:  # the pool shut down under it: a fault, answered and recorded
            log.exception(
                "the %s bodies' worker could not answer request %s", self.name, request_id
            )
            detail = f"the {self.name} bodies' worker stopped during this request ({exc})"
            return False, _fault(op, request_id, "worker-lost", detail[:300])
        finally:
            self.busy -= 1
        return strict, Outcome(status, content)

    async def _submit(
        self, name: str, body: bytes, request_id: str, limits: dict[str, int]
    ) -> tuple[ProcessPoolExecutor, Future[Answer]]:
        """Hand the work to the worker; a worker found dead before it took the work (it died
        idle) is replaced once, so its death costs no answer. Returns the pool it went to,
        which only that pool's failure may drop (another request may have started the next
        one meanwhile)."""
        for _ in range(2):
            pool = await self.started()
            try:
                return pool, pool.submit(_answer, name, body, request_id, limits)
            except BrokenProcessPool:
                self._drop(pool)
        raise BrokenProcessPool("the worker died as it started")

    async def started(self) -> ProcessPoolExecutor:
        """The worker's pool, started when there is none: the pool of this call, even if
        another request drops it while this one waits for the worker to start."""
        pool = self.pool
        if pool is None:
            context = multiprocessing.get_context("spawn")
            # the server's pid now, not when the app was built: a server forked after it
            # (gunicorn --preload) would have its worker kill itself at start
            pool = ProcessPoolExecutor(1, context, _start, (os.getpid(), *self.cluster))
            self.pool, self.pid = pool, None
            try:
                pid = await asyncio.wrap_future(pool.submit(os.getpid))
            except BrokenProcessPool:
                self._drop(pool)
                raise
            if self.pool is pool:
                self.pid = pid
        return pool

    def _drop(self, pool: ProcessPoolExecutor | None) -> None:
        """Forget ``pool`` (its worker died) unless it was already replaced."""
        if pool is not None and self.pool is pool:
            self.pool, self.pid = None, None

    def close(self) -> None:
        if self.pool is None:
            return
        self.pool.shutdown(wait=self.busy == 0, cancel_futures=True)
        if self.busy and self.pid is not None:
            with contextlib.suppress(ProcessLookupError):  # it died meanwhile
                os.kill(self.pid, signal.SIGKILL)
        self.pool, self.pid = None, None
