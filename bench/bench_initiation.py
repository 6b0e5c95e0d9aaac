"""Track initiation: Mu et al.'s study (with Stone Soup alongside) and time per scan.

Run from the repository root::

    python bench/bench_initiation.py                    # 500 runs, Stone Soup too (~4 min)
    python bench/bench_initiation.py --runs 50 --no-stonesoup --max-plots 10000
    python bench/bench_initiation.py --quick    # 5 runs, to 10^4 plots, best of 1 (CI)

1. Mu et al.'s evaluation: 5 ground targets at 25 m/s, radar at the
   origin, a 15 km square, P_D 0.8, sigma_r 5 m, sigma_az 0.2 deg, 1 s scans, Poisson
   clutter 20 or 250 per scan, 3/4 over 4 scans, 500 seeded runs (the same scans for
   every method: run r is seeded by ``SeedSequence(seed).spawn(runs)[r]``). Methods: the
   Cartesian logic method (:data:`LOGIC`) and Mu et al.'s polar method (:data:`POLAR`),
   both through ``core.initiation.evaluate``, with 99% and with 95% gates; and Stone Soup's
   ``MultiMeasurementInitiator`` on the same scans (``bench/stonesoup_initiation.py``,
   needs ``pip install -e ".[bench]"``). Scored by labels (a confirmed track is true when
   most of its plots come from one target, each target once) and by distance (100 m).
2. Time per scan against clutter plots per scan, 10^2 to 10^5, at the paper's clutter
   density (250 per 15 km square): the square grows with the plot count, so the plots
   near each gate stay the same and the growth shows the cost of the machinery itself
   (the candidate search, candidate pairs, capture gates). Cartesian plots with a fixed 20 m
   sigma (the logic method), and polar plots about a radar at the centre (the polar
   method, whose windows grow with range), and the logic method under score
   confirmation (:data:`SCORE`, the same plots). Mean of scans 2-5 of 5 (scan 1 only
   makes initiators), best of ``--repeats``.

Ends with the ``SUMMARY`` lines of the front table (bench/README.md): the logic and polar
methods' time per scan at the largest plot count against the 0.1 s aim, and the logic
method's time per scan at clutter 250 against Stone Soup's on the same scans. Stone Soup is
skipped, with a note, where the ``bench`` extra is not installed.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy

from plotgate.core.initiation import InitiationConfig, cartesian_scan, initiate
from plotgate.core.initiation.evaluate import evaluate
from plotgate.core.initiation.simulate import Scenario, mu_scenario, simulate

SEED = 2026
LOGIC = InitiationConfig(
    mode="cartesian",
    capture_gate="combined",
    v_max=30.0,
    capture_scans=2,
    confirm_k=3,
    confirm_m=4,
    drop_misses=2,
)
"""Capture by Konovalov's combined gate (ring 0-30 m/s, else the 99% ellipse of the two
plots' errors), a Kalman filter, 99% chi-square gates widening after a miss."""
POLAR = InitiationConfig(
    mode="polar",
    v_max=30.0,
    capture_scans=2,
    confirm_k=3,
    confirm_m=4,
    drop_misses=2,
    a_max=10.0,
    K_A=3.0,
)
"""First-association windows, range-only extrapolation, the tangential-speed azimuth
window, K_R = K_az = 3.03 (99%), and |second difference of range| <= 3 x 10 m/s^2
(the range noise alone gives sqrt(6) x 5 m = 12 m/s^2 rms)."""
DENSITY = 250.0 / 15000.0**2  # clutter plots per m^2 per scan
AIM_S = 0.1
"""Seconds per scan the logic and polar methods aim at, at 10^5 plots per scan (issue 27)."""
SCORE = replace(LOGIC, confirmation="score", P_D=0.8, clutter_density=DENSITY)
"""The logic method under score confirmation: its time per scan against k/m's."""
EXISTENCE = replace(SCORE, confirmation="existence", existence_confirm=0.85)
"""The logic method under existence confirmation (IPDA, issue 38)."""


def study(runs: int, seed: int, stonesoup: bool) -> tuple[list[str], dict[str, float]]:
    """The study's table rows, and the seconds per scan at clutter 250 of the logic method
    (99% gates) and of Stone Soup (when run), by name."""
    rows, per_scan_250 = [], {}
    methods = (
        ("logic (Cartesian), 99% gates", LOGIC),
        ("polar (Mu et al.), 99% gates", POLAR),
        ("logic (Cartesian), 95% gates", replace(LOGIC, capture_P_G=0.95, gate_P_G=0.95)),
        ("polar (Mu et al.), 95% gates", replace(POLAR, gate_P_G=0.95)),
    )
    for clutter in (20.0, 250.0):
        scenario = mu_scenario(clutter)
        for name, config in methods:
            start = time.perf_counter()
            ev = evaluate(scenario, config, runs, seed)
            per_scan = (time.perf_counter() - start) / (runs * scenario.scans)
            if clutter == 250.0 and config is LOGIC:
                per_scan_250["logic"] = per_scan
            rows.append(
                f"| {clutter:g} | {name} | {ev.mean_true:.2f} | {ev.mean_false:.2f} | "
                f"{ev.mean_true_by_distance:.2f} | {ev.mean_false_by_distance:.2f} | "
                f"{ev.ceiling:.2f} | {ev.mean_time_to_confirmation:.2f} | "
                f"{per_scan * 1e3:.2f} |"
            )
        if stonesoup:
            sys.path.insert(0, str(Path(__file__).resolve().parent))
            from stonesoup_initiation import stonesoup_initiation

            out = stonesoup_initiation(clutter, runs, seed)
            rows.append(
                f"| {clutter:g} | Stone Soup MultiMeasurementInitiator, 99% gate | "
                f"{out['mean_true']:.2f} | {out['mean_false']:.2f} | — | — | — | — | "
                f"{out['seconds_per_scan'] * 1e3:.2f} |"
            )
            if clutter == 250.0:
                per_scan_250["stonesoup"] = out["seconds_per_scan"]
    return rows, per_scan_250


def _cartesian_scans(n: int, rng: np.random.Generator) -> list:
    """Five scans of n clutter plots (20 m sigma) at DENSITY plus five targets."""
    side = np.sqrt(n / DENSITY)
    targets = rng.uniform(0.0, side, (5, 2))
    scans = []
    for i in range(5):
        z = np.vstack([rng.uniform(0.0, side, (n, 2)), targets + [25.0 * i, 0.0]])
        z = z + 20.0 * rng.standard_normal(z.shape)
        scans.append(
            cartesian_scan(float(i), z, np.broadcast_to(np.eye(2) * 400.0, (z.shape[0], 2, 2)))
        )
    return scans


def _polar_scans(n: int, rng: np.random.Generator) -> list:
    side = np.sqrt(n / DENSITY)
    scenario = Scenario(
        x0=rng.uniform(-side / 2, side / 2, (5, 2)),
        v=np.tile([25.0, 0.0], (5, 1)),
        scans=5,
        interval=1.0,
        P_D=0.8,
        clutter=float(n),
        region=np.array([-side, side, -side, side]) / 2,
        sensor=np.zeros(2),
        sigma_r=5.0,
        sigma_az=np.radians(0.2),
    )
    return simulate(scenario, rng).scans


def scaling(max_plots: int, repeats: int, seed: int) -> tuple[list[str], dict[str, float]]:
    """The table rows, and each method's seconds per scan at the largest plot count."""
    rows, largest = [], {}
    sizes = [n for n in (100, 1_000, 10_000, 100_000) if n <= max_plots]
    base = {}
    for name, config, make in (
        ("logic (Cartesian)", LOGIC, _cartesian_scans),
        ("polar (Mu et al.)", POLAR, _polar_scans),
        ("score (Cartesian)", SCORE, _cartesian_scans),
        ("existence (Cartesian)", EXISTENCE, _cartesian_scans),
    ):
        for n in sizes:
            scans = make(n, np.random.default_rng(seed))
            best = np.inf
            for _ in range(repeats):
                state, times = None, []
                for scan in scans:
                    start = time.perf_counter()
                    state, _ = initiate(state, [scan], config)
                    times.append(time.perf_counter() - start)
                best = min(best, float(np.mean(times[1:])))
            base.setdefault(name, (n, best))
            largest[name] = best
            n0, t0 = base[name]
            growth = np.log(best / t0) / np.log(n / n0) if n > n0 else float("nan")
            rows.append(
                f"| {name} | {n:,} | {best * 1e3:.1f} | {best / n * 1e6:.2f} | "
                f"{'—' if n == n0 else f'{growth:.2f}'} | {state.tracks.size} |"
            )
    return rows, largest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=500, help="Monte Carlo runs (500)")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument(
        "--no-stonesoup", dest="stonesoup", action="store_false", help="skip the Stone Soup rows"
    )
    parser.add_argument(
        "--no-study", dest="study", action="store_false", help="only the time per scan"
    )
    parser.add_argument(
        "--max-plots",
        type=int,
        default=100_000,
        help="largest clutter per scan of the timing (10^5)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="best of this many (3)")
    parser.add_argument(
        "--quick", action="store_true", help="5 runs, to 10^4 plots, best of 1 (CI; every path)"
    )
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.repeats, args.max_plots = 5, 1, 10_000
    if args.stonesoup and importlib.util.find_spec("stonesoup") is None:
        print('note: Stone Soup is not installed (pip install -e ".[bench]"): its rows skipped')
        args.stonesoup = False
    print(
        f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}"
    )
    if args.study:
        print(f"\n## Mu et al.'s study: {args.runs} runs, seed {args.seed}\n")
        print(
            "| clutter | method | targets initiated | false tracks | initiated (100 m) | "
            "false (100 m) | confirmable | time to confirm s | ms per scan |\n"
            "|---:|---|---:|---:|---:|---:|---:|---:|---:|"
        )
        rows, per_scan_250 = study(args.runs, args.seed, args.stonesoup)
        for row in rows:
            print(row)
    print("\n## Time per scan against clutter plots per scan\n")
    print(
        "| method | clutter plots | ms per scan | us per plot | growth exponent "
        "| tracks after 5 scans |\n|---|---:|---:|---:|---:|---:|"
    )
    rows, largest = scaling(args.max_plots, args.repeats, args.seed)
    for row in rows:
        print(row)
    print()
    n = max(n for n in (100, 1_000, 10_000, 100_000) if n <= args.max_plots)
    for key, name in (("logic", "logic (Cartesian)"), ("polar", "polar (Mu et al.)")):
        summary(
            f"initiation.{key}",
            f"initiate, {name}, {n:,} clutter plots per scan, s per scan",
            "—",
            f"{largest[name]:.3f} s",
            f"<= {AIM_S} s at 10^5",
            largest[name] <= AIM_S if n == 100_000 else None,
        )
    if args.study and "stonesoup" in per_scan_250:
        ours, theirs = per_scan_250["logic"], per_scan_250["stonesoup"]
        summary(
            "initiation.stonesoup",
            f"Mu et al.'s study, clutter 250, logic 99%, {args.runs} runs, ms per scan",
            "Stone Soup MultiMeasurementInitiator, same scans",
            f"{theirs / ours:.0f}x faster ({ours * 1e3:.2f} vs {theirs * 1e3:.1f} ms)",
            "—",
            None,
        )
    return 0


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    sys.exit(main())
