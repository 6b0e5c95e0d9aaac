"""Serving while the kernels compile: a warm-up process fills numba's cache, the server
loads from it.

With an empty cache (a fresh clone, a new numba, a new ``NUMBA_CACHE_DIR``) importing every
operation compiles about eighty kernels: minutes on a busy two-core machine. The server
no longer waits for that before it listens. :class:`Warmup` starts a child process
(``python -m plotgate.service.warmup``) that imports the operations' handler modules one
at a time, most used first (:data:`MOST_USED`), and so compiles their kernels and writes
them to the disk cache; as each module is done the server imports it, loading its kernels
from that cache in a fraction of a second. numba holds the interpreter's lock for long
stretches while it compiles, so compiling in a thread of the server would stall its event
loop (``/healthz`` included); in the child it stalls nothing of the server's.

A request whose operation is not ready waits for it (:meth:`Warmup.wait`), and its
module goes next in the child's queue: it is never refused. ``/readyz`` lists the ready
operations and those still compiling (:meth:`Warmup.report`). The console hears of it when
something compiles: once when the first kernel compiles, then every
:data:`PROGRESS_EVERY_S` the kernels done of :func:`kernel_names` and the time so far,
then the time the whole warm-up took. With a warm cache the child loads everything in
about a second and nothing is said.

If the child cannot do its work (it died, or its import failed even after the cache repair
of :func:`plotgate.service.kernels.load_kernels`), the server imports the remaining
modules itself, in a thread: slower to answer meanwhile, but every operation still comes
ready.
"""

import ast
import asyncio
import importlib.util
import json
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from starlette.datastructures import State

from plotgate.service.guards import ASGIApp, Receive, Scope, Send, route_path
from plotgate.service.kernels import CacheRepairFailed, load_kernels
from plotgate.service.registry import OPERATIONS

__all__ = [
    "CHILD",
    "MOST_USED",
    "PROGRESS_EVERY_S",
    "KernelsFirst",
    "Warmup",
    "kernel_names",
    "readiness",
    "warm_order",
]

MOST_USED = ("gates.test", "gates.pairs", "gates.probability", "solves.position")
"""Operations whose kernels compile first, most used first (the README's tour starts with
gate tests); the others follow in the registry's order."""

PROGRESS_EVERY_S = 10.0
"""Seconds between two progress lines on the console while kernels compile."""

CHILD = [sys.executable, "-m", "plotgate.service.warmup"]
"""The warm-up process's command."""

_JOIN_S = 10.0
"""Longest wait on shutdown for the warm-up thread (it may be importing a module)."""


def kernel_names(package: str = "plotgate.core") -> frozenset[str]:
    """The compiled kernels of core, as ``module.function``: the functions decorated
    ``@kernel(...)`` or ``@rule(...)`` (:mod:`plotgate.core.compiled`), read from the
    sources without importing (and so compiling) them."""
    spec = importlib.util.find_spec(package)
    roots = spec.submodule_search_locations if spec else None
    names: set[str] = set()
    for root in roots or ():
        for source in Path(root).rglob("*.py"):
            parts = source.relative_to(root).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            module = ".".join((package, *parts))
            tree = ast.parse(source.read_text(encoding="utf-8"))
            names.update(
                f"{module}.{node.name}"
                for node in tree.body
                if isinstance(node, ast.FunctionDef) and any(map(_compiles, node.decorator_list))
            )
    return frozenset(names)


def _compiles(decorator: ast.expr) -> bool:
    call = decorator.func if isinstance(decorator, ast.Call) else decorator
    return isinstance(call, ast.Name) and call.id in ("kernel", "rule")


def warm_order() -> list[str]:
    """The operations' handler modules in the order the warm-up compiles them."""
    names = [*MOST_USED, *(n for n in OPERATIONS if n not in MOST_USED)]
    return list(dict.fromkeys(OPERATIONS[n].module for n in names))


class Warmup:
    """The kernels' warm-up of one server process: started in the app's lifespan, on its
    event loop (:meth:`start`), stopped on shutdown (:meth:`close`).

    ``say`` writes a line to the console (the server's stderr); ``loaded`` is called on the
    event loop once every module the warm-up imported is loaded."""

    def __init__(
        self, say: Callable[[str], None], loaded: Callable[[], None] = lambda: None
    ) -> None:
        self.say = say
        self.on_loaded = loaded
        self.order = warm_order()
        self.modules = {op.name: op.module for op in OPERATIONS.values()}
        self.loaded = {m for m in self.order if m in sys.modules}
        self.queue = [m for m in self.order if m not in self.loaded]
        self.kernels = kernel_names()
        self.compiled: set[str] = set()
        self.started = time.monotonic()
        self.compiling_since: float | None = None
        self.lock = threading.Lock()
        self.events: dict[str, asyncio.Event] = {}
        self.loop: asyncio.AbstractEventLoop | None = None
        self.child: subprocess.Popen[str] | None = None
        self.thread: threading.Thread | None = None
        self.progress: asyncio.Task[None] | None = None
        self.closed = False

    def start(self) -> "Warmup":
        """Start the child and the thread that follows it (nothing when every handler is
        already imported, as in a process that served before)."""
        self.loop = asyncio.get_running_loop()
        self.events = {m: asyncio.Event() for m in self.order}
        for module in self.loaded:
            self.events[module].set()
        if self.queue:
            self.thread = threading.Thread(target=self._follow, name="warmup", daemon=True)
            self.thread.start()
            self.progress = asyncio.create_task(self._report_progress())
        return self

    def close(self) -> None:
        """Stop the child (its cache files are written whole or not at all) and the
        progress lines."""
        if self.progress is not None:
            self.progress.cancel()
        with self.lock:
            self.closed = True
            self.queue.clear()
            child = self.child
        if child is not None and child.poll() is None:
            child.kill()
        if self.thread is not None:
            self.thread.join(timeout=_JOIN_S)

    def is_ready(self, operation: str) -> bool:
        return self.modules[operation] in self.loaded

    async def wait(self, operation: str) -> None:
        """Return once ``operation``'s kernels are loaded; its module goes to the front of
        the queue meanwhile."""
        module = self.modules[operation]
        if module in self.loaded:
            return
        with self.lock:
            if module in self.queue:
                self.queue.remove(module)
                self.queue.insert(0, module)
        await self.events[module].wait()

    def report(self) -> dict[str, list[str]]:
        """The operations whose kernels are loaded, and those still compiling (or queued):
        ``/readyz``'s ``operations`` member."""
        ready = [name for name in self.modules if self.is_ready(name)]
        return {"ready": ready, "compiling": [n for n in self.modules if n not in ready]}

    def _next(self) -> str | None:
        with self.lock:
            return self.queue.pop(0) if self.queue and not self.closed else None

    def _follow(self) -> None:
        """The warm-up thread: hand the child one module at a time, follow its progress,
        import each module it finished; import the rest here if the child fails."""
        try:
            self._through_child()
        except (OSError, ValueError, _ChildFailed) as exc:
            if self.closed:
                return
            self.say(f"the warm-up process failed ({exc}); compiling in the server instead")
        while (module := self._next()) is not None:
            self._load(module)
        self._finished()

    def _through_child(self) -> None:
        with subprocess.Popen(
            CHILD, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        ) as child:
            self.child = child
            assert child.stdin is not None and child.stdout is not None
            while (module := self._next()) is not None:
                child.stdin.write(module + "\n")
                child.stdin.flush()
                self._until_done(module, child.stdout)
                self._load(module)

    def _until_done(self, module: str, lines: Iterable[str]) -> None:
        for line in lines:
            message = json.loads(line)
            if "compiled" in message:
                self._compiled(message["compiled"])
            elif "repaired" in message:
                self.say(message["repaired"])
            elif message.get("failed"):
                with self.lock:
                    self.queue.insert(0, module)
                raise _ChildFailed(message["failed"])
            elif message.get("done") == module:
                return
        with self.lock:
            self.queue.insert(0, module)
        raise _ChildFailed("it ended early")

    def _compiled(self, kernel: str) -> None:
        if self.compiling_since is None:
            self.compiling_since = time.monotonic()
            self.say(
                f"compiling {len(self.kernels)} numerical kernels (first start only, a minute or "
                "more); answering meanwhile: a request waits for its operation's kernels"
            )
        if kernel in self.kernels:
            self.compiled.add(kernel)

    def _load(self, module: str) -> None:
        """Import ``module`` here (from the cache the child wrote) and mark it ready."""
        try:
            load_kernels(lambda: None, module=module)
        except CacheRepairFailed as exc:
            self.say(f"cannot compile and cache the kernels of {module} ({exc})")
        except Exception as exc:  # noqa: BLE001 - a bug: its requests answer 500, none hangs
            self.say(f"cannot import {module}: {type(exc).__name__}: {exc}")
        self.loaded.add(module)
        if self.loop is not None:
            self.loop.call_soon_threadsafe(self.events[module].set)

    def _finished(self) -> None:
        if self.compiling_since is not None:
            elapsed = time.monotonic() - self.started
            self.say(
                f"every kernel ready in {elapsed:.0f} s (cached: later starts take a few seconds)"
            )
        if self.loop is not None and not self.closed:
            if self.progress is not None:
                self.loop.call_soon_threadsafe(self.progress.cancel)
            self.loop.call_soon_threadsafe(self.on_loaded)

    async def _report_progress(self) -> None:
        while True:
            await asyncio.sleep(PROGRESS_EVERY_S)
            if self.compiling_since is not None:
                ready = self.report()["ready"]
                self.say(
                    f"kernels: {len(self.compiled)} of {len(self.kernels)} compiled, "
                    f"{time.monotonic() - self.started:.0f} s; {len(ready)} of "
                    f"{len(self.modules)} operations ready"
                )


def readiness(warmup: Warmup | None) -> dict[str, list[str]]:
    """``/readyz``'s ``operations``: :meth:`Warmup.report`, or every operation ready where
    no warm-up runs (an app without its lifespan imports each handler on first use)."""
    return warmup.report() if warmup is not None else {"ready": list(OPERATIONS), "compiling": []}


class KernelsFirst:
    """ASGI middleware in front of the operations: a ``POST`` to an operation whose kernels
    the warm-up has not loaded yet waits for them (:meth:`Warmup.wait`), so it never runs a
    compilation on the event loop and is never refused for it. It sits inside the guards:
    an unauthenticated caller waits for nothing."""

    def __init__(self, app: ASGIApp, state: State) -> None:
        self.app = app
        self.state = state
        self.paths = {op.path: op.name for op in OPERATIONS.values()}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        warmup: Warmup | None = getattr(self.state, "warmup", None)
        if warmup is not None and scope["type"] == "http" and scope["method"] == "POST":
            name = self.paths.get(route_path(scope))
            if name is not None and not warmup.is_ready(name):
                await warmup.wait(name)
        await self.app(scope, receive, send)


class _ChildFailed(RuntimeError):
    """The warm-up process ended or failed before finishing a module."""


def _child() -> None:
    """The warm-up process: for each module named on stdin, import it (compiling and
    caching its kernels), saying each kernel compiled and then the module done, as JSON
    lines on stdout."""
    from numba.core import event as numba_event

    class Compiled(numba_event.Listener):
        def on_start(self, event: numba_event.Event) -> None:
            pass

        def on_end(self, event: numba_event.Event) -> None:
            function = event.data["dispatcher"].py_func
            _send({"compiled": f"{function.__module__}.{function.__qualname__}"})

    for line in sys.stdin:
        module = line.strip()
        try:
            with numba_event.install_listener("numba:compile", Compiled()):
                load_kernels(lambda: None, module=module, repaired=_repaired)
        except Exception as exc:  # noqa: BLE001 - the server compiles it instead, and says why
            _send({"failed": f"{module}: {type(exc).__name__}: {exc}"})
            return
        _send({"done": module})


def _repaired(exc: Exception, removed: int) -> None:
    _send(
        {
            "repaired": f"numba's cache of the kernels was unreadable ({type(exc).__name__}: "
            f"{exc}); removed its {removed} files"
        }
    )


def _send(message: dict[str, str]) -> None:
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


if __name__ == "__main__":
    _child()
