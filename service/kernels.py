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

numba trusts its cache files: a damaged one (cut short, overwritten) makes the import
raise whatever unpickling it raises, and numba does not recover. :func:`load_kernels`
then removes plotgate's cache files and compiles again, once: the cache is only a cache,
and a start that repairs it is what a user expects of it. The files are found where numba
puts them (its documented rule): in ``NUMBA_CACHE_DIR`` when set, else in ``__pycache__``
beside each source file.
"""

import hashlib
import importlib
import importlib.util
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

from numba.core import event as numba_event

__all__ = ["CacheRepairFailed", "cache_files", "load_kernels"]


class CacheRepairFailed(RuntimeError):
    """The kernels failed to load or compile even with their cache files removed."""


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


def cache_files(package: str = "plotgate.core") -> list[Path]:
    """numba's cache files (index ``.nbi``, data ``.nbc``) of the package's source files,
    found without importing the package."""
    spec = importlib.util.find_spec(package)
    roots = spec.submodule_search_locations if spec else None
    sources = sorted(p for root in roots or () for p in Path(root).rglob("*.py"))
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    found: set[Path] = set()
    for source in sources:
        folder = os.path.dirname(os.path.abspath(source))
        if cache_dir:  # numba's own naming: the folder's name and its path's SHA-1
            digest = hashlib.sha1(folder.encode()).hexdigest()
            cache = Path(cache_dir) / f"{os.path.basename(folder)}_{digest}"
        else:
            cache = Path(folder) / "__pycache__"
        for pattern in (f"{source.stem}.*.nbi", f"{source.stem}.*.nbc"):
            found.update(cache.glob(pattern))
    return sorted(found)


def _forget_modules(loaded: set[str]) -> None:
    """Drop the modules a failed import left loaded, so the next import compiles their
    kernels too and caches them again (their files were removed with the damaged ones).

    Modules ``loaded`` before the import began stay: an in-process replay loads each
    operation as it meets it, and the modules it already runs (the registry, core's errors)
    must stay the ones its running code refers to. Their kernels stay compiled in memory
    and are cached again by the next process."""
    for name in [m for m in sys.modules if m.startswith(("plotgate.core", "plotgate.service."))]:
        if name != __name__ and name not in loaded:
            del sys.modules[name]


def _watched_import(announce: Callable[[], None], module: str | None) -> bool:
    """Import ``module`` (None: every operation's handler); whether a kernel compiled
    meanwhile."""
    listener = _FirstCompile(announce)
    with numba_event.install_listener("numba:compile", listener):
        if module is None:
            importlib.import_module("plotgate.service.registry").load_all()
        else:
            importlib.import_module(module)
    return listener.compiled


def load_kernels(
    announce: Callable[[], None],
    module: str | None = None,
    repaired: Callable[[Exception, int], None] = lambda exc, removed: None,
    package: str = "plotgate.core",
) -> float | None:
    """Import ``module`` (by default every operation's handler, and so every kernel: see
    :func:`plotgate.service.registry.load_all`; one operation's handler module loads just
    its kernels) and call ``announce()`` once if a kernel compiles meanwhile.

    When the import fails with cache files of ``package`` (where the kernels are)
    present, they are removed, ``repaired(exc,
    how many)`` is called, and the import is tried once more; a second failure raises
    :class:`CacheRepairFailed`. Returns the seconds the import took when something
    compiled, None when every kernel came from numba's cache or was already loaded.
    """
    started = time.monotonic()
    loaded = set(sys.modules)
    try:
        compiled = _watched_import(announce, module)
    except Exception as exc:  # noqa: BLE001 - numba raises what unpickling a damaged file raises
        damaged = cache_files(package)
        if not damaged:
            raise
        for path in damaged:
            path.unlink(missing_ok=True)
        _forget_modules(loaded)
        repaired(exc, len(damaged))
        try:
            compiled = _watched_import(announce, module)
        except Exception as again:  # noqa: BLE001 - a full disk, an unwritable cache
            raise CacheRepairFailed(f"{type(again).__name__}: {again}") from again
    return time.monotonic() - started if compiled else None
