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

A kernel of many arrays takes them as one structured argument, a ``typing.NamedTuple``
whose numba type :func:`record` states once (numba passes named tuples by value, each
field typed); the kernel's signature then names the record, never its 12-20 arrays.

Kernels use numpy's error model (a division by zero gives inf or nan, as in the
reference, rather than raising) and no fast-math, so they round as the reference does.
"""

from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba

__all__ = ["ARRAY_1D", "ARRAY_2D", "ARRAY_3D", "kernel", "record", "rule", "tuple_of"]

_types: Any = numba.types  # numba's type constructors are untyped
_njit: Any = numba.njit  # its stubs do not list the _nrt option

ARRAY_1D = numba.float64[::1]
"""numba type of a C-contiguous float64 vector."""
ARRAY_2D = numba.float64[:, ::1]
"""numba type of a C-contiguous float64 matrix."""
ARRAY_3D = numba.float64[:, :, ::1]
"""numba type of a C-contiguous float64 array of three axes."""

F = TypeVar("F", bound=Callable[..., Any])


def record(cls: type, *fields: Any) -> Any:
    """The numba type of the named tuple ``cls`` whose fields have the numba types ``fields``.

    One class may have several record types (a batch of problems and one problem of it,
    say): numba types each field of a named tuple on its own.
    """
    names = getattr(cls, "_fields")  # noqa: B009 (a named tuple's field names)
    if len(fields) != len(names):
        raise TypeError(f"{cls.__name__} has {len(names)} fields, got {len(fields)} types")
    return _types.NamedTuple(fields, cls)


def tuple_of(*fields: Any) -> Any:
    """The numba type of a tuple of the given numba types (a kernel returning several values)."""
    return _types.Tuple(fields)


def kernel(
    signature: Any, *, parallel: bool = False, inline: bool = False, refcounts: bool = True
) -> Callable[[F], F]:
    """Compile a function for ``signature`` now, with numba's nopython mode, cached.

    ``signature`` is numba's signature string, or a signature built from numba types
    (``numba.void(RECORD, numba.int64)``) when an argument is a :func:`record`.

    ``parallel=True`` lets ``numba.prange`` loops run on every core (kernels whose
    iterations are independent problems: a batch of solves, of gate pairs).

    ``inline=True`` inlines the function into the kernels that call it (numba's IR
    inlining), for small helpers called in a hot loop: a call that passes records
    counts a reference for each of their arrays, which cost the Gauss-Newton engine
    two thirds of its time before its helpers were inlined.

    ``refcounts=False`` compiles without numba's runtime (its ``_nrt`` option, the flag
    numba's own tests set): no reference is counted for the arrays the kernel reads,
    slices or passes on, and it cannot allocate one. For a kernel taking only arrays
    its caller allocated, called once per problem of a batch: the atomic counts of its
    records' arrays cost the fused single shot about a fifth of its time (0.6-0.7 us of
    2.2-3.5 us a solve). Kernels it calls keep their own runtime.

    A kernel is a module-level function (numba caches by source file)::

        @kernel("float64(float64[:])")
        def total(x):
            s = 0.0
            for v in x:
                s += v
            return s
    """
    # a Dispatcher calls like the function it compiles; the kernels are typed as that function
    jit = _njit(
        signature,
        cache=True,
        nogil=True,
        parallel=parallel,
        error_model="numpy",
        inline="always" if inline else "never",
        _nrt=refcounts,
    )
    return cast(Callable[[F], F], jit)


def rule(signature: str) -> Callable[[Callable[..., Any]], Any]:
    """Compile a scalar function as a numpy ufunc (``numba.vectorize``), cached.

    A rule is written once and called by both sides of a kernel's pair: by the kernel
    on scalars and by its numpy reference on arrays, element by element, with the same
    arithmetic (a decision such as a convergence test cannot drift between the two).
    """
    vectorize: Any = numba.vectorize
    return cast(Callable[[Callable[..., Any]], Any], vectorize([signature], cache=True))
