"""Issue 27's and 40's solver aims in one run: CPU time (process_time), one thread, peers alike.

Run from the repository root (``OPENBLAS_NUM_THREADS=1 python bench/bench_solver_aims.py``,
``--quick`` for CI):

* single shot: ``ml_solve`` on the two batches of 10^4 problems of
  ``bench_multistatic.py`` (the same seed and draws, so the same problems): the
  ``study`` batch (the study's forward-scatter geometry, drawn first) and the ``spread``
  batch (receivers 2.5 km apart across the track, drawn next), each against its numpy
  reference and against scipy's ``least_squares(method="lm")``, one call a problem from
  the batched sum-range closed form (whose time is added);
* trajectory: ``trajectory_solve`` on the study's 200 samples from its own start and
  from a given start, against ``lm`` from that given start (5 noise draws, mean of the
  least of 15).

CPU time, so a shared machine's waits are not counted; one numba and one BLAS thread, as
scipy runs. Ends with one ``SUMMARY`` line per aim (bench/README.md's front table).
"""

import argparse
import json
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

SINGLE_SHOT_AIM = 100.0  # lm's time over ml_solve's, at least
TRAJECTORY_AIM = 0.3  # own start's time over lm's from the given start, at most


def cpu(f, r):
    """Least CPU seconds of r calls."""
    b = np.inf
    for _ in range(r):
        t = time.process_time()
        f()
        b = min(b, time.process_time() - t)
    return b


def single_shot(
    name: str, sc: bm.Scenario, size: int, repeats: int, rng: np.random.Generator
) -> tuple[str, float]:
    """ml_solve, its reference and lm on one batch: (line, lm / ml_solve)."""
    ls, tx, rx, _ = bm.problems(sc, size, rng)
    ml_solve(ls, tx, rx, bm.SIGMA)
    core = cpu(lambda: ml_solve(ls, tx, rx, bm.SIGMA), repeats)
    ref = cpu(lambda: ml_solve_reference(ls, tx, rx, bm.SIGMA), 2)
    closed = cpu(lambda: sum_range_solve(ls, tx, rx, baseline_tol=5 * bm.SIGMA), 3)
    starts = sum_range_solve(ls, tx, rx, baseline_tol=5 * bm.SIGMA).x
    began = time.process_time()
    bm.scipy_batch(ls, tx, rx, starts, "lm")
    lm = time.process_time() - began + closed
    us = 1e6 / size
    return (
        f"single shot, {size:,} {name} problems: ml_solve {core * us:.2f} us, "
        f"ml_solve_reference {ref * us:.2f} us, lm + closed form {lm * us:.1f} us; "
        f"lm / ml_solve {lm / core:.1f}x"
    ), lm / core


def trajectory(rng: np.random.Generator, draws: int, repeats: int) -> tuple[str, float, float]:
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
        own.append(cpu(lambda ls=ls: trajectory_solve(ls, sc.t, sc.tx, sc.rx, bm.SIGMA), repeats))
        given.append(
            cpu(
                lambda ls=ls, x0=x0: trajectory_solve(ls, sc.t, sc.tx, sc.rx, bm.SIGMA, x0=x0),
                repeats,
            )
        )
        lms.append(
            cpu(lambda x0=x0, f=fun, j=jac: least_squares(f, x0, jac=j, method="lm"), repeats)
        )
    o, g, m = np.mean(own), np.mean(given), np.mean(lms)
    return (
        (
            f"trajectory, 200 samples: own start {o * 1e3:.3f} ms, given start {g * 1e3:.3f} ms, "
            f"lm from the given start {m * 1e3:.3f} ms; "
            f"own / lm {o / m:.2f}, given / lm {g / m:.2f}"
        ),
        o / m,
        g / m,
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


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> str:
    """One front-table row, as bench/README.md's protocol prints it (met None: no aim)."""
    fields = {
        "row": row,
        "workload": workload,
        "peer": peer,
        "measured": measured,
        "aim": aim,
        "met": None if met is None else bool(met),
    }
    return "SUMMARY " + json.dumps(fields)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="1,000 problems, 2 draws (CI: the same paths)"
    )
    args = parser.parse_args(argv)
    size, repeats, draws = (1_000, 3, 2) if args.quick else (10_000, 7, 5)
    generator = np.random.default_rng(bm.SEED)
    lines, rows = [], []
    for name, sc in (("study", bm.scenario()), ("spread", bm.spread_scenario())):
        line, ratio = single_shot(name, sc, size, repeats, generator)
        lines.append(line)
        rows.append(
            summary(
                f"solvers.single_shot.{name}",
                f"ml_solve, {size:,} single-shot problems, {name} batch (bench_multistatic's "
                "draws), one thread, CPU time",
                "scipy least_squares lm + the closed-form start, one call a problem",
                f"{ratio:.1f}x lm",
                f">= {SINGLE_SHOT_AIM:.0f}x",
                ratio >= SINGLE_SHOT_AIM,
            )
        )
        print(line, flush=True)
    line, own, given = trajectory(generator, draws, 15 if not args.quick else 5)
    print(line)
    workload = "trajectory_solve, 200 samples x 3 range sums, one thread, CPU time"
    peer = "scipy least_squares lm from the given start (a line through the closed form)"
    rows.append(
        summary(
            "solvers.trajectory.own_start",
            workload + ", own start",
            peer,
            f"{own:.2f}x lm",
            f"<= {TRAJECTORY_AIM}x",
            own <= TRAJECTORY_AIM,
        )
    )
    rows.append(
        summary(
            "solvers.trajectory.given_start",
            workload + ", given start",
            peer,
            f"{given:.2f}x lm",
            "none",
            None,
        )
    )
    for row in rows:
        print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
