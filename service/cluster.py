"""Heavy batch work on a Dask cluster: one place that says "use a cluster".

Monte Carlo runs are cut into fixed chunks by core
(:data:`plotgate.core.initiation.evaluate.CHUNK_RUNS`); this module only says where the
chunks run. :func:`cluster` opens a ``distributed.Client`` on an existing scheduler
(``address``) or on a LocalCluster of ``local_workers`` processes it starts and stops,
and :func:`mapper` is then that client's ``map`` (results gathered in order), or None
without a cluster, which core reads as the builtin ``map`` in this process. The service
names its scheduler once (:func:`configure`, from ``PLOTGATE_DASK_SCHEDULER``) and
connects on first use; an unreachable scheduler or work past ``PLOTGATE_DASK_TIMEOUT_S``
raises :class:`ClusterUnavailable`, which the service answers 503 with ``Retry-After``.
The chunks' seeds are spawned per run, so the numbers are bit-identical in-process and
on any number of workers.

Dask (``distributed``) is an optional dependency: ``pip install "plotgate[cluster]"``.
"""

from __future__ import annotations

import asyncio
import gc
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from tqdm import tqdm

__all__ = ["ClusterTimeout", "ClusterUnavailable", "cluster", "configure", "mapper", "run_worker"]

_client: Any = None
_address: str | None = None  # the service's scheduler, connected on first use
_timeout: float | None = None
_progress = False  # inside cluster(progress=True)
_lock = threading.Lock()


class ClusterUnavailable(RuntimeError):
    """Dask is not installed, the scheduler cannot be reached, or the work on it did not
    finish in time (:class:`ClusterTimeout`)."""


class ClusterTimeout(ClusterUnavailable):
    """The work did not finish on the cluster within the timeout; its tasks are cancelled.
    The service answers 504, which a client does not retry: the same work would take as
    long again."""


def configure(address: str | None, timeout: float | None = None) -> None:
    """The service's cluster: connect to ``address`` on first use (None: in-process), and
    wait at most ``timeout`` seconds for one request's work (None: no limit)."""
    global _address, _timeout, _client
    with _lock:
        if _client is not None and _address is not None:
            _client.close()
            _client = None
        _address, _timeout = address, timeout


def _connected() -> Any:
    """The client of the configured scheduler, connecting (again) when there is none or
    it has lost the scheduler."""
    global _client
    with _lock:
        if _client is not None and _client.status == "running":
            return _client
        try:
            from distributed import Client
        except ImportError as exc:
            raise ClusterUnavailable(
                'PLOTGATE_DASK_SCHEDULER needs Dask: pip install "plotgate[cluster]"'
            ) from exc
        assert _address is not None
        _check_address(_address)
        try:
            _client = Client(_address, timeout="5s")
        except (OSError, ValueError) as exc:
            reason = str(exc)
        else:
            return _client
        # A Client that failed to start sits in reference cycles; collected during a later
        # Client's start, its finalizer waits on a lock that start holds, and the thread
        # hangs for good (seen after ~15 failed connections). Collect it now instead.
        gc.collect()
        raise ClusterUnavailable(f"no Dask scheduler answers at {_address}: {reason}")


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

    Raises
    ------
    ClusterUnavailable
        The configured scheduler cannot be reached; or, when mapping, the work did not
        finish within the timeout (its tasks are cancelled).
    """
    if _client is None and _address is None:
        return _in_process if _progress else None
    client = _connected() if _address is not None else _client
    timeout = _timeout

    def mapped(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
        from distributed import as_completed

        futures = client.map(function, list(items), pure=False)
        with _bar(len(futures)) as bar:
            try:
                for _ in as_completed(futures, timeout=timeout):
                    bar.update()
            except TimeoutError as exc:
                client.cancel(futures)
                raise ClusterTimeout(
                    f"the work did not finish on the cluster within {timeout:g} s"
                ) from exc
        return list(client.gather(futures))

    return mapped


def _bar(total: int) -> tqdm[Any]:
    """A bar of chunks done on stderr, drawn only inside ``cluster(progress=True)``."""
    return tqdm(total=total, unit="chunk", desc="chunks", disable=not _progress, leave=False)


def _in_process(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
    """The builtin ``map`` with the progress bar."""
    items = list(items)
    out = []
    with _bar(len(items)) as bar:
        for item in items:
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
    a terminal).

    Raises
    ------
    ClusterUnavailable
        Dask is not installed, or the scheduler does not answer within 10 s.
    """
    global _client, _progress
    _progress = progress
    try:
        with _cluster(address, local_workers):
            yield
    finally:
        _progress = False


@contextmanager
def _cluster(address: str | None, local_workers: int | None) -> Iterator[None]:
    global _client
    if address is None and local_workers is None:
        yield
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ClusterUnavailable('a cluster needs Dask: pip install "plotgate[cluster]"') from exc
    local = None
    try:
        if address is None:
            local = LocalCluster(
                n_workers=local_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
            address = local.scheduler_address
        else:
            _check_address(address)
        try:
            client = Client(address, timeout="10s")
        except (OSError, ValueError) as exc:  # ValueError: no address at all
            raise ClusterUnavailable(f"no Dask scheduler answers at {address}: {exc}") from exc
        _client = client
        try:
            yield
        finally:
            _client = None
            client.close()
    finally:
        if local is not None:
            local.close()


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
        raise ClusterUnavailable('a worker needs Dask: pip install "plotgate[cluster]"') from exc
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
