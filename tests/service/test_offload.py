"""The large-body worker's pool under a worker's death, with requests in flight: a pool is
dropped only by a failure of its own, so a request that started the next worker while the
dead one's other requests were still failing gets its answer (it used to get a bare 500,
unrecorded, and leave the new worker orphaned)."""

import asyncio
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool

import plotgate.service.offload as offload
from plotgate.service.registry import OPERATIONS

OP = OPERATIONS["gates.test"]


class _Pool:
    """A stand-in for the worker's ProcessPoolExecutor: work waits in ``pending`` until the
    test answers or breaks it; the worker's pid comes a little later, as from a spawn."""

    pending: list[Future] = []

    def __init__(self, *args, **kwargs) -> None:
        self.closed = False

    def submit(self, fn, *args) -> Future:
        future: Future = Future()
        if fn is offload.os.getpid:
            asyncio.get_running_loop().call_later(0.05, future.set_result, 1234)
        else:
            self.pending.append(future)
        return future

    def shutdown(self, **kwargs) -> None:
        self.closed = True


def test_a_dead_workers_requests_do_not_drop_the_next_worker(monkeypatch):
    monkeypatch.setattr(offload, "ProcessPoolExecutor", _Pool)
    _Pool.pending = []

    async def session() -> list[int]:
        bodies = offload.LargeBodies(None, None)
        first = asyncio.create_task(bodies.answer(OP, b"{}", "a", None))
        second = asyncio.create_task(bodies.answer(OP, b"{}", "b", None))
        await asyncio.sleep(0.2)
        a, b = _Pool.pending
        _Pool.pending.clear()
        a.set_exception(BrokenProcessPool("killed"))  # the worker died with a and b in it
        await asyncio.sleep(0.01)
        third = asyncio.create_task(bodies.answer(OP, b"{}", "c", None))  # a new worker
        await asyncio.sleep(0.01)
        b.set_exception(BrokenProcessPool("killed"))  # b's failure, after c's new pool
        await asyncio.sleep(0.2)
        [c] = _Pool.pending
        c.set_result((True, 200, b"{}"))
        answers = [await t for t in (first, second, third)]
        return [outcome.status for _, outcome in answers]

    assert asyncio.run(session()) == [503, 503, 200]
