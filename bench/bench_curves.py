"""Operating curves of track initiation on Mu et al.'s scenario, with Stone Soup's points.

Run from the repository root::

    python bench/bench_curves.py                      # 4 x 500 runs at clutter 20, 100, 250, 500
    python bench/bench_curves.py --runs 50 --seeds 11 --clutter 250      # quick
    python bench/bench_curves.py --curves score --clutter 250   # only the curves named so
    python bench/bench_curves.py --plot-only          # redraw from bench/results
    python bench/bench_curves.py --runs 5 --seeds 11 --clutter 250 --out /tmp/c.json --no-figure

Each curve is one :func:`plotgate.core.initiation.evaluate.sweep` per seed: the same runs
(run r of seed s simulates ``mu_scenario(clutter)`` with ``SeedSequence(s).spawn(runs)[r]``)
under every value of one setting, scored by plot labels (a confirmed track is true when
more than half of its plots come from one target, each target once; every other confirmed
track is false). The seeds are the held-out report seeds, :data:`HELD_OUT`, never the
tuning seeds :data:`TUNING` (bench/HISTORY.md, "Track initiation on held-out seeds"): each
point pools their runs, its standard error the sample standard deviation over the pooled
runs over their square root. The curves:

- logic: the Cartesian logic method as in bench_initiation.py (combined capture gate,
  2/2, Kalman, 3/4), gate_P_G swept;
- polar (Mu et al.): the paper's method (2/2, 3/4, the acceleration check), gate_P_G
  swept; its 99% point is the paper's own configuration;
- polar 2/3: the polar method capturing over one missed scan (capture_scans = 3), K_A
  swept;
- logic 2/4, k/m: the logic method capturing over two missed scans, k/m swept from 4/4
  to 2/4 (two plots confirm: the permissive end, where Stone Soup's min_points = 2 is);
- score (Cartesian and polar): the README's configuration
  (``docs/examples/score_initiation.json``): score confirmation with at least
  confirm_k = 3 plots, capture over 2/3, P_D 0.8, the clutter density estimated from
  each scan's plot count over the 15 km square, new-target density 50 per square per
  scan (10 times the five targets', a prior that leans towards confirmation),
  true_deletion 1e-6 (no tentative track is dropped by its score before its plots are
  in); false_confirmation swept.

Stone Soup's ``MultiMeasurementInitiator`` points come from
``bench/results/stonesoup_heldout.jsonl``, one line per (clutter, min_points, P_G, seed),
written by ``python bench/stonesoup_initiation.py --sweep bench/results/stonesoup_heldout.jsonl
--clutter 250 --seed 11`` (and 12, 13, 14; about 8 minutes per 500 runs at clutter 250), and
pooled over the held-out seeds here (:func:`pooled`). Ours are written to
``bench/results/curves.json``; the figure to ``docs/figures/initiation_curves.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from plotgate.core.initiation import InitiationConfig
from plotgate.core.initiation.evaluate import sweep
from plotgate.core.initiation.simulate import mu_scenario

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
SCORE = json.loads((ROOT / "docs/examples/score_initiation.json").read_text())
"""The README's score configuration; its false_confirmation is swept."""
TUNING = (2026, 1, 2, 3)
"""Seeds the configurations were chosen on: never in a reported figure."""
HELD_OUT = (11, 12, 13, 14)
"""The report seeds, fixed before any figure on them was taken: 4 x 500 runs a point."""
GATES = [0.9, 0.95, 0.99, 0.995, 0.999]
ALPHAS = [1e-3, 0.05, 0.15, 0.2, 0.9]
CURVES: list[tuple[str, dict[str, Any], str, list[Any]]] = [
    ("logic 2/2, 3/4", {"mode": "cartesian", "capture_gate": "combined"}, "gate_P_G", GATES),
    ("polar (Mu et al.) 2/2, 3/4", {"mode": "polar"}, "gate_P_G", GATES),
    ("polar 2/3, 3/4", {"mode": "polar", "capture_scans": 3}, "K_A", [1.5, 2.0, 3.0, 5.0, 10.0]),
    (
        "logic 2/4, k/m",
        {"mode": "cartesian", "capture_gate": "combined", "capture_scans": 4},
        "confirm",
        ["4/4", "3/4", "2/3", "2/4"],
    ),
    ("score, Cartesian", SCORE, "false_confirmation", ALPHAS),
    ("score, polar", {**SCORE, "mode": "polar"}, "false_confirmation", ALPHAS),
]
"""(name, settings besides v_max = 30 m/s, swept setting, its values)."""


def run(clutter: float, runs: int, seeds: list[int], names: list[str] | None = None) -> list[dict]:
    """Every curve's points at one clutter level (the curves whose name contains one of
    ``names``, when given), each pooling ``runs`` runs of every seed."""
    rows = []
    for name, settings, parameter, values in CURVES:
        if names is not None and not any(part in name for part in names):
            continue
        start = time.perf_counter()
        config = InitiationConfig(**{"v_max": 30.0, **settings})
        curves = [sweep(mu_scenario(clutter), config, parameter, values, runs, s) for s in seeds]
        seconds = time.perf_counter() - start
        for i, value in enumerate(values):
            true = np.concatenate([curve[i].true for curve in curves])
            false = np.concatenate([curve[i].false for curve in curves])
            rows.append(
                {
                    "clutter": clutter,
                    "curve": name,
                    "parameter": parameter,
                    "value": value,
                    "runs": int(true.size),
                    "seeds": list(seeds),
                    "mean_true": float(true.mean()),
                    "se_true": _se(true),
                    "mean_false": float(false.mean()),
                    "se_false": _se(false),
                    "confirmable": float(np.mean([curve[i].ceiling for curve in curves])),
                    "seconds_per_curve": seconds,
                }
            )
        print(f"clutter {clutter:g}: {name} ({len(values)} points) in {seconds:.1f} s", flush=True)
    return rows


def _se(x: np.ndarray) -> float:
    return float(np.std(x, ddof=1) / np.sqrt(x.size)) if x.size > 1 else float("nan")


def stonesoup_points(seeds: tuple[int, ...] = HELD_OUT) -> list[dict[str, Any]]:
    """Stone Soup's points on ``seeds``, pooled over them (:func:`pooled`)."""
    path = RESULTS / "stonesoup_heldout.jsonl"
    if not path.exists():
        return []
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    groups: dict[tuple[float, int, float], list[dict[str, Any]]] = {}
    for row in rows:
        if row["seed"] in seeds:
            groups.setdefault((row["clutter"], row["min_points"], row["P_G"]), []).append(row)
    return [pooled(group) for group in groups.values()]


def pooled(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """One point from per-seed rows of the same setting: means weighted by runs, and the
    standard error of the pooled runs, their variance rebuilt from each row's mean and
    standard error (within-seed plus between-seed sums of squares)."""
    n = np.array([r["runs"] for r in rows], dtype=float)
    out = {**rows[0], "runs": int(n.sum()), "seeds": sorted(r["seed"] for r in rows)}
    del out["seed"]
    for key in ("true", "false"):
        mean = np.array([r[f"mean_{key}"] for r in rows])
        var = np.array([r[f"se_{key}"] ** 2 * r["runs"] for r in rows])  # per-seed variance
        grand = float((n * mean).sum() / n.sum())
        ss = ((n - 1) * var).sum() + (n * (mean - grand) ** 2).sum()
        out[f"mean_{key}"] = grand
        out[f"se_{key}"] = math.sqrt(ss / (n.sum() - 1) / n.sum())
    return out


def table(rows: list[dict[str, Any]], stone: list[dict[str, Any]]) -> str:
    lines = [
        "| clutter | method | setting | targets initiated | false tracks |",
        "|---:|---|---|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['clutter']:g} | {r['curve']} | {r['parameter']} = {r['value']} | "
            f"{r['mean_true']:.3f} ± {r['se_true']:.3f} | "
            f"{r['mean_false']:.3f} ± {r['se_false']:.3f} |"
        )
    for s in sorted(stone, key=lambda s: (s["clutter"], s["min_points"], s["P_G"])):
        lines.append(
            f"| {s['clutter']:g} | Stone Soup MultiMeasurementInitiator ({s['runs']} runs) | "
            f"min_points {s['min_points']}, P_G {s['P_G']:g} | {s['mean_true']:.3f} ± "
            f"{s['se_true']:.3f} | {s['mean_false']:.3f} ± {s['se_false']:.3f} |"
        )
    return "\n".join(lines)


def dominated(rows: list[dict[str, Any]], stone: list[dict[str, Any]]) -> str:
    """For each Stone Soup point: the best of ours that dominates it within two standard
    errors, or NOT dominated.

    Ours dominates when its targets are at least Stone Soup's less two standard errors of
    the difference, its false tracks at most Stone Soup's plus two, and it is better on
    one of the two beyond that noise or fewer in false tracks outright (none where Stone
    Soup has none: nothing is fewer than zero). Best: the fewest false tracks.
    """
    out = []
    for s in sorted(stone, key=lambda s: (s["clutter"], s["min_points"], s["P_G"])):
        ours = [
            r
            for r in rows
            if r["clutter"] == s["clutter"]
            and r["mean_true"] >= s["mean_true"] - _margin(r, s, "true")
            and r["mean_false"] <= s["mean_false"] + _margin(r, s, "false")
            and (
                r["mean_true"] > s["mean_true"] + _margin(r, s, "true")
                or r["mean_false"] < s["mean_false"]
                or r["mean_false"] == s["mean_false"] == 0
            )
        ]
        best = min(ours, key=lambda r: (r["mean_false"], -r["mean_true"]), default=None)
        where = (
            f"{best['curve']} {best['parameter']} = {best['value']}: "
            f"{best['mean_true']:.3f} ± {best['se_true']:.3f} targets, "
            f"{best['mean_false']:.3f} ± {best['se_false']:.3f} false"
            if best
            else "NOT dominated"
        )
        out.append(
            f"- clutter {s['clutter']:g}, Stone Soup min_points {s['min_points']}, P_G "
            f"{s['P_G']:g}, {s['runs']} runs ({s['mean_true']:.3f} ± {s['se_true']:.3f}, "
            f"{s['mean_false']:.3f} ± {s['se_false']:.3f}): {where}"
        )
    return "\n".join(out)


def _margin(ours: dict[str, Any], theirs: dict[str, Any], key: str) -> float:
    """Two standard errors of the difference of two independent means."""
    return 2.0 * math.hypot(ours[f"se_{key}"], theirs[f"se_{key}"])


def _points(ax: Any, points: list[dict[str, Any]], **style: Any) -> None:
    """Operating points (false tracks, targets) with their standard errors as bars."""
    ax.errorbar(
        [p["mean_false"] for p in points],
        [p["mean_true"] for p in points],
        xerr=[p["se_false"] for p in points],
        yerr=[p["se_true"] for p in points],
        capsize=2,
        **style,
    )


def _values(ax: Any, points: list[dict[str, Any]]) -> None:
    """Each point's swept value beside it, small, in the curve's colour."""
    color = ax.lines[-1].get_color()
    for i, p in enumerate(points):  # alternately below-right and above-left: no overlap
        ax.annotate(
            f"{p['value']:g}" if isinstance(p["value"], float) else str(p["value"]),
            (p["mean_false"], p["mean_true"]),
            xytext=(4, -9) if i % 2 == 0 else (-14, 5),
            textcoords="offset points",
            fontsize=5.5,
            color=color,
        )


def figure(rows: list[dict[str, Any]], stone: list[dict[str, Any]], out: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    levels = sorted({r["clutter"] for r in rows})
    seeds = ", ".join(str(s) for s in rows[0]["seeds"])
    fig = Figure(figsize=(5.5 * len(levels), 5.0), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(levels), squeeze=False).ravel()  # one panel a level: none empty
    for ax, level in zip(axes, levels, strict=True):
        for name, _, parameter, _ in CURVES:
            pts = sorted(
                (r for r in rows if r["clutter"] == level and r["curve"] == name),
                key=lambda r: r["mean_false"],
            )
            if not pts:  # a curve not traced on these seeds
                continue
            _points(ax, pts, marker="o", ms=3, label=f"{name}: {parameter}")
            _values(ax, pts)
        ss = [s for s in stone if s["clutter"] == level]
        if ss:
            _points(ax, ss, fmt="k*", ms=9, label="Stone Soup (min_points 3, P_G 0.95-0.999)")
        # targets detected in 3 of 4 scans (every curve but the k/m sweep counts 3/4)
        ceiling = [
            r["confirmable"]
            for r in rows
            if r["clutter"] == level and r["curve"] != "logic 2/4, k/m"
        ]
        ax.axhline(ceiling[0], color="grey", lw=0.8, ls=":", label="detected in 3 of 4 scans")
        ax.set_xscale("symlog", linthresh=0.01, linscale=0.5)
        widest = [r["mean_false"] + r["se_false"] for r in rows if r["clutter"] == level]
        widest += [s["mean_false"] + s["se_false"] for s in ss]
        ax.set_xlim(0.0, max(0.01, 1.3 * max(widest)))
        ax.set_xlabel("false tracks per run (linear below 0.01, log above)")
        ax.set_ylabel("targets initiated per run (of 5)")
        ax.set_title(f"clutter {level:g} plots per scan, {rows[0]['runs']} runs (seeds {seeds})")
        ax.grid(True, which="both", alpha=0.3)
        # every panel's own curves in its own legend
        ax.legend(loc="lower right", fontsize=7, title="curve: setting swept", title_fontsize=7)
    fig.suptitle(
        f"Operating curves of track initiation on Mu et al.'s scenario, held-out seeds "
        f"({rows[0]['runs']} runs, the same scans for every value)\neach point is one value "
        "of the setting swept, written beside it; bars: one standard error"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=500, help="runs per seed")
    parser.add_argument("--seeds", default=",".join(map(str, HELD_OUT)))
    parser.add_argument("--clutter", default="20,100,250,500")
    parser.add_argument("--curves", help="comma-separated: only the curves whose name has one")
    parser.add_argument("--plot-only", action="store_true", help="redraw from bench/results")
    parser.add_argument("--out", type=Path, default=RESULTS / "curves.json")
    parser.add_argument("--figure", type=Path, default=ROOT / "docs/figures/initiation_curves.png")
    parser.add_argument("--no-figure", dest="figure", action="store_const", const=None)
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    if set(seeds) & set(TUNING):
        print(f"note: seeds {sorted(set(seeds) & set(TUNING))} are tuning seeds", file=sys.stderr)
    rows = json.loads(args.out.read_text()) if args.out.exists() else []
    if not args.plot_only:
        clutter = [float(c) for c in args.clutter.split(",")]
        names = args.curves.split(",") if args.curves else None
        new = [r for c in clutter for r in run(c, args.runs, seeds, names)]
        redone = {(r["clutter"], r["curve"]) for r in new}
        rows = [
            r for r in rows if r.get("seeds") == seeds and (r["clutter"], r["curve"]) not in redone
        ]
        rows += new
        rows.sort(key=lambda r: (r["clutter"], [c[0] for c in CURVES].index(r["curve"])))
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(rows, indent=1) + "\n")
    stone = stonesoup_points(tuple(rows[0]["seeds"]))
    print(table(rows, stone))
    print()
    print(dominated(rows, stone))
    if args.figure is not None:
        figure(rows, stone, args.figure)
        print(f"\nfigure: {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
