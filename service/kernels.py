"""Loading every compiled kernel before a command runs, and saying so when they compile.

The kernels of :mod:`plotgate.core` compile for their signatures when their modules are
imported (:mod:`plotgate.core.compiled`), and numba keeps the machine code in its disk
cache. With an empty cache (a fresh clone, a new numba, a new ``NUMBA_CACHE_DIR``) that
import compiles about eighty functions, a minute or more on a small machine; with a warm
cache it takes about a second. Before, the first ``plotgate serve`` said nothing for that
minute and looked hung; :func:`load_kernels` lets the command say what is happening.

It watches numba's ``"numba:compile"`` event, which fires for a compilation and never for
a load from the cache, so the announcement comes only when something really compiles (a
first start, or a cache numba threw away). The watch lives here, not in core: importing
any module of :mod:`plotgate.core` imports all of them, and so compiles every kernel,
before a listener installed from inside core could see it.
"""

import importlib
import time
from collections.abc import Callable

from numba.core import event as numba_event

__all__ = ["load_kernels"]


class _FirstCompile(numba_event.Listener):
    """Calls ``announce`` at the start of the first compilation it sees."""

    def __init__(self, announce: Callable[[], None]) -> None:
        self.announce = announce
        self.compiled = False

    def on_start(self, event: numba_event.Event) -> None:
        if not self.compiled:
            self.compiled = True
            self.announce()

    def on_end(self, event: numba_event.Event) -> None:
        pass


def load_kernels(
    announce: Callable[[], None], module: str = "plotgate.service.registry"
) -> float | None:
    """Import ``module`` (by default the registry: every operation, and so every kernel)
    and call ``announce()`` once if a kernel compiles meanwhile.

    Returns the seconds the import took when something compiled, None when every kernel
    came from numba's cache or was already loaded.
    """
    listener = _FirstCompile(announce)
    started = time.monotonic()
    with numba_event.install_listener("numba:compile", listener):
        importlib.import_module(module)
    return time.monotonic() - started if listener.compiled else None
