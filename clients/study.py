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

Each check's verdict weighs its shortfall against that Monte Carlo noise
(:func:`verdict`): ``met`` when the estimate is within the limit; ``NOT MET`` only when
it is beyond the limit by more than :func:`noise_allowance` standard errors (2 for one
estimate; for a check "at every sample", the allowance that noise alone passes at every
one of n samples 39 times in 40: 3.66 standard errors at 200 samples); ``within noise``
between the two, where more runs decide. The standard error of a ratio to a bound is the
RMSE's own: the study's ``ml_single_se`` for the ML single shot, and 1/sqrt(2R) of the
ratio for the others (the relative standard error of an RMSE of Gaussian errors over R
runs; for the paired ratio, whose noise mostly cancels, an upper bound). The largest
Mahalanobis error and the unflagged false minima are a largest value and a count, not
estimates of a mean: no standard error, ``met`` or ``NOT MET``.
"""

from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist
from typing import Any

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = [
    "DEFAULT_REQUEST",
    "LIMITS",
    "OPERATION",
    "MET",
    "NOT_MET",
    "WITHIN_NOISE",
    "Check",
    "checks",
    "draw",
    "noise_allowance",
    "run_study",
    "table",
    "verdict",
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
MET, WITHIN_NOISE, NOT_MET = "met", "within noise", "NOT MET"
NOISE_ALLOWANCE = 2.0
"""Standard errors a single estimate may lie beyond its limit before it is NOT MET."""
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


def _crossings(samples: list[dict[str, Any]]) -> dict[int, int]:
    """Sample index -> k, where the target crosses baseline k (transmitter to receiver k,
    counted from 1): a local minimum of that range sum's gradient below
    :data:`_BASELINE_GRADIENT`."""
    crossings: dict[int, int] = {}
    for p in range(len(samples[0]["gradient"])):
        g = [s["gradient"][p] for s in samples]
        for i in range(len(g)):
            lower = (i == 0 or g[i] <= g[i - 1]) and (i + 1 == len(g) or g[i] <= g[i + 1])
            if lower and g[i] < _BASELINE_GRADIENT:
                crossings[i] = p + 1
    return crossings


CROSSING_NOTE = "bk: the target crosses baseline k (transmitter to receiver k)"


@dataclass(frozen=True)
class Check:
    """One accuracy requirement: what, the measured value with its standard error, and the
    verdict (:data:`MET`, :data:`WITHIN_NOISE` or :data:`NOT_MET`)."""

    requirement: str
    result: str
    verdict: str

    @property
    def passed(self) -> bool:
        """False only for a shortfall beyond the Monte Carlo noise."""
        return self.verdict != NOT_MET


def noise_allowance(n: int) -> float:
    """Standard errors an estimate may lie beyond its limit, at the worst of ``n``, before
    the shortfall is more than noise: 2 for one estimate; for n, the one-sided quantile that
    noise alone exceeds at any of them with probability 1/40 (Bonferroni), at least 2."""
    return max(NOISE_ALLOWANCE, NormalDist().inv_cdf(1.0 - 0.025 / max(n, 1)))


def verdict(estimates: list[tuple[float, float]], limit: float) -> str:
    """The verdict on ``(ratio, standard error)`` estimates that should all lie within
    ``limit`` of 1: :data:`NOT_MET` when one lies beyond it by more than
    :func:`noise_allowance` of its standard errors."""
    excess = [(abs(r - 1.0) - limit, se) for r, se in estimates]
    if all(e <= 0.0 for e, _ in excess):
        return MET
    allowance = noise_allowance(len(estimates))
    if any(e > allowance * se for e, se in excess):
        return NOT_MET
    return WITHIN_NOISE


def _worst(values: list[tuple[int, float, float]]) -> tuple[int, float, float]:
    """(sample, ratio, standard error) farthest from 1."""
    return max(values, key=lambda v: abs(v[1] - 1.0))


def _ratio_check(requirement: str, values: list[tuple[int, float, float]], limit: float) -> Check:
    """A check that every (sample, ratio, standard error) lies within ``limit`` of 1."""
    i, r, se = _worst(values)
    outside = sum(abs(v - 1.0) > limit for _, v, _ in values)
    where = f"worst {r:.3f} ± {se:.3f} at sample {i}"
    if len(values) > 1:
        where += f" ({outside} of {len(values)} outside)"
    return Check(requirement, where, verdict([(v, e) for _, v, e in values], limit))


def checks(answer: dict[str, Any]) -> list[Check]:
    """Judge a study answer against :data:`LIMITS` (track checks only with tracks)."""
    samples = answer["samples"]
    rel = 1.0 / (2.0 * answer["runs"]) ** 0.5  # relative standard error of an RMSE

    def ratios(num: str, den: str) -> list[tuple[int, float, float]]:
        out = [(i, _ratio(s, num, den)) for i, s in enumerate(samples) if s[num] is not None]
        return [(i, r, r * rel) for i, r in out]

    lim = LIMITS["ml_single"]
    single = [
        (i, r, r * s["ml_single_se"])
        for i, s in enumerate(samples)
        for r in [_ratio(s, "ml_single", "crlb")]
    ]
    out = [
        _ratio_check(f"ML single shot within {lim:.0%} of the CRLB at every sample", single, lim),
        _ratio_check(
            f"ML single shot within {lim:.0%} of the linearised efficient estimator on the "
            "same noise at every sample (paired: Monte Carlo noise mostly cancels)",
            ratios("ml_single", "linearised"),
            lim,
        ),
    ]
    far = max(s["max_distance"] for s in samples)
    out.append(
        Check(
            f"no ML solution more than {LIMITS['max_distance']:g} CRLB away",
            f"largest Mahalanobis error {far:.2f} (a largest value: no standard error)",
            MET if far <= LIMITS["max_distance"] else NOT_MET,
        )
    )
    out.append(
        _ratio_check(
            f"difference range within {LIMITS['difference_range']:.0%} of its CRLB at every "
            "sample",
            ratios("difference_range", "crlb_difference"),
            LIMITS["difference_range"],
        )
    )
    if samples[-1]["full_track"] is not None:
        out += [
            _ratio_check(
                f"ML track within {LIMITS['ml_track']:.0%} of its accumulated CRLB at every "
                "prefix",
                ratios("ml_track", "crlb_accumulated"),
                LIMITS["ml_track"],
            ),
            _ratio_check(
                f"full ML track within {LIMITS['full_track']:.0%} of its CRLB at every sample",
                ratios("full_track", "full_track_crlb"),
                LIMITS["full_track"],
            ),
        ]
    false = sum(s["false_minima"] for s in samples)
    unflagged = sum(s["false_unflagged"] for s in samples)
    out.append(
        Check(
            "every false minimum flagged by the chi-square test",
            f"{false} false minima, {unflagged} unflagged (a count: no standard error)",
            MET if unflagged == 0 else NOT_MET,
        )
    )
    return out


def _bold(text: str) -> str:
    return f"**{text}**"


def _fmt(v: float) -> str:
    if v != v:
        return "—"
    return f"{v:.3g}" if abs(v) < 1000 else f"{v:,.0f}"


def table(answer: dict[str, Any], every: int = 1) -> str:
    """Markdown: the checks, then one row per sample (every ``every``-th, plus crossings)."""
    samples = answer["samples"]
    notes = {i: f"on b{k}" for i, k in _crossings(samples).items()}
    lines = [
        f"Monte Carlo: {answer['runs']} runs, seed {answer['seed']}, sigma {answer['sigma']} m;"
        f" eq. 5 noise estimate {answer['noise_sigma']:.4f} ± "
        f"{answer['noise_sigma_spread']:.4f} m.",
        "",
        "| requirement | result (± one standard error) | verdict |",
        "|---|---|---|",
        *(
            f"| {c.requirement} | {c.result} | {_bold(c.verdict) if not c.passed else c.verdict} |"
            for c in checks(answer)
        ),
        "",
        "Total RMSE sqrt(sum of per-axis RMSE^2), m; curves of Fadeev et al., Fig. 3: "
        "1 single-shot CRLB, 2 accumulated CRLB, 3 ML track, 4 ML single shot, 5 sum range, "
        "6 difference range; lin: the linearised efficient estimator on the same noise; "
        f'dist: largest Mahalanobis error of curve 4; note "on bk": '
        f"{CROSSING_NOTE.removeprefix('bk: ')}.",
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
    from plotgate.clients.gate_figures import matplotlib_classes

    Figure, FigureCanvasAgg = matplotlib_classes()
    samples = answer["samples"]
    y = [s["position"][1] / 1e3 for s in samples]
    fig = Figure(figsize=(12, 6.2), layout="constrained")
    FigureCanvasAgg(fig)
    curves = [
        ("crlb", "1 CRLB single shot", "-"),
        ("crlb_accumulated", "2 CRLB accumulated", "-"),
        ("ml_track", "3 ML track", "--"),
        ("ml_single", "4 ML single shot", "--"),
        ("sum_range", "5 sum range", ":"),
        ("difference_range", "6 difference range", ":"),
    ]
    crossings = _crossings(samples)
    for axis, name in enumerate(("x", "y")):
        ax = fig.add_subplot(1, 2, axis + 1)
        for key, label, style in curves:
            values = [float("nan") if s[key] is None else s[key][axis] for s in samples]
            ax.plot(y, values, style, label=label, linewidth=1.4)
        for n, (i, k) in enumerate(crossings.items()):
            ax.axvline(
                y[i], color="grey", linewidth=0.8, alpha=0.6, label=None if n else CROSSING_NOTE
            )
            ax.text(
                y[i],
                1.0,
                f"b{k}",
                fontsize="small",
                va="bottom",
                ha="center",
                transform=ax.get_xaxis_transform(),
            )
        ax.set_yscale("log")
        ax.set_xlabel("target y, km")
        ax.set_ylabel(f"RMSE of {name}, m")
        ax.grid(True, which="both", alpha=0.3)
    # one legend for both panels, below them, where it covers no curve
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=3)
    fig.suptitle(
        f"Multistatic accuracy along the track (Fadeev et al., Fig. 3, curves 1-6): "
        f"{answer['runs']} runs, sigma {answer['sigma']} m"
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return out
