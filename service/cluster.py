"""Heavy batch work on a Dask cluster: one place that says "use a cluster".

Monte Carlo runs are cut into fixed chunks by core
(:data:`plotgate.core.initiation.evaluate.CHUNK_RUNS`); this module only says where the
chunks run. :func:`cluster` opens a ``distributed.Client`` on an existing scheduler
(``address``) or on a LocalCluster of ``local_workers`` processes it starts and stops,
and :func:`mapper` is then that client's ``map`` (results gathered in order), or None
without a cluster, which core reads as the builtin ``map`` in this process. The service
names its scheduler once (:func:`configure`, from ``PLOTGATE_DASK_SCHEDULER``) and
connects on first use; an unreachable scheduler raises :class:`ClusterUnavailable`
(the service answers 503 with ``Retry-After``), work past ``PLOTGATE_DASK_TIMEOUT_S``
raises :class:`ClusterTimeout` (504). The chunks' seeds are spawned per run, so the
numbers are bit-identical in-process and on any number of workers.

Every talk with Dask runs as a coroutine on one event loop in a daemon thread
(:func:`_talk`), under a deadline this module keeps itself: Dask's own connect timeout
does not cover a peer that accepts and then never speaks (its handshake reads without
one), and a peer that speaks something else makes it raise whatever its parser hits
(an HTTP banner read as a frame length is a 3 EiB ``MemoryError``). So past the
deadline the coroutine is cancelled, and anything Dask raises while connecting or
talking becomes :class:`ClusterUnavailable`, whatever its type; only an error a task
itself raised on a worker comes back as it is, as it would in-process.
:func:`configure` cancels the calls in flight, so a stuck call never holds up shutdown.
One request's work is cancelled alone with :class:`Cancellable` (its client went away):
its calls to the cluster, and in this process the chunks not yet started.

Dask (``distributed``) is an optional dependency: ``pip install "plotgate[cluster]"``.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextvars
import logging
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Coroutine, Iterable, Iterator
from contextlib import contextmanager, suppress
from typing import Any, TypeVar

from tqdm import tqdm

from plotgate.install import install_hint

__all__ = [
    "CONNECT_S",
    "NO_WORKERS_S",
    "Cancellable",
    "ClusterTimeout",
    "ClusterUnavailable",
    "WorkCancelled",
    "cancel_calls",
    "cluster",
    "configure",
    "lazy_map",
    "mapper",
    "numba_threads",
    "run_worker",
    "while_workers",
    "workers",
]

CONNECT_S = 5.0
"""Longest wait for a scheduler's handshake, s; the service waits at most its
``PLOTGATE_DASK_TIMEOUT_S`` when that is shorter (a request's whole wait on the cluster,
connecting included, is bounded by it)."""

_CLOSE_S = 2.0
"""Longest wait for Dask to cancel tasks or close a client, s: cleanup past a deadline is
bounded too, and the caller waits this much longer than its deadline at most."""

_DASK_SHARE = 0.8
"""Dask's own connect timeout, as a share of the caller's deadline (:func:`_connect`)."""

_T = TypeVar("_T")

_client: Any = None  # an asynchronous distributed.Client living on _loop
_address: str | None = None  # the service's scheduler, connected on first use
_timeout: float | None = None
_progress = False  # inside cluster(progress=True)
_lock = threading.Lock()  # guards the names above and _calls; never held while Dask talks
_calls: set[concurrent.futures.Future[Any]] = set()  # talks in flight, for configure
_loop: asyncio.AbstractEventLoop | None = None


class ClusterUnavailable(RuntimeError):
    """Dask is not installed, the scheduler cannot be reached or answers nonsense, or the
    work on it did not finish in time (:class:`ClusterTimeout`)."""


class ClusterTimeout(ClusterUnavailable):
    """The work did not finish on the cluster within the timeout; its tasks are cancelled.
    The service answers 504, which a client does not retry: the same work would take as
    long again."""


class WorkCancelled(ClusterUnavailable):
    """The work was cancelled before it finished (:meth:`Cancellable.cancel`: the service's
    client went away): its talk with the cluster was cancelled, and its tasks with it, or,
    in this process, no further chunk was started."""


class Cancellable:
    """One request's batch work, which another thread can cancel: the service runs an
    operation with :meth:`run` in a worker thread and cancels it when the client goes
    away. The work's talks with the cluster are cancelled then (so are their tasks on
    the workers), and in this process the next chunk does not start (the chunk running
    finishes: a compiled kernel cannot be stopped). Either way the work raises
    :class:`WorkCancelled`. Work run outside :meth:`run` is not cancellable, as before."""

    def __init__(self) -> None:
        self.cancelled = False
        self._lock = threading.Lock()
        self._calls: set[concurrent.futures.Future[Any]] = set()

    def run(self, function: Callable[..., _T], *args: Any) -> _T:
        """``function(*args)`` with its batch work cancellable by :meth:`cancel`."""
        token = _current.set(self)
        try:
            return function(*args)
        finally:
            _current.reset(token)

    def cancel(self) -> None:
        """Stop the work: its talks with the cluster now, the chunks in this process before
        the next one starts. Safe from any thread, and more than once."""
        with self._lock:
            self.cancelled = True
            calls = list(self._calls)
        for call in calls:
            call.cancel()

    def check(self) -> None:
        """Raise :class:`WorkCancelled` if :meth:`cancel` was called."""
        if self.cancelled:
            raise WorkCancelled("the work was cancelled: its client went away")

    def _watch(self, call: concurrent.futures.Future[Any]) -> None:
        with self._lock:
            if not self.cancelled:
                self._calls.add(call)
                return
        call.cancel()

    def _forget(self, call: concurrent.futures.Future[Any]) -> None:
        with self._lock:
            self._calls.discard(call)


_current: contextvars.ContextVar[Cancellable | None] = contextvars.ContextVar(
    "plotgate_cancellable", default=None
)
"""The work this thread runs inside :meth:`Cancellable.run`, if any."""


class _TaskFailed(Exception):
    """A task raised on a worker: its own error (core's, or a bug), not the cluster's."""

    def __init__(self, error: BaseException) -> None:
        super().__init__(str(error))
        self.error = error


def configure(address: str | None, timeout: float | None = None) -> None:
    """The service's cluster: connect to ``address`` on first use (None: in-process), and
    wait at most ``timeout`` seconds for one request's work, connecting included (None:
    no limit). The calls in flight are cancelled (their callers get
    :class:`ClusterUnavailable` at once) and the previous client is closed."""
    global _address, _timeout, _client
    with _lock:
        old = _client if _address is not None else None
        if old is not None:
            _client = None
        _address, _timeout = address, timeout
    cancel_calls()
    if old is not None:
        _close(old)


def cancel_calls() -> None:
    """Cancel every talk with Dask in flight: each caller gets :class:`ClusterUnavailable`
    at once (the service answers 503), and its tasks are cancelled. Quick, so a signal
    handler's callback on the event loop may call it."""
    with _lock:
        stuck = list(_calls)
    for call in stuck:
        call.cancel()


def _cluster_loop() -> asyncio.AbstractEventLoop:
    """The event loop every talk with Dask runs on, in a daemon thread started on first
    use: a daemon, so a talk that never ends cannot keep the process from exiting."""
    global _loop
    with _lock:
        if _loop is None:
            loop = asyncio.new_event_loop()
            thread = threading.Thread(target=loop.run_forever, name="plotgate-dask", daemon=True)
            thread.start()
            _loop = loop
        return _loop


def _talk(
    work: Coroutine[Any, Any, _T],
    within: float | None,
    failing: str,
    late: Callable[[], ClusterUnavailable],
) -> _T:
    """Run ``work`` on the cluster loop and wait for it at most ``within`` s (None: no
    limit). Past that it is cancelled and ``late()`` raised; anything else it raises is
    :class:`ClusterUnavailable` (``failing``: what failed, with what Dask raised), but for
    an error of a task of its own (:class:`_TaskFailed`), re-raised as the task raised it.
    """
    call = asyncio.run_coroutine_threadsafe(_bounded(work, within, failing, late), _cluster_loop())
    cancellable = _current.get()
    with _lock:
        _calls.add(call)
    if cancellable is not None:
        cancellable._watch(call)
    try:
        # the loop enforces `within` itself; this wait only covers a loop that stalls
        return call.result(None if within is None else within + _CLOSE_S + 1.0)
    except _TaskFailed as exc:
        raise exc.error from None
    except concurrent.futures.CancelledError:
        if cancellable is not None:
            cancellable.check()
        raise ClusterUnavailable(
            f"{failing}: the call was cancelled (the cluster reconfigured or the service stopping)"
        ) from None
    except TimeoutError:
        call.cancel()
        raise late() from None
    finally:
        with _lock:
            _calls.discard(call)
        if cancellable is not None:
            cancellable._forget(call)


async def _bounded(
    work: Coroutine[Any, Any, _T],
    within: float | None,
    failing: str,
    late: Callable[[], ClusterUnavailable],
) -> _T:
    """``work`` under ``within`` s, its errors the cluster's (:func:`_as_cluster_errors`)."""
    try:
        return await asyncio.wait_for(_as_cluster_errors(work, failing), within)
    except TimeoutError:
        raise late() from None


async def _as_cluster_errors(work: Coroutine[Any, Any, _T], failing: str) -> _T:
    """``work``, with anything it raises as :class:`ClusterUnavailable` but a task's own
    error (:class:`_TaskFailed`) and this call being cancelled. A CancelledError Dask
    raises on its own (a scheduler lost, its futures cancelled) is the cluster failing."""
    try:
        return await work
    except (ClusterUnavailable, _TaskFailed):
        raise
    except asyncio.CancelledError as exc:
        task = asyncio.current_task()
        if task is not None and task.cancelling():
            raise
        raise ClusterUnavailable(f"{failing}: the work was cancelled ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - whatever Dask raises while talking
        raise ClusterUnavailable(f"{failing}: {type(exc).__name__}: {exc}") from exc


async def _connect(address: str, within: float) -> Any:
    """An asynchronous Client of the scheduler at ``address``, closed again if it does not
    start. Dask's own connect timeout (also how long it tries to reconnect when the
    scheduler goes away later) is 80% of ``within``, so a refused connection ends with
    Dask's reason before the caller's deadline cuts it short."""
    from distributed import Client

    patience = _DASK_SHARE * within
    client = Client(address, asynchronous=True, timeout=patience, set_as_default=False)
    try:
        await client
    except BaseException:
        await _quietly_closed(client)
        raise
    return client


async def _quietly_closed(client: Any) -> None:
    """Close ``client`` within :data:`_CLOSE_S`, whatever state it is in."""
    try:
        await asyncio.wait_for(client.close(), _CLOSE_S)
    except Exception:  # noqa: BLE001, S110 - a client that cannot close cleanly is dropped
        pass


def _close(client: Any) -> None:
    """Close ``client`` on the cluster loop, waiting :data:`_CLOSE_S` at most: a client
    that will not close is left to the daemon loop, so shutdown goes on."""

    closing = asyncio.run_coroutine_threadsafe(_quietly_closed(client), _cluster_loop())
    try:
        closing.result(_CLOSE_S + 1.0)
    except TimeoutError:
        closing.cancel()


def _open(address: str, within: float) -> Any:
    """A running client of the scheduler at ``address``, connected within ``within`` s.

    Raises
    ------
    ClusterUnavailable
        Dask is not installed, ``address`` is no scheduler address, or no scheduler
        answered at it in time or sensibly.
    """
    try:
        import distributed  # noqa: F401
    except ImportError as exc:
        raise ClusterUnavailable("a cluster needs Dask: " + install_hint("cluster")) from exc
    _check_address(address)

    failing = f"no Dask scheduler answers at {address}"

    def late() -> ClusterUnavailable:
        return ClusterUnavailable(f"{failing} within {within:g} s")

    return _talk(_connect(address, within), within, failing, late)


def _connected(within: float) -> Any:
    """The client of the configured scheduler, connecting (again) when there is none or
    it has lost the scheduler (a scheduler restarted on the same address is used by the
    next request). The client it replaces is closed: one still trying to reconnect would
    otherwise join the new scheduler too, and hold a connection for nothing. Two requests
    may connect at once; the later client is closed and the first one kept."""
    global _client
    with _lock:
        client, address = _client, _address
    if client is not None and client.status == "running":
        return client
    assert address is not None
    client = _open(address, within)
    with _lock:
        if _address == address and (_client is None or _client.status != "running"):
            stale, _client, kept = _client, client, client
        else:
            stale, kept = client, (_client if _address == address else None)
    if stale is not None:
        _close(stale)
    if kept is None:
        raise ClusterUnavailable("the service's cluster was reconfigured meanwhile")
    return kept


def _check_address(address: str) -> None:
    """Refuse (:class:`ClusterUnavailable`) an address Dask cannot parse, before a Client
    is built for it: ``not-an-address``, ``tcp://host`` without a port, an unknown
    protocol."""
    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(address)
        get_backend(scheme)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except ValueError as exc:
        raise ClusterUnavailable(f"{address!r} is no Dask scheduler address: {exc}") from None


def mapper() -> Callable[..., Iterable[Any]] | None:
    """The cluster's ``map`` (ordered results), or None: run in this process. Inside
    ``cluster(progress=True)`` the map draws a progress bar of the chunks done on stderr,
    in this process too.

    The service's timeout starts here: connecting and all the work mapped then share it.

    Raises
    ------
    ClusterUnavailable
        The configured scheduler cannot be reached; or, when mapping, the cluster failed
        (:class:`ClusterUnavailable`) or the work did not finish within the timeout
        (:class:`ClusterTimeout`, its tasks cancelled).
    """
    if _client is None and _address is None:
        return _in_process if _progress or _current.get() is not None else None
    timeout = _timeout
    deadline = None if timeout is None else time.monotonic() + timeout
    if _address is not None:
        client = _connected(CONNECT_S if timeout is None else min(CONNECT_S, timeout))
    else:
        client = _client

    def late() -> ClusterUnavailable:
        return ClusterTimeout(f"the work did not finish on the cluster within {timeout:g} s")

    def mapped(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
        items = list(items)
        left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
        with _bar(len(items)) as bar:
            return _talk(
                _mapped(client, function, items, bar), left, "the Dask cluster failed", late
            )

    return mapped


def workers() -> int | None:
    """The worker threads the cluster's scheduler reports now, or None without a cluster.

    What a cluster may take in one request scales with it
    (:func:`plotgate.service.registry.over_caps`). Asked when a request passes a one-core
    cap, so a request within the caps never waits for the scheduler. A scheduler that has
    lost every worker reports 0.

    Raises
    ------
    ClusterUnavailable
        The configured scheduler cannot be reached, or does not answer in time.
    """
    if _client is None and _address is None:
        return None
    within = CONNECT_S if _timeout is None else min(CONNECT_S, _timeout)
    client = _connected(within) if _address is not None else _client
    failing = "the Dask scheduler did not report its workers"

    def late() -> ClusterUnavailable:
        return ClusterUnavailable(f"{failing} within {within:g} s")

    return _talk(_threads(client), within, failing, late)


async def _threads(client: Any) -> int:
    """The threads of every worker the scheduler knows (its ``ncores``)."""
    nthreads: dict[str, int] = await client.scheduler.ncores()
    return sum(nthreads.values())


def lazy_map(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
    """``function`` over ``items`` by :func:`mapper`'s map, asked for only now: an
    operation hands this to core, which checks its input before it maps any work, so a
    bad request is refused (422) before the cluster is even reached, and never answered
    503 because the cluster is down.

    Raises
    ------
    ClusterUnavailable
        As :func:`mapper` and its map.
    """
    return list((mapper() or map)(function, items))


async def _mapped(
    client: Any, function: Callable[..., Any], items: list[Any], bar: tqdm[Any]
) -> list[Any]:
    """``function`` over ``items`` on the cluster, results in order, while the cluster has
    workers (:func:`while_workers`); the tasks are cancelled when this is (past the
    deadline) or anything fails."""
    futures = client.map(function, items, pure=False)
    work = asyncio.ensure_future(_gathered(client, futures, bar))
    watch = asyncio.ensure_future(while_workers(client))
    try:
        await asyncio.wait({work, watch}, return_when=asyncio.FIRST_COMPLETED)
        if not work.done():
            watch.result()  # raises: no worker, or no scheduler
        return work.result()
    except BaseException as exc:
        failed = [f for f in futures if f.status == "error"]
        await _cancelled(client, futures)
        if failed and isinstance(exc, Exception):
            raise _TaskFailed(exc) from exc
        raise
    finally:
        work.cancel()
        watch.cancel()


async def _gathered(client: Any, futures: list[Any], bar: tqdm[Any]) -> list[Any]:
    from distributed import as_completed

    async for _ in as_completed(futures, loop=client.loop):
        bar.update()
    return list(await client.gather(futures))


NO_WORKERS_S = 3.0
"""How long a request's work waits on a cluster that has no worker (none joined, or every
one died), s; then it is answered 503 ``cluster-unavailable`` with that cause, not 504
after ``PLOTGATE_DASK_TIMEOUT_S`` (300 s by default). Long enough for a restarted worker
to join again."""
_WORKERS_POLL_S = 0.5
"""How often a request's work asks the scheduler for its workers, s."""


async def while_workers(client: Any) -> None:
    """Return never: raise :class:`ClusterUnavailable` once the scheduler has had no worker
    for :data:`NO_WORKERS_S`, or refuses the question, or does not answer it within
    :data:`CONNECT_S` (it died: a killed scheduler's client waits to reconnect rather than
    fail). The bound is a handshake's, not the shorter :data:`_CLOSE_S`: a scheduler busy
    on a loaded machine answers in seconds, and is not taken for dead."""
    alone_since = None
    while True:
        try:
            threads = await asyncio.wait_for(_threads(client), CONNECT_S)
        except Exception as exc:  # noqa: BLE001 - whatever a dead scheduler's client raises
            raise ClusterUnavailable(
                f"the Dask scheduler did not report its workers: {type(exc).__name__}: {exc}"
            ) from None
        now = time.monotonic()
        if threads:
            alone_since = None
        elif alone_since is None:
            alone_since = now
        elif now - alone_since >= NO_WORKERS_S:
            raise ClusterUnavailable(
                f"the Dask cluster has had no worker for {NO_WORKERS_S:g} s: its work "
                "cannot run (start a worker: plotgate worker SCHEDULER)"
            )
        await asyncio.sleep(_WORKERS_POLL_S)


async def _cancelled(client: Any, futures: list[Any]) -> None:
    """Cancel ``futures`` on the cluster within :data:`_CLOSE_S`, if it still listens."""
    try:
        await asyncio.wait_for(client.cancel(futures), _CLOSE_S)
    except Exception:  # noqa: BLE001, S110 - a lost scheduler has nothing left to cancel
        pass


def _bar(total: int) -> tqdm[Any]:
    """A bar of chunks done on stderr, drawn only inside ``cluster(progress=True)``.

    Every chunk done is drawn (``miniters=1, mininterval=0``): chunks are seconds of work
    each, so drawing costs nothing, and tqdm's default of one draw per 0.1 s would skip the
    last count when chunks end close together, leaving a bar that never reads done."""
    return tqdm(
        total=total,
        unit="chunk",
        desc="chunks",
        disable=not _progress,
        leave=False,
        miniters=1,
        mininterval=0,
    )


def _in_process(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
    """The builtin ``map`` with the progress bar, and stopped before the next item once the
    work is cancelled (:class:`Cancellable`)."""
    items = list(items)
    cancellable = _current.get()
    out = []
    with _bar(len(items)) as bar:
        for item in items:
            if cancellable is not None:
                cancellable.check()
            out.append(function(item))
            bar.update()
    return out


@contextmanager
def cluster(
    address: str | None = None, local_workers: int | None = None, progress: bool = False
) -> Iterator[None]:
    """Run the batch work inside on a cluster: the scheduler at ``address``, or a
    LocalCluster of ``local_workers`` single-threaded worker processes; neither, in this
    process. ``progress``: draw the chunks done as a bar on stderr (the command line, on
    a terminal). The work inside has no time limit (the command line's user can stop
    it); connecting has :data:`CONNECT_S`.

    Raises
    ------
    ClusterUnavailable
        Dask is not installed, or no scheduler answers, in time or sensibly.
    """
    global _progress
    _progress = progress
    try:
        with _dask_quiet(logging.CRITICAL), _cluster(address, local_workers):
            yield
    finally:
        _progress = False


@contextmanager
def _cluster(address: str | None, local_workers: int | None) -> Iterator[None]:
    """The cluster inside, closed cleanly after it, or abandoned on an interrupt
    (:func:`_abandoned`): a Ctrl-C ends the command at once, not after the workers finish
    their chunks."""
    global _client
    if address is None and local_workers is None:
        yield
        return
    try:
        from distributed import LocalCluster
    except ImportError as exc:
        raise ClusterUnavailable("a cluster needs Dask: " + install_hint("cluster")) from exc
    local = client = None
    try:
        if address is None:
            assert local_workers is not None  # one of the two, or the early return
            local = LocalCluster(
                n_workers=0,
                threads_per_worker=1,
                processes=True,
                # a free port: None means Dask's 8787, and a second cluster on the
                # machine warned "Port 8787 is already in use" (an error under the tests)
                dashboard_address=":0",
                # the workers' own logs are not the command's output: at shutdown on a busy
                # machine a worker's heartbeat to the closed scheduler logged a traceback on
                # the command's stderr; a task's error still comes back as it is raised
                silence_logs=logging.CRITICAL,
                env={"NUMBA_NUM_THREADS": str(numba_threads(local_workers))},
            )
            _start_workers(local, local_workers)
            address = local.scheduler_address
        client = _open(address, CONNECT_S)
        _client = client
        yield
    except KeyboardInterrupt:
        _abandoned(local)
        local = client = None  # left to end with the process, not closed
        raise
    finally:
        _client = None
        if client is not None:
            _close(client)
        if local is not None:
            with _dask_quiet():
                local.close()


def numba_threads(local_workers: int) -> int:
    """Threads of each local worker's parallel numba kernels: the machine's cores shared
    among the workers, as Dask itself runs each worker's numpy, BLAS and OpenMP on one
    thread (its ``pre-spawn-environ``): two workers on two cores, each with numba's
    default of a thread per core, would run the study's parallel Gauss-Newton kernel on
    four threads over two cores. Per-problem results do not depend on the threads, so
    neither do the numbers."""
    return max(1, (os.cpu_count() or 1) // local_workers)


WORKERS_START_S = 120.0
"""Longest wait for the local worker processes to start and join, s (seconds each on a
loaded machine: each imports numpy, scipy, numba and Dask)."""


def _start_workers(local: Any, n: int) -> None:
    """Start ``n`` worker processes in ``local`` with SIGINT ignored (:func:`_sigint_ignored`)
    only while they are spawned, then wait for them to join with SIGINT live: a Ctrl-C
    while they load their modules (many seconds under load) ends the command."""
    with _sigint_ignored():
        local.scale(n)
        deadline = time.monotonic() + WORKERS_START_S
        while len(_worker_processes()) < n and time.monotonic() < deadline:
            time.sleep(0.02)
    try:
        local.wait_for_workers(n, timeout=WORKERS_START_S)
    except TimeoutError as exc:
        raise ClusterUnavailable(
            f"the {n} local Dask workers did not start within {WORKERS_START_S:g} s"
        ) from exc


def _worker_processes() -> list[multiprocessing.process.BaseProcess]:
    """The Dask worker processes this process has spawned and that still run."""
    return [p for p in multiprocessing.active_children() if p.name.startswith("Dask Worker")]


@contextmanager
def _dask_quiet(level: int = logging.ERROR) -> Iterator[None]:
    """Dask's log lines below ``level`` off: its warnings while a local cluster closes (on
    a loaded machine a worker slow to stop drew "Worker process still alive after 4.0
    seconds, killing" at the end of a call that had answered; Dask kills it, as it says,
    and nothing is left to do), and within :func:`cluster` its errors too: a scheduler
    killed mid-run drew the client's reconnection traceback on the command's stderr before
    the command's own one-line message (the 503), which says all there is to say."""
    # Dask's import configures its loggers, its client's with a level of its own: first
    with suppress(ImportError):
        import distributed  # noqa: F401
    loggers = [logging.getLogger(name) for name in ("distributed", "distributed.client")]
    previous = [logger.level for logger in loggers]
    for logger, was in zip(loggers, previous, strict=True):
        logger.setLevel(max(level, was))  # never louder than an enclosing quiet
    try:
        yield
    finally:
        for logger, was in zip(loggers, previous, strict=True):
            logger.setLevel(was)


_QUIET_TRACKER = "ignore::UserWarning:multiprocessing.resource_tracker"


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while the local worker processes are spawned, so that they ignore it.

    A Ctrl-C at a terminal goes to every process of the foreground group, the workers
    included, and each one printed its own KeyboardInterrupt traceback. A process started
    meanwhile inherits the ignored SIGINT, Python keeps it ignored, and Dask sets no handler
    of its own: so this process alone answers a Ctrl-C, and the workers end with it (Dask's
    worker processes exit at once when their parent goes). Blocking the signal instead
    would keep a Ctrl-C pending rather than lose it, but the threads Dask spawns the workers
    from do not inherit this thread's mask, so the workers would get it: a Ctrl-C in the
    moment the processes are spawned (not the seconds they take to load) is lost. The resource
    tracker's warning about semaphores left to it (what an abandoned cluster leaves) is
    switched off in the processes started meanwhile, the tracker included: it cleans them
    up, as is its job. Only the main thread may set a handler: elsewhere nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.warnoptions.append(_QUIET_TRACKER)
    try:
        yield
    finally:
        sys.warnoptions.remove(_QUIET_TRACKER)
        signal.signal(signal.SIGINT, previous)


def _abandoned(local: Any) -> None:
    """After an interrupt: stop the talks in flight and leave the cluster (its client and
    the local one, if any) to die with this process, which the caller ends at once (the
    command line exits 130), rather than close it. A clean close waits for every worker to
    finish its chunk, and Dask warned "Worker process still alive after 4.0 seconds,
    killing" after 5 s; the worker processes instead exit as soon as this one does (they
    watch their parent). Dask's own log lines about the lost connections are silenced, as
    its atexit close of the local cluster is: after a Ctrl-C they are noise."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C: already ending
    logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)
    cancel_calls()
    if local is not None:
        local.shutdown_on_close = False  # no atexit close (10 s at most, with warnings)


def run_worker(address: str, nthreads: int = 1, wait: float = 10.0) -> None:
    """Join the scheduler at ``address`` as a worker with ``nthreads`` threads until the
    scheduler goes away or SIGTERM / SIGINT arrives (then close cleanly).

    Raises
    ------
    ClusterUnavailable
        Dask is not installed, or no scheduler answers within ``wait`` seconds.
    """
    try:
        from distributed import Worker
    except ImportError as exc:
        raise ClusterUnavailable("a worker needs Dask: " + install_hint("cluster")) from exc
    _check_address(address)

    async def work() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)
        try:
            worker = await Worker(address, nthreads=nthreads, death_timeout=wait, dashboard=False)
        except (OSError, TimeoutError, RuntimeError) as exc:  # RuntimeError: no address at all
            raise ClusterUnavailable(f"no Dask scheduler answers at {address}: {exc}") from exc
        finished = asyncio.ensure_future(worker.finished())
        stopped = asyncio.ensure_future(stop.wait())
        await asyncio.wait({finished, stopped}, return_when=asyncio.FIRST_COMPLETED)
        stopped.cancel()
        await worker.close()

    asyncio.run(work())
