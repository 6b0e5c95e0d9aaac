"""Passive/active identification: Kvasnov's experiment by Monte Carlo, and picture timing.

Run from the repository root::

    python bench/bench_identification.py          # ~1 min; writes the PNG
    python bench/bench_identification.py --runs 20000 --no-png   # quicker
    python bench/bench_identification.py --quick   # 2,000 runs, no PNG (CI)

1. Realized type I error at alpha = 0.05 under the paper's setup: n = 50 passive
   bearings N(theta_0, sigma), m active bearings uniform over a sector of width w
   around the same object (the paper's zone is 3 degrees wide), sigma known or
   estimated from the passive sample; against w / sigma and m. Each run is one test;
   ``--runs`` seeded runs per point.
2. Realized type II error beta (false identification) against the separation delta / sigma
   and m, active bearings normal (the formula's case) and uniform of width sqrt(12) sigma
   (the same spread), next to the formula Phi(z - d sqrt(m)) - Phi(-z - d sqrt(m)) (the
   paper's known population mean) and the same with the passive mean's own error
   (``type_two_error(..., n=50)``: Z ~ N(d sqrt(m), 1 + m / n)).
3. Time per identification in pictures of 100 passive x 100 active tracks with 50
   samples each: ``identify_picture`` (the 10^4 Z values and the assignment), best of
   ``--repeats``, per pair.

Writes docs/figures/identification_errors.png (alpha against w / sigma, beta against
delta / sigma) and prints markdown, then the ``SUMMARY`` line of the front table
(bench/README.md): the time per identification in a picture.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy

from plotgate.core.identification import experiment, identify_picture, type_two_error

ROOT = Path(__file__).resolve().parent.parent
SEED = 4004
SIGMA = np.radians(1.0)
WIDTHS = (1.0, 2.0, 3.0, np.sqrt(12.0), 4.0, 5.0)  # sector width / sigma
SEPARATIONS = (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0)  # delta / sigma
MS = (2, 5, 10, 20)


def alpha_rows(runs: int, seed: int) -> tuple[list[str], dict]:
    rows, curves = [], {}
    for estimate in (False, True):
        for m in (5, 10):
            values = []
            for k, w in enumerate(WIDTHS):
                out = experiment(
                    50, m, SIGMA, 0.0, w * SIGMA, runs, seed + 10 * m + k, estimate_sigma=estimate
                )
                values.append(out.rejected)
                ratio = (w * w / 12.0 + m / 50.0) ** 0.5  # sd of Z relative to N(0, 1)
                expected = 2.0 * scipy.stats.norm.sf(1.959964 / ratio)
                rows.append(
                    f"| {'estimated' if estimate else 'known'} | {m} | {w:.3g} | "
                    f"{out.rejected:.4f} ± {out.standard_error:.4f} | "
                    f"{expected:.4f} |"
                )
            curves[(estimate, m)] = values
    return rows, curves


def beta_rows(runs: int, seed: int) -> tuple[list[str], dict]:
    rows, curves = [], {}
    for m in MS:
        formula, normal, uniform = [], [], []
        for k, d in enumerate(SEPARATIONS):
            f = float(type_two_error(d * SIGMA, SIGMA, m, 0.05))
            g = float(type_two_error(d * SIGMA, SIGMA, m, 0.05, n=50))  # passive error too
            a = experiment(50, m, SIGMA, d * SIGMA, 1.0, runs, seed + 100 * m + k, law="normal")
            u = experiment(
                50, m, SIGMA, d * SIGMA, np.sqrt(12.0) * SIGMA, runs, seed + 100 * m + k + 50
            )
            formula.append(f)
            normal.append(a.identified)
            uniform.append(u.identified)
            rows.append(
                f"| {m} | {d:g} | {f:.4f} | {g:.4f} | {a.identified:.4f} | {u.identified:.4f} |"
            )
        curves[m] = (formula, normal, uniform)
    return rows, curves


def figure(alpha: dict, beta: dict, out: Path) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 2, 1)
    for (estimate, m), values in alpha.items():
        how = "estimated" if estimate else "known"
        ax.plot(WIDTHS, values, "o-", label=f"m = {m}, sigma {how}")
    ax.axhline(0.05, color="grey", linestyle="--", label="nominal alpha 0.05")
    ax.axhline(0.04, color="black", linestyle=":", label="paper: about 0.04")
    ax.set_xlabel("width of the active sector / sigma")
    ax.set_ylabel("realized type I error (missed identification)")
    ax.set_title("n = 50 passive normal, m active uniform")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    ax = fig.add_subplot(1, 2, 2)
    for k, (m, (formula, normal, uniform)) in enumerate(beta.items()):
        ax.plot(SEPARATIONS, formula, "-", color=f"C{k}", label=f"m = {m}: formula")
        ax.plot(SEPARATIONS, normal, "o", color=f"C{k}", label=f"m = {m}: MC normal")
        ax.plot(SEPARATIONS, uniform, "x", color=f"C{k}", label=f"m = {m}: MC uniform")
    ax.set_xlabel("separation delta / sigma")
    ax.set_ylabel("type II error beta (false identification)")
    ax.set_title("alpha = 0.05, n = 50")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="x-small", ncol=2)
    fig.suptitle("Kvasnov's Z-test by Monte Carlo")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return out


def picture_timing(repeats: int, seed: int) -> tuple[str, float]:
    """The table row, and the best seconds per picture."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(0.0, 2 * np.pi, 100)
    passive = centres[:, None] + SIGMA * rng.standard_normal((100, 50))
    active = rng.permutation(centres)[:, None] + SIGMA * rng.standard_normal((100, 50))
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        pic = identify_picture(passive, active)
        best = min(best, time.perf_counter() - start)
    row = (
        f"| 100 x 100, 50 samples each | {best * 1e3:.2f} | {best / 1e4 * 1e6:.3f} | "
        f"{len(pic.pairs)} |"
    )
    return row, best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100_000, help="runs per point (10^5)")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--png", type=Path, default=ROOT / "docs" / "figures" / "identification_errors.png"
    )
    parser.add_argument("--no-png", dest="png", action="store_const", const=None)
    parser.add_argument("--quick", action="store_true", help="2,000 runs a point, no PNG (CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.runs, args.repeats, args.png = 2_000, 2, None
    print(
        f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}"
    )
    print(f"\n## Realized type I error, alpha = 0.05, n = 50 ({args.runs:,} runs a point)\n")
    print(
        "| sigma | m | sector width / sigma | realized alpha | normal approximation |\n"
        "|---|---:|---:|---:|---:|"
    )
    rows, alpha = alpha_rows(args.runs, args.seed)
    print("\n".join(rows))
    print(f"\n## Type II error against separation ({args.runs:,} runs a point)\n")
    print(
        "| m | delta / sigma | formula (population mean known) | with the passive mean's "
        "error, n = 50 | MC normal | MC uniform, width sqrt(12) sigma |\n"
        "|---:|---:|---:|---:|---:|---:|"
    )
    rows, beta = beta_rows(args.runs, args.seed)
    print("\n".join(rows))
    print("\n## Picture timing\n")
    print(
        "| picture | ms per picture | us per identification | pairs identified |\n"
        "|---|---:|---:|---:|"
    )
    row, best = picture_timing(args.repeats, args.seed)
    print(row)
    if args.png is not None:
        print(f"\nwrote {figure(alpha, beta, args.png)}")
    print()
    summary(
        "identification.picture",
        "identify_picture: 100 passive x 100 active tracks, 50 bearings each (10^4 Z tests"
        " and the assignment)",
        "—",
        f"{best * 1e3:.2f} ms a picture, {best / 1e4 * 1e6:.3f} µs an identification",
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
