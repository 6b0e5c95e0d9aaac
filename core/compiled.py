"""Compiled kernels: numba's JIT with one set of options for every kernel in core.

Where numpy's per-call overhead sets the speed (small problems, iterations with step
control, quadrature nodes, per-pair gate tests), a kernel compiled by numba does the work.
Each kernel sits next to the numpy (or scipy) reference it replaces, in the same module,
and the tests hold the two together on random batches and on the edge cases.

:func:`kernel` compiles eagerly, for the signature it is given, when its module is
imported: the service imports every operation before it answers ``/readyz``, so no
request pays for a compilation. ``cache=True`` keeps the machine code on disk, so an
import after the first loads it in milliseconds. numba writes that cache in a
``__pycache__`` folder beside the source, or in ``NUMBA_CACHE_DIR`` when it is set: where
the installed package is read-only (a container's site-packages), point
``NUMBA_CACHE_DIR`` at a folder the service's user can write. The Docker image does, and
compiles the kernels while it is built, so a container starts warm.

Kernels use numpy's error model (a division by zero gives inf or nan, as in the
reference, rather than raising) and no fast-math, so they round as the reference does.
"""

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba

__all__ = ["kernel"]

F = TypeVar("F", bound=Callable[..., Any])


def kernel(signature: str, *, parallel: bool = False) -> Callable[[F], F]:
    """Compile a function for ``signature`` now, with numba's nopython mode, cached.

    ``parallel=True`` lets ``numba.prange`` loops run on every core (kernels whose
    iterations are independent problems: a batch of solves, of gate pairs).

    A kernel is a module-level function (numba caches by source file)::

        @kernel("float64(float64[:])")
        def total(x):
            s = 0.0
            for v in x:
                s += v
            return s
    """
    # a Dispatcher calls like the function it compiles; the kernels are typed as that function
    jit = numba.njit(signature, cache=True, nogil=True, parallel=parallel, error_model="numpy")
    return cast(Callable[[F], F], jit)
