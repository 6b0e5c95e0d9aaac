"""Issue 27's two solver aims in one run: CPU time (process_time), one thread, peers alike.

Run from the repository root (``OPENBLAS_NUM_THREADS=1 python bench/bench_solver_aims.py``):

* single shot: ``ml_solve`` on the 10^4 study problems of ``bench_multistatic.py`` (same
  seed) against its numpy reference and against scipy's ``least_squares(method="lm")``,
  one call a problem from the batched sum-range closed form (whose time is added);
* trajectory: ``trajectory_solve`` on the study's 200 samples from its own start and
  from a given start, against ``lm`` from that given start (5 noise draws, mean of the
  least of 15).

CPU time, so a shared machine's waits are not counted; one numba and one BLAS thread, as
scipy runs.
"""

import sys
import time

import numba
import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, "bench")
import bench_multistatic as bm  # noqa: E402

from plotgate.core.multistatic import ml_solve, sum_range_solve, trajectory_solve  # noqa: E402
from plotgate.core.multistatic.position import ml_solve_reference  # noqa: E402

numba.set_num_threads(1)


def cpu(f, r):
    """Least CPU seconds of r calls."""
    b = np.inf
    for _ in range(r):
        t = time.process_time()
        f()
        b = min(b, time.process_time() - t)
    return b


def single_shot(rng: np.random.Generator) -> str:
    """ml_solve, its reference and lm on the 10^4 study problems."""
    ls, tx, rx, _ = bm.problems(bm.scenario(), 10_000, rng)
    ml_solve(ls, tx, rx, bm.SIGMA)
    core = cpu(lambda: ml_solve(ls, tx, rx, bm.SIGMA), 7)
    ref = cpu(lambda: ml_solve_reference(ls, tx, rx, bm.SIGMA), 2)
    closed = cpu(lambda: sum_range_solve(ls, tx, rx, baseline_tol=5 * bm.SIGMA), 3)
    starts = sum_range_solve(ls, tx, rx, baseline_tol=5 * bm.SIGMA).x
    began = time.process_time()
    bm.scipy_batch(ls, tx, rx, starts, "lm")
    lm = time.process_time() - began + closed
    return (
        f"single shot, 10^4 study problems: ml_solve {core * 100:.2f} us, "
        f"ml_solve_reference {ref * 100:.2f} us, lm + closed form {lm * 100:.1f} us; "
        f"lm / ml_solve {lm / core:.1f}x"
    )


def trajectory(rng: np.random.Generator, draws: int = 5) -> str:
    """trajectory_solve, own start and given start, against lm from the given start."""
    sc = bm.scenario()
    tau = sc.t - sc.t[0]
    clean = bm.range_sums(sc.x, sc.tx, sc.rx)
    own, given, lms = [], [], []
    for _ in range(draws):
        ls = clean + bm.SIGMA * rng.standard_normal(clean.shape)
        x0 = bm.line_start(sc, ls)
        fun, jac = track_residuals(sc, tau, ls.reshape(-1))
        trajectory_solve(ls, sc.t, sc.tx, sc.rx, bm.SIGMA)
        own.append(cpu(lambda ls=ls: trajectory_solve(ls, sc.t, sc.tx, sc.rx, bm.SIGMA), 15))
        given.append(
            cpu(lambda ls=ls, x0=x0: trajectory_solve(ls, sc.t, sc.tx, sc.rx, bm.SIGMA, x0=x0), 15)
        )
        lms.append(cpu(lambda x0=x0, f=fun, j=jac: least_squares(f, x0, jac=j, method="lm"), 15))
    o, g, m = np.mean(own), np.mean(given), np.mean(lms)
    return (
        f"trajectory, 200 samples: own start {o * 1e3:.3f} ms, given start {g * 1e3:.3f} ms, "
        f"lm from the given start {m * 1e3:.3f} ms; own / lm {o / m:.2f}, given / lm {g / m:.2f}"
    )


def track_residuals(sc, tau, flat):
    """Residuals and Jacobian of a constant-velocity track for scipy (numpy only)."""
    n_t, p, _ = sc.tx.shape

    def fun(theta):
        x = theta[:2] + tau[:, None] * theta[2:]
        d, e = x[:, None] - sc.rx, x[:, None] - sc.tx
        h = np.sqrt((d * d).sum(-1)) + np.sqrt((e * e).sum(-1))
        return (flat - h.reshape(-1)) / bm.SIGMA

    def jac(theta):
        x = theta[:2] + tau[:, None] * theta[2:]
        d, e = x[:, None] - sc.rx, x[:, None] - sc.tx
        H = d / np.sqrt((d * d).sum(-1))[..., None] + e / np.sqrt((e * e).sum(-1))[..., None]
        return -np.concatenate([H, tau[:, None, None] * H], -1).reshape(n_t * p, 4) / bm.SIGMA

    return fun, jac


if __name__ == "__main__":
    generator = np.random.default_rng(bm.SEED)
    print(single_shot(generator))
    print(trajectory(generator))
