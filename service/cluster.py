"""Heavy batch work on a Dask cluster: one place that says "use a cluster".

Monte Carlo runs are cut into fixed chunks by core (:data:`plotgate.core.initiation.evaluate.
CHUNK_RUNS`); this module only says where the chunks run. :func:`cluster` opens a
``distributed.Client`` on an existing scheduler (``address``) or on a LocalCluster of
``local_workers`` processes it starts and stops, and :func:`mapper` is then that client's
``map`` (results gathered in order), or None without a cluster, which core reads as the
builtin ``map`` in this process. The chunks' seeds are spawned per run, so the numbers are
bit-identical in-process and on any number of workers.

Dask (``distributed``) is an optional dependency: ``pip install "plotgate[cluster]"``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["ClusterUnavailable", "cluster", "mapper"]

_client: Any = None


class ClusterUnavailable(RuntimeError):
    """Dask is not installed, or the scheduler cannot be reached."""


def mapper() -> Callable[..., Iterable[Any]] | None:
    """The open cluster's ``map`` (ordered results), or None: run in this process."""
    client = _client
    if client is None:
        return None

    def mapped(function: Callable[..., Any], items: Iterable[Any]) -> list[Any]:
        futures = client.map(function, list(items), pure=False)
        return list(client.gather(futures))

    return mapped


@contextmanager
def cluster(address: str | None = None, local_workers: int | None = None) -> Iterator[None]:
    """Run the batch work inside on a cluster: the scheduler at ``address``, or a
    LocalCluster of ``local_workers`` single-threaded worker processes; neither, in this
    process.

    Raises
    ------
    ClusterUnavailable
        Dask is not installed, or the scheduler does not answer within 10 s.
    """
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
        try:
            client = Client(address, timeout="10s")
        except OSError as exc:
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
