"""``plotgate study``: the multistatic accuracy study of Fadeev et al., Fig. 3, as a table and PNG.

The operation ``solves.study`` does the Monte Carlo (in-process or on a server,
:mod:`plotgate.clients.runners`); this module holds the default scenario, judges the answer
against the accuracy requirements, and writes the markdown table and the figure.

Default scenario (:data:`DEFAULT_REQUEST`; ours, in the spirit of Fadeev et al.'s
forward-scatter system): one transmitter at (9900, 1000) m heading 120 degrees and three
receivers at (150, 500), (600, 1000), (150, 1500) m heading 60 degrees, all at 10 m/s
(as the paper's Fig. 2), baselines 9763, 9300 and 9763 m at t = 0; a target at 80 m/s
due north along x = 5 km crosses the three baselines, the central one exactly at
t = 11.2 s (sample 112), where that range sum's gradient vanishes. 200 samples 0.1 s
apart, sigma 0.5 m, 1000 runs, seed 20261122.

The checks (:data:`LIMITS`): the ML single-shot RMSE within 5% of the CRLB at every
sample; no ML solution more than 10 CRLB (Mahalanobis) from the truth; the
difference-range RMSE within 10% of its own bound; the ML track RMSE within 5% of the
accumulated bound at every prefix, and the full track's at every sample time; every false
minimum flagged by the chi-square test. A ratio from R runs carries a Monte Carlo error
of about 1/sqrt(2R) (2.2% at 1000 runs), so the table also gives RMSE / RMSE_linearised,
the paired ratio that cancels most of it.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = [
    "DEFAULT_REQUEST",
    "LIMITS",
    "OPERATION",
    "Check",
    "checks",
    "draw",
    "run_study",
    "table",
]

OPERATION = "solves.study"
_COS60, _SIN60 = 5.0, 8.660254037844386  # 10 m/s at 60 degrees from the x axis
DEFAULT_REQUEST: dict[str, Any] = {
    "transmitter": {"position": [9900.0, 1000.0], "velocity": [-_COS60, _SIN60]},
    "receivers": [
        {"position": p, "velocity": [_COS60, _SIN60]}
        for p in ([150.0, 500.0], [600.0, 1000.0], [150.0, 1500.0])
    ],
    "target": {"position": [5000.0, 200.99484522385694], "velocity": [0.0, 80.0]},
    "sample_times": [round(0.1 * i, 10) for i in range(200)],
    "sigma": 0.5,
    "runs": 1000,
    "seed": 20261122,
    "alpha": 0.01,
    "tracks": True,
}
LIMITS = {
    "ml_single": 0.05,
    "max_distance": 10.0,
    "difference_range": 0.10,
    "ml_track": 0.05,
    "full_track": 0.05,
}
_BASELINE_GRADIENT = 0.2  # a pair's |dl/dx| below this, at a local minimum: on its baseline


def run_study(
    request: dict[str, Any] | None = None,
    *,
    server: str | None = None,
    runner: Runner | None = None,
) -> dict[str, Any]:
    """Answer a study request (default :data:`DEFAULT_REQUEST`) in-process or on ``server``."""
    body = DEFAULT_REQUEST if request is None else request
    if runner is not None:
        return runner(body)
    if server is None:
        return in_process_runner(OPERATION)(body)
    from plotgate.clients.client import Client

    with Client(server) as client:
        return http_runner(client, OPERATION)(body)


def _total(axes: list[float] | None) -> float:
    return float("nan") if axes is None else sum(v * v for v in axes) ** 0.5


def _ratio(s: dict[str, Any], num: str, den: str) -> float:
    return _total(s[num]) / _total(s[den])


def _notes(samples: list[dict[str, Any]]) -> dict[int, str]:
    """Sample index -> "on b2" at each pair's baseline crossing (gradient local minimum)."""
    notes: dict[int, str] = {}
    for p in range(len(samples[0]["gradient"])):
        g = [s["gradient"][p] for s in samples]
        for i in range(len(g)):
            lower = (i == 0 or g[i] <= g[i - 1]) and (i + 1 == len(g) or g[i] <= g[i + 1])
            if lower and g[i] < _BASELINE_GRADIENT:
                notes[i] = f"on b{p + 1}"
    return notes


@dataclass(frozen=True)
class Check:
    """One accuracy requirement: what, the measured value, and whether it holds."""

    requirement: str
    result: str
    passed: bool


def _worst(values: list[tuple[int, float]]) -> tuple[int, float]:
    """(sample, ratio) farthest from 1."""
    return max(values, key=lambda iv: abs(iv[1] - 1.0))


def checks(answer: dict[str, Any]) -> list[Check]:
    """Judge a study answer against :data:`LIMITS` (track checks only with tracks)."""
    samples = answer["samples"]
    out = []
    single = [(i, _ratio(s, "ml_single", "crlb")) for i, s in enumerate(samples)]
    paired = [(i, _ratio(s, "ml_single", "linearised")) for i, s in enumerate(samples)]
    i, r = _worst(single)
    j, q = _worst(paired)
    lim = LIMITS["ml_single"]
    outside = sum(abs(v - 1.0) > lim for _, v in single)
    out.append(
        Check(
            f"ML single shot within {lim:.0%} of the CRLB at every sample",
            f"worst {r:.3f} at sample {i} ({outside} of {len(single)} outside; Monte Carlo "
            f"SE there {samples[i]['ml_single_se']:.1%})",
            outside == 0,
        )
    )
    out.append(
        Check(
            f"ML single shot within {lim:.0%} of the linearised efficient estimator on the "
            f"same noise (paired: Monte Carlo noise cancels)",
            f"worst {q:.3f} at sample {j}",
            abs(q - 1.0) <= lim,
        )
    )
    far = max(s["max_distance"] for s in samples)
    out.append(
        Check(
            f"no ML solution more than {LIMITS['max_distance']:g} CRLB away",
            f"largest Mahalanobis error {far:.2f}",
            far <= LIMITS["max_distance"],
        )
    )
    diff = [(i, _ratio(s, "difference_range", "crlb_difference")) for i, s in enumerate(samples)]
    i, r = _worst(diff)
    out.append(
        Check(
            f"difference range within {LIMITS['difference_range']:.0%} of its CRLB",
            f"worst {r:.3f} at sample {i}",
            abs(r - 1.0) <= LIMITS["difference_range"],
        )
    )
    if samples[-1]["full_track"] is not None:
        track = [
            (i, _ratio(s, "ml_track", "crlb_accumulated"))
            for i, s in enumerate(samples)
            if s["ml_track"] is not None
        ]
        full = [(i, _ratio(s, "full_track", "full_track_crlb")) for i, s in enumerate(samples)]
        (i, r), (j, q) = _worst(track), _worst(full)
        lim = LIMITS["ml_track"]
        out.append(
            Check(
                f"ML track within {lim:.0%} of its CRLB (every prefix; full track at every "
                f"sample)",
                f"prefixes: worst {r:.3f} at sample {i}; full track: worst {q:.3f} at sample {j}",
                abs(r - 1.0) <= lim and abs(q - 1.0) <= LIMITS["full_track"],
            )
        )
    false = sum(s["false_minima"] for s in samples)
    unflagged = sum(s["false_unflagged"] for s in samples)
    out.append(
        Check(
            "every false minimum flagged by the chi-square test",
            f"{false} false minima, {unflagged} unflagged",
            unflagged == 0,
        )
    )
    return out


def _fmt(v: float) -> str:
    if v != v:
        return "—"
    return f"{v:.3g}" if abs(v) < 1000 else f"{v:,.0f}"


def table(answer: dict[str, Any], every: int = 1) -> str:
    """Markdown: the checks, then one row per sample (every ``every``-th, plus crossings)."""
    samples = answer["samples"]
    notes = _notes(samples)
    lines = [
        f"Monte Carlo: {answer['runs']} runs, seed {answer['seed']}, sigma {answer['sigma']} m;"
        f" eq. 5 noise estimate {answer['noise_sigma']:.4f} ± "
        f"{answer['noise_sigma_spread']:.4f} m.",
        "",
        "| requirement | result | met |",
        "|---|---|---|",
        *(
            f"| {c.requirement} | {c.result} | {'yes' if c.passed else '**no**'} |"
            for c in checks(answer)
        ),
        "",
        "Total RMSE sqrt(sum of per-axis RMSE^2), m; curves of Fadeev et al., Fig. 3: "
        "1 single-shot CRLB, 2 accumulated CRLB, 3 ML track, 4 ML single shot, 5 sum range, "
        "6 difference range; lin: the linearised efficient estimator on the same noise; "
        "dist: largest Mahalanobis error of curve 4.",
        "",
        "| i | t s | note | 1 CRLB | 2 CRLB acc. | 3 ML track | 4 ML single | 5 sum-range | "
        "6 diff-range | diff CRLB | 4/1 | 4/lin | 3/2 | 3/lin | 6/diff | dist 4 | "
        "inconsistent 4 |",
        "|---:|---:|---|" + "---:|" * 14,
    ]
    for i, s in enumerate(samples):
        if i % every and i not in notes and i != len(samples) - 1:
            continue
        cells = [
            _total(s[k])
            for k in (
                "crlb",
                "crlb_accumulated",
                "ml_track",
                "ml_single",
                "sum_range",
                "difference_range",
                "crlb_difference",
            )
        ]
        ratios = [
            _ratio(s, "ml_single", "crlb"),
            _ratio(s, "ml_single", "linearised"),
            _ratio(s, "ml_track", "crlb_accumulated"),
            _ratio(s, "ml_track", "linearised_track"),
            _ratio(s, "difference_range", "crlb_difference"),
        ]
        lines.append(
            f"| {i} | {s['t']:g} | {notes.get(i, '')} | "
            + " | ".join(_fmt(v) for v in cells)
            + " | "
            + " | ".join("—" if r != r else f"{r:.3f}" for r in ratios)
            + f" | {s['max_distance']:.2f} | {s['inconsistent']} |"
        )
    return "\n".join(lines) + "\n"


def draw(answer: dict[str, Any], out: Path) -> Path:
    """Per-axis RMSE of curves 1-6 against the target's y, log scale, in the style of
    Fadeev et al., Fig. 3."""
    from plotgate.clients.plots import matplotlib_classes

    Figure, FigureCanvasAgg = matplotlib_classes()
    samples = answer["samples"]
    y = [s["position"][1] / 1e3 for s in samples]
    fig = Figure(figsize=(12, 5.5), layout="constrained")
    FigureCanvasAgg(fig)
    curves = [
        ("crlb", "1 CRLB single shot", "-"),
        ("crlb_accumulated", "2 CRLB accumulated", "-"),
        ("ml_track", "3 ML track", "--"),
        ("ml_single", "4 ML single shot", "--"),
        ("sum_range", "5 sum range", ":"),
        ("difference_range", "6 difference range", ":"),
    ]
    for axis, name in enumerate(("x", "y")):
        ax = fig.add_subplot(1, 2, axis + 1)
        for key, label, style in curves:
            values = [float("nan") if s[key] is None else s[key][axis] for s in samples]
            ax.plot(y, values, style, label=label, linewidth=1.4)
        for i, note in _notes(samples).items():
            ax.axvline(y[i], color="grey", linewidth=0.8, alpha=0.6)
            ax.text(
                y[i],
                1.0,
                note,
                rotation=90,
                fontsize="small",
                va="bottom",
                ha="right",
                transform=ax.get_xaxis_transform(),
            )
        ax.set_yscale("log")
        ax.set_xlabel("target y, km")
        ax.set_ylabel(f"RMSE of {name}, m")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    fig.suptitle(
        f"Multistatic accuracy along the track (Fadeev et al., Fig. 3, curves 1-6): "
        f"{answer['runs']} runs, sigma {answer['sigma']} m"
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return out
