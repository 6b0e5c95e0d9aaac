"""Throughput of the core gates on N = 10^6 seeded random pairs.

Run from the repository root::

    python bench/bench_gates.py            # 10^6 pairs, best of 5, and the kernels' import cost
    python bench/bench_gates.py --quick    # 10^5 pairs, best of 2, no import timing (CI)

Each gate is timed end to end (input validation included) as the best of 5 runs
with time.perf_counter, and reported as pair tests per second. The baseline is
the ellipse gate's rho = nu^T S^-1 nu computed the naive vectorized way, with
np.linalg.solve over the batch and no validation; the last column is each
gate's throughput relative to it. The gates with a compiled kernel (ellipse,
combined, sector, first association) are timed beside their numpy
``test_reference``. Prints a markdown table, then the first-call cost of the kernels:
importing plotgate.core with an empty ``NUMBA_CACHE_DIR`` (compiling) and again with
the cache that import wrote (loading). Ends with the ``SUMMARY`` lines of the front table
(bench/README.md): the ellipse and combined gates against their aims.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numpy as np
import scipy

from plotgate.core import (
    CombinedGate,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    RectangularGate,
    RingGate,
    SectorGate,
    gate_threshold,
)

N = 10**6
REPEATS = 5
SEED = 20240601
AIMS = {"EllipseGate": 1e7, "CombinedGate": 3e6}
"""Pair tests per second on one core each compiled gate aims at (bench/HISTORY.md)."""


def best_time(run: Callable[[], object], repeats: int) -> float:
    """Best wall time of ``repeats`` calls, in seconds."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def random_covariances(rng: np.random.Generator, n: int, sigma: float) -> np.ndarray:
    """n random symmetric positive definite 2x2 matrices with scale sigma^2."""
    A = rng.normal(0.0, sigma, (n, 2, 2))
    return A @ A.transpose(0, 2, 1) + 0.1 * sigma**2 * np.eye(2)


def solve_baseline(z: np.ndarray, z_pred: np.ndarray, S: np.ndarray, P_G: float) -> np.ndarray:
    """rho = nu^T S^-1 nu <= gamma with one batched np.linalg.solve (no validation)."""
    nu = z - z_pred
    x = np.linalg.solve(S, nu[..., None])[..., 0]
    rho = np.einsum("ni,ni->n", nu, x)
    return rho <= gate_threshold(P_G)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10^5 pairs, best of 2 (CI)")
    args = parser.parse_args(argv)
    n, repeats = (10**5, 2) if args.quick else (N, REPEATS)
    rng = np.random.default_rng(SEED)
    z1 = rng.uniform(-5e4, 5e4, (N, 2))
    z2 = z1 + rng.uniform(-3000.0, 3000.0, (N, 2))
    P1 = random_covariances(rng, N, 150.0)
    P2 = random_covariances(rng, N, 150.0)
    S = P1 + P2
    sigma_r = rng.uniform(50.0, 250.0, N)
    sigma_az = rng.uniform(1e-3, 1e-2, N)
    r1, r2 = np.hypot(z1[:, 0], z1[:, 1]), np.hypot(z2[:, 0], z2[:, 1])
    az1, az2 = np.arctan2(z1[:, 0], z1[:, 1]), np.arctan2(z2[:, 0], z2[:, 1])

    baseline_inside = solve_baseline(z2, z1, S, 0.9)
    if not np.array_equal(EllipseGate(0.9).test(z2, z1, S).inside, baseline_inside):
        sys.exit("EllipseGate and the solve baseline disagree")

    ellipse, combined = EllipseGate(0.9), CombinedGate(100.0, 500.0, 0.9)
    sector, first = SectorGate(3.0, 3.0), FirstAssociationGate(500.0, 3.0, 3.0)
    sector_args = (r2, az2, r1, az1, sigma_r, sigma_az, sigma_r, sigma_az)
    first_args = (r1, az1, r2, az2, 5.0, sigma_r, sigma_az, sigma_r, sigma_az)
    compiled: list[tuple[str, Callable[[], object]]] = [
        ("EllipseGate", lambda: ellipse.test(z2, z1, S)),
        ("CombinedGate", lambda: combined.test(z1, P1, z2, P2, 5.0)),
        ("SectorGate", lambda: sector.test(*sector_args)),
        ("FirstAssociationGate", lambda: first.test(*first_args)),
    ]
    cases: list[tuple[str, Callable[[], object]]] = [
        ("baseline: ellipse rho via np.linalg.solve", lambda: solve_baseline(z2, z1, S, 0.9)),
        ("EllipseGate, numpy reference", lambda: ellipse.test_reference(z2, z1, S)),
        ("CombinedGate, numpy reference", lambda: combined.test_reference(z1, P1, z2, P2, 5.0)),
        ("SectorGate, numpy reference", lambda: sector.test_reference(*sector_args)),
        ("FirstAssociationGate, numpy reference", lambda: first.test_reference(*first_args)),
        ("RingGate", lambda: RingGate(100.0, 500.0).test(z1, z2, 5.0)),
        ("ExpandedGate", lambda: ExpandedGate(500.0, 0.9).test(z1, z2, 5.0, sigma_r, sigma_az)),
        ("RectangularGate", lambda: RectangularGate(2.0).test(z2, z1, sigma_r, sigma_r)),
    ]
    rates = {name: n / best_time(run, repeats) for name, run in cases}
    rates |= {f"{name}, compiled kernel": n / best_time(run, repeats) for name, run in compiled}
    baseline = rates[cases[0][0]]

    print(
        f"N = {n:,} pairs, best of {repeats}, seed {SEED}; Python {platform.python_version()},"
        f" numpy {np.__version__}, scipy {scipy.__version__}, {os.cpu_count()} CPUs"
        f" ({platform.machine()})\n"
    )
    print("| gate | best time (ms) | pair tests / s | vs solve baseline |")
    print("|---|---:|---:|---:|")
    for name, rate in sorted(rates.items(), key=lambda item: item[0].split(",")[0]):
        print(f"| {name} | {1e3 * n / rate:.1f} | {rate:.3g} | {rate / baseline:.1f}x |")
    if not args.quick:
        cold, warm = kernel_import_times()
        print(
            f"\nImporting plotgate.core: {cold:.2f} s with an empty NUMBA_CACHE_DIR"
            f" (compiling its kernels), {warm:.2f} s from the cache it wrote."
        )
    print()
    for name, aim in AIMS.items():
        rate = rates[f"{name}, compiled kernel"]
        row = {
            "row": f"gates.{name}",
            "workload": f"{name}.test on {n:,} random pairs, pair tests/s",
            "peer": "ellipse rho via np.linalg.solve (no validation)",
            "measured": f"{rate:.3g}/s, {rate / baseline:.1f}x the peer",
            "aim": f">= {aim:.0e}/s",
            "met": rate >= aim,
        }
        print("SUMMARY " + json.dumps(row))


def kernel_import_times() -> tuple[float, float]:
    """Seconds to import plotgate.core in a fresh process: empty kernel cache, then warm.

    The difference is the compilation of core's kernels (importing compiles them).
    """
    code = (
        "import time; t = time.perf_counter(); import plotgate.core;"
        " print(time.perf_counter() - t)"
    )
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        times = [
            float(
                subprocess.run(
                    [sys.executable, "-c", code],
                    env=env,
                    check=True,
                    capture_output=True,
                    text=True,
                ).stdout
            )
            for _ in range(2)
        ]
    return times[0], times[1]


if __name__ == "__main__":
    main()
