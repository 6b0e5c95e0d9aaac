"""Cost of multistatic range-sum position solves, against scipy.optimize.least_squares.

Run from the repository root::

    python bench/bench_multistatic.py                  # 10^4 problems, 20 tracks
    python bench/bench_multistatic.py --quick          # CI: 10^3 problems, 3 tracks
    python bench/bench_multistatic.py --trap-only      # the initial-guess trap alone

Problems come from the accuracy study's scenario (``clients.study.DEFAULT_REQUEST``, run
by ``plotgate study``: one transmitter and three receivers on platforms at 10 m/s,
baselines about 10 km, the target at 80 m/s crossing them, sigma 0.5 m): each
single-shot problem is one of its 200 samples, drawn at random, with fresh noise
(seeded). A second set puts the receivers 2.5 km apart across the track (``spread``), a
better-conditioned geometry where Gauss-Newton needs fewer steps.

* Single shot: ``ml_solve`` on the whole batch (validation and the closed-form start
  included), best of ``--repeats``. The Gauss-Newton iterations alone, from the closed
  form's roots: the compiled engine (``gauss_newton``, what ``ml_solve``
  runs) against the numpy reference (``gauss_newton_reference``) on the same starts. The
  baselines, in the same run on the same problems, are
  ``scipy.optimize.least_squares`` (``trf``, its default, and ``lm``, MINPACK) with the
  analytic Jacobian, one call per problem (scipy has no batch), each started from
  the sum-range closed form; the batched closed form's time is added to theirs. Their
  answers are compared with ml_solve's (distance in metres and in sigmas of
  ml_solve's covariance).
* Trajectory: ``trajectory_solve`` on the study's 200 samples (600 range sums, 4
  unknowns), end to end with its own start, from a given start, and all ``--tracks``
  tracks in one batched call (time per track); the baselines solve the same problem from
  the given start (a straight line fitted to the per-sample closed-form positions). Mean
  over ``--tracks`` noise draws of the best of ``--repeats``.
* The initial-guess trap: at the instant the target crosses the central baseline
  (sample 112), ``--trap-runs`` noise draws, each with a start 500 m from the truth in
  a random direction (its own seeded generator, so the figures do not depend on the
  other sections' sizes). A solve is trapped when it ends more than 10 CRLB standard
  deviations (Mahalanobis, at the truth) from the truth, the accuracy study's bound on
  any ML error. Before, the start alone: plain ``least_squares`` (trf, one call per
  problem) and ``ml_solve(..., closed_form_starts=False)`` (what ``solves.position``
  did with ``initial``). After: ``ml_solve`` with ``x0`` (the start plus the closed
  form's roots), and without; then the operation ``solves.position`` itself
  (in-process, the validated request, one request of all the problems) with and
  without ``initial``. Times are CPU seconds per solve (``time.process_time``: a busy
  machine's waits are not counted), the least of ``--repeats`` round-robin rounds of
  the five calls in the same run (scipy's: one pass).
  The script exits 1 when anything after is trapped.

The ratio columns are scipy's time over core's (above 1: core is faster). Prints markdown,
then one ``SUMMARY`` line per front-table row (bench/README.md): single shot on each batch
(lm over ml_solve on one thread), trajectory from its own and from a given start (over lm).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numba
import numpy as np
import scipy
from scipy.optimize import least_squares

from plotgate.clients.study import DEFAULT_REQUEST
from plotgate.core.multistatic import (
    MLSolution,
    crlb,
    ml_solve,
    platform_positions,
    range_sums,
    sum_range_solve,
    trajectory_solve,
)
from plotgate.core.multistatic.gauss_newton import (
    consistency_threshold,
    gauss_newton,
    gauss_newton_reference,
)
from plotgate.core.multistatic.model import range_sum_jacobian_unchecked, range_sums_unchecked
from plotgate.service.operations.solves import position
from plotgate.service.schemas import PositionSolveRequest, PositionSolveResult

SEED = 20261123
SIGMA = 0.5
ALPHA = 0.01
CROSS = 112  # the sample at which the target is on the central baseline
TRAP_OFFSET = 500.0  # m
TRAPPED = 10.0  # CRLB standard deviations from the truth: a false minimum
SPREAD_RX0 = np.array([[150.0, -1500.0], [600.0, 1000.0], [150.0, 3500.0]])


@dataclass(frozen=True)
class Scenario:
    t: np.ndarray  # (T,)
    tx: np.ndarray  # (T, P, D)
    rx: np.ndarray  # (T, P, D)
    x: np.ndarray  # (T, D) the true target positions


def scenario() -> Scenario:
    """The platforms and target of ``plotgate study``'s default request."""
    req = DEFAULT_REQUEST
    t = np.array(req["sample_times"])
    tx = platform_positions(req["transmitter"]["position"], req["transmitter"]["velocity"], t)
    rx0 = np.array([r["position"] for r in req["receivers"]])
    rx = platform_positions(rx0, req["receivers"][0]["velocity"], t)
    x = np.array(req["target"]["position"]) + t[:, None] * np.array(req["target"]["velocity"])
    return Scenario(t, np.repeat(tx[:, None], rx0.shape[0], axis=1), rx, x)


def spread_scenario() -> Scenario:
    """The same with the receivers 2.5 km apart across the track."""
    base = scenario()
    rx0 = np.array([r["position"] for r in DEFAULT_REQUEST["receivers"]])
    return replace(base, rx=base.rx + (SPREAD_RX0 - rx0)[None])


def best_time(run: Callable[[], object], repeats: int) -> float:
    """Best wall time of ``repeats`` calls, in seconds."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def problems(
    sc: Scenario, size: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``size`` single-shot problems: (l (N, P), tx, rx (N, P, D), truth (N, D))."""
    i = rng.integers(0, sc.t.size, size)
    tx, rx, x = sc.tx[i], sc.rx[i], sc.x[i]
    ls = range_sums(x, tx, rx) + SIGMA * rng.standard_normal((size, tx.shape[1]))
    return ls, tx, rx, x


def _direct_residuals(tx: np.ndarray, rx: np.ndarray):
    """The same residuals without core's input checks (numpy only), for scipy."""

    def fun(x: np.ndarray, l: np.ndarray) -> np.ndarray:  # noqa: E741
        d = x - rx
        e = x - tx
        return (l - np.sqrt((d * d).sum(-1)) - np.sqrt((e * e).sum(-1))) / SIGMA

    def jac(x: np.ndarray, l: np.ndarray) -> np.ndarray:  # noqa: E741
        d = x - rx
        e = x - tx
        return (
            -(d / np.sqrt((d * d).sum(-1))[:, None] + e / np.sqrt((e * e).sum(-1))[:, None])
            / SIGMA
        )

    return fun, jac


def scipy_batch(
    ls: np.ndarray, tx: np.ndarray, rx: np.ndarray, starts: np.ndarray, method: str
) -> np.ndarray:
    out = np.empty_like(starts)
    for n in range(ls.shape[0]):
        fun, jac = _direct_residuals(tx[n], rx[n])
        out[n] = least_squares(fun, starts[n], jac=jac, args=(ls[n],), method=method).x
    return out


def single_shot(
    name: str, sc: Scenario, size: int, repeats: int, rng: np.random.Generator
) -> tuple[list[str], float]:
    """The batch's rows, and lm's time over ml_solve's on one thread."""
    ls, tx, rx, _ = problems(sc, size, rng)
    sol = ml_solve(ls, tx, rx, SIGMA)
    core_s = best_time(lambda: ml_solve(ls, tx, rx, SIGMA), repeats)
    cf_s = best_time(lambda: sum_range_solve(ls, tx, rx, baseline_tol=5 * SIGMA), repeats)
    starts = sum_range_solve(ls, tx, rx, baseline_tol=5 * SIGMA).x
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one_s = best_time(lambda: ml_solve(ls, tx, rx, SIGMA), repeats)
    finally:
        numba.set_num_threads(threads)
    rows = [
        f"| {name} | ml_solve (batch, {threads} threads) | {core_s * 1e6 / size:.2f} "
        f"| {size / core_s:,.0f} | 1.0x | {np.mean(sol.iterations):.1f} | — |",
        f"| {name} | ml_solve (batch, one thread) | {one_s * 1e6 / size:.2f} "
        f"| {size / one_s:,.0f} | — | — | — |",
    ]
    sigma = np.full(ls.shape, SIGMA)
    row = np.arange(size)

    def predict(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return range_sums_unchecked(x, tx[idx], rx[idx])

    def jacobian(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
        return range_sum_jacobian_unchecked(x, tx[idx], rx[idx])

    tau = np.zeros(ls.shape[1])
    kernel_s = best_time(
        lambda: gauss_newton(ls, sigma, tx, rx, tau, row, starts, 50, 1e-9), repeats
    )
    numpy_s = best_time(
        lambda: gauss_newton_reference(predict, jacobian, ls, sigma, starts, 50, 1e-9), repeats
    )
    fast = gauss_newton(ls, sigma, tx, rx, tau, row, starts, 50, 1e-9)
    ref = gauss_newton_reference(predict, jacobian, ls, sigma, starts, 50, 1e-9)
    same = int((fast.iterations == ref.iterations).sum())
    gap = float(
        (np.abs(fast.theta - ref.theta).max(axis=1) / (1 + np.abs(ref.theta).max(axis=1))).max()
    )
    rows += [
        f"| {name} | Gauss-Newton alone, compiled engine | {kernel_s * 1e6 / size:.2f} "
        f"| {size / kernel_s:,.0f} | — | {np.mean(fast.iterations):.1f} "
        f"| same iterations as numpy in {same} of {size}; max relative gap {gap:.1e} |",
        f"| {name} | Gauss-Newton alone, numpy reference | {numpy_s * 1e6 / size:.2f} "
        f"| {size / numpy_s:,.0f} | — | {np.mean(ref.iterations):.1f} | — |",
    ]
    lm_ratio = 0.0
    for method in ("trf", "lm"):
        start = time.perf_counter()
        x = scipy_batch(ls, tx, rx, starts, method)
        s = time.perf_counter() - start + cf_s
        lm_ratio = s / one_s
        dx = x - sol.x
        sigmas = np.sqrt(np.einsum("ni,nij,nj->n", dx, np.linalg.inv(sol.covariance), dx))
        metres = np.linalg.norm(dx, axis=-1)
        rows.append(
            f"| {name} | least_squares {method} + closed-form start | "
            f"{s * 1e6 / size:.1f} | {size / s:,.0f} | {s / core_s:.2f}x "
            f"({s / one_s:.2f}x one thread) | — | "
            f"max {metres.max():.1g} m = {sigmas.max():.1g} sigma; "
            f"{(sigmas > 0.1).sum()} beyond 0.1 sigma |"
        )
    return rows, lm_ratio


def line_start(sc: Scenario, ls: np.ndarray) -> np.ndarray:
    """(x0, v) of a straight line through the per-sample closed-form positions."""
    x = sum_range_solve(ls, sc.tx, sc.rx, baseline_tol=5 * SIGMA).x
    tau = sc.t - sc.t[0]
    slope, icpt = np.polyfit(tau, x, 1)
    return np.concatenate([icpt, slope])


def trajectory(
    sc: Scenario, tracks: int, repeats: int, rng: np.random.Generator
) -> tuple[list[str], float, float]:
    """The trajectory rows, and own start's and given start's time over lm's."""
    tau = sc.t - sc.t[0]
    n_t, p, _ = sc.tx.shape
    clean = range_sums(sc.x, sc.tx, sc.rx)
    times = {k: [] for k in ("core", "core_x0", "trf", "lm")}
    diffs = {"trf": 0.0, "lm": 0.0}
    iters = []
    draws = clean + SIGMA * rng.standard_normal((tracks, *clean.shape))
    batch_s = best_time(lambda: trajectory_solve(draws, sc.t, sc.tx, sc.rx, SIGMA), repeats)
    for ls in draws:
        x0 = line_start(sc, ls)
        sol = trajectory_solve(ls, sc.t, sc.tx, sc.rx, SIGMA)
        iters.append(sol.iterations)
        times["core"].append(
            best_time(lambda ls=ls: trajectory_solve(ls, sc.t, sc.tx, sc.rx, SIGMA), repeats)
        )
        times["core_x0"].append(
            best_time(
                lambda ls=ls, x0=x0: trajectory_solve(ls, sc.t, sc.tx, sc.rx, SIGMA, x0=x0),
                repeats,
            )
        )
        flat = ls.reshape(-1)

        def fun(theta: np.ndarray, flat=flat) -> np.ndarray:
            x = theta[:2] + tau[:, None] * theta[2:]  # (T, D)
            d = x[:, None] - sc.rx
            e = x[:, None] - sc.tx
            h = np.sqrt((d * d).sum(-1)) + np.sqrt((e * e).sum(-1))
            return (flat - h.reshape(-1)) / SIGMA

        def jac(theta: np.ndarray, flat=flat) -> np.ndarray:
            x = theta[:2] + tau[:, None] * theta[2:]
            d = x[:, None] - sc.rx
            e = x[:, None] - sc.tx
            H = d / np.sqrt((d * d).sum(-1))[..., None] + e / np.sqrt((e * e).sum(-1))[..., None]
            return -np.concatenate([H, tau[:, None, None] * H], -1).reshape(n_t * p, 4) / SIGMA

        for method in ("trf", "lm"):
            out = least_squares(fun, x0, jac=jac, method=method)
            diffs[method] = max(diffs[method], float(np.abs(out.x - sol.state).max()))
            times[method].append(
                best_time(
                    lambda m=method, x0=x0: least_squares(fun, x0, jac=jac, method=m), repeats
                )
            )
    mean = {k: float(np.mean(v)) for k, v in times.items()}
    rows = [
        f"| trajectory_solve, own start | {mean['core'] * 1e3:.2f} | "
        f"{mean['trf'] / mean['core']:.2f}x | {mean['lm'] / mean['core']:.2f}x | "
        f"{np.mean(iters):.1f} |",
        f"| trajectory_solve, {tracks} tracks in one call (per track) | "
        f"{batch_s / tracks * 1e3:.2f} | {mean['trf'] * tracks / batch_s:.2f}x | "
        f"{mean['lm'] * tracks / batch_s:.2f}x | — |",
        f"| trajectory_solve, given start | {mean['core_x0'] * 1e3:.2f} | "
        f"{mean['trf'] / mean['core_x0']:.2f}x | {mean['lm'] / mean['core_x0']:.2f}x | — |",
        f"| least_squares trf, same start | {mean['trf'] * 1e3:.2f} | — | — | "
        f"max |state - core| {diffs['trf']:.1e} |",
        f"| least_squares lm, same start | {mean['lm'] * 1e3:.2f} | — | — | "
        f"max |state - core| {diffs['lm']:.1e} |",
    ]
    return rows, mean["core"] / mean["lm"], mean["core_x0"] / mean["lm"]


@dataclass(frozen=True)
class TrapRow:
    name: str
    x: np.ndarray  # (N, D) answers
    consistent: np.ndarray  # (N,)
    has_alternative: np.ndarray  # (N,)
    seconds: float  # per solve


def cpu_times(runs: list[Callable[[], object]], repeats: int) -> list[float]:
    """Least CPU time (process_time) of each call over ``repeats`` round-robin rounds.

    Round-robin, so load from other processes hits every call alike; CPU time, so
    waiting for a core is not counted (numpy runs these on one thread).
    """
    best = [np.inf] * len(runs)
    for _ in range(repeats):
        for i, run in enumerate(runs):
            start = time.process_time()
            run()
            best[i] = min(best[i], time.process_time() - start)
    return best


def _ml_row(name: str, sol: MLSolution, seconds: float) -> TrapRow:
    return TrapRow(name, sol.x, sol.consistent, sol.has_alternative, seconds)


def _operation_row(name: str, answer: PositionSolveResult, seconds: float) -> TrapRow:
    out = answer.solutions
    return TrapRow(
        name,
        np.array([s.position for s in out]),
        np.array([s.consistent for s in out]),
        np.array([s.alternative is not None for s in out]),
        seconds,
    )


def trap(sc: Scenario, runs: int, repeats: int, rng: np.random.Generator) -> tuple[list[str], int]:
    """Starts TRAP_OFFSET from the truth at the crossing: rows, and how many after are trapped."""
    tx, rx, truth = sc.tx[CROSS], sc.rx[CROSS], sc.x[CROSS]
    ls = range_sums(truth, tx, rx) + SIGMA * rng.standard_normal((runs, tx.shape[0]))
    angle = rng.uniform(0.0, 2.0 * np.pi, runs)
    starts = truth + TRAP_OFFSET * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    J = crlb(truth, tx, rx, SIGMA).information[0]
    fun, jac = _direct_residuals(tx, rx)

    began = time.process_time()  # scipy solves one problem per call; timed once (slow)
    x_scipy = np.array(
        [least_squares(fun, starts[r], jac=jac, args=(ls[r],)).x for r in range(runs)]
    )
    scipy_s = time.process_time() - began
    res = (ls - range_sums(x_scipy, tx, rx)) / SIGMA
    cost_scipy = np.einsum("np,np->n", res, res)
    threshold = consistency_threshold(ALPHA, tx.shape[0] - 2)  # ml_solve's own test
    wire = [
        {
            "range_sums": ls[r].tolist(),
            "transmitter": tx[0].tolist(),
            "receivers": rx.tolist(),
            "sigma": SIGMA,
        }
        for r in range(runs)
    ]
    guessed = PositionSolveRequest.model_validate(
        {
            "problems": [dict(w, initial=s.tolist()) for w, s in zip(wire, starts, strict=True)],
            "alpha": ALPHA,
        }
    )
    plain = PositionSolveRequest.model_validate({"problems": wire, "alpha": ALPHA})
    calls: list[Callable[[], object]] = [
        lambda: ml_solve(ls, tx, rx, SIGMA, x0=starts, alpha=ALPHA, closed_form_starts=False),
        lambda: ml_solve(ls, tx, rx, SIGMA, x0=starts, alpha=ALPHA),
        lambda: ml_solve(ls, tx, rx, SIGMA, alpha=ALPHA),
        lambda: position(guessed),
        lambda: position(plain),
    ]
    alone, with_x0, without_x0, op_guessed, op_plain = (call() for call in calls)
    per_solve = [t / runs for t in cpu_times(calls, repeats)]
    before = [
        TrapRow(
            "least_squares (trf), the start alone",
            x_scipy,
            cost_scipy <= threshold,
            np.zeros(runs, dtype=bool),
            scipy_s / runs,
        ),
        _ml_row("ml_solve, the start alone (closed_form_starts=False)", alone, per_solve[0]),
    ]
    after = [
        _ml_row("ml_solve with x0 (the start + the closed form's roots)", with_x0, per_solve[1]),
        _ml_row("ml_solve without x0 (the closed form's roots)", without_x0, per_solve[2]),
        _operation_row("solves.position with initial", op_guessed, per_solve[3]),
        _operation_row("solves.position without initial", op_plain, per_solve[4]),
    ]
    rows, trapped_after = [], 0
    for when, group in (("before", before), ("after", after)):
        for row in group:
            e = row.x - truth
            trapped = np.sqrt(np.einsum("ni,ij,nj->n", e, J, e)) > TRAPPED
            at_tx = trapped & (np.linalg.norm(row.x - tx[0], axis=-1) < 200.0)
            flagged = f"{(~row.consistent[trapped]).mean():.0%}" if trapped.any() else "—"
            if when == "after":
                trapped_after += int(trapped.sum())
            rows.append(
                f"| {when} | {row.name} | {trapped.sum()} of {runs} | {at_tx.sum()} "
                f"| {flagged} | {row.has_alternative.sum()} "
                f"| {row.seconds * 1e6:.1f} |"
            )
    return rows, trapped_after


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


def sections(args: argparse.Namespace, rng: np.random.Generator) -> list[str]:
    """The single-shot and trajectory tables; their SUMMARY lines."""
    summaries = []
    print(f"\n## Single shot, batch of {args.size:,} problems\n")
    print(
        "| geometry | solver | us per solve | solves / s | scipy / core time "
        "| mean GN iterations | agreement with ml_solve |\n"
        "|---|---|---:|---:|---:|---:|---|"
    )
    for key, name, sc in (
        ("study", "study (forward scatter)", scenario()),
        ("spread", "spread receivers", spread_scenario()),
    ):
        rows, ratio = single_shot(name, sc, args.size, args.repeats, rng)
        for row in rows:
            print(row)
        summaries.append(
            summary(
                f"multistatic.single_shot.{key}",
                f"ml_solve, {args.size:,} single-shot problems, {key} batch, one thread, wall",
                "scipy least_squares lm + the closed-form start, one call a problem",
                f"{ratio:.1f}x lm",
                ">= 100x",
                ratio >= 100.0,
            )
        )
    sc = scenario()
    print(
        f"\n## Trajectory, {sc.t.size} samples x 3 range sums, 4 unknowns "
        f"(mean of {args.tracks} tracks)\n"
    )
    print(
        "| solver | ms per solve | trf / core | lm / core | GN iterations / agreement |\n"
        "|---|---:|---:|---:|---|"
    )
    rows, own, given = trajectory(sc, args.tracks, args.repeats, rng)
    for row in rows:
        print(row)
    workload = f"trajectory_solve, {sc.t.size} samples x 3 range sums, wall"
    peer = "scipy least_squares lm from the given start"
    summaries.append(
        summary(
            "multistatic.trajectory.own_start",
            workload + ", own start",
            peer,
            f"{own:.2f}x lm",
            "<= 0.3x",
            own <= 0.3,
        )
    )
    summaries.append(
        summary(
            "multistatic.trajectory.given_start",
            workload + ", given start",
            peer,
            f"{given:.2f}x lm",
            "none",
            None,
        )
    )
    return summaries


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--size", type=int, default=10_000, help="single-shot problems per batch (10^4)"
    )
    parser.add_argument(
        "--tracks", type=int, default=20, help="200-sample trajectories to time (20)"
    )
    parser.add_argument("--repeats", type=int, default=3, help="best of this many (3)")
    parser.add_argument(
        "--trap-runs",
        type=int,
        default=500,
        help="starts 500 m off in the initial-guess trap (500)",
    )
    parser.add_argument(
        "--trap-only", action="store_true", help="run the initial-guess trap alone"
    )
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="CI's size: --size 1000 --tracks 3 --trap-runs 100 --repeats 2",
    )
    args = parser.parse_args(argv)
    if args.quick:
        args.size, args.tracks, args.trap_runs, args.repeats = 1000, 3, 100, 2
    if min(args.size, args.tracks, args.repeats, args.trap_runs) < 1:
        parser.error("--size, --tracks, --repeats and --trap-runs must be at least 1")
    rng = np.random.default_rng(args.seed)
    print(
        f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}"
    )
    summaries = [] if args.trap_only else sections(args, rng)
    print(
        f"\n## Initial guesses {TRAP_OFFSET:.0f} m off on the central baseline (sample "
        f"{CROSS}), {args.trap_runs} runs\n"
    )
    print(
        "| | solver | trapped (> 10 CRLB from the truth) | at the transmitter "
        "| trapped ones flagged by chi-square | alternative reported | us per solve |\n"
        "|---|---|---:|---:|---:|---:|---:|"
    )
    rows, trapped_after = trap(
        scenario(), args.trap_runs, args.repeats, np.random.default_rng([args.seed, CROSS])
    )
    for row in rows:
        print(row)
    print()
    for line in summaries:
        print(line)
    if trapped_after:
        print(f"\n{trapped_after} solves after the change are trapped", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
