"""Konovalov's gating-probability figures, drawn from the service's own answers.

``plotgate plot fig2`` redraws Fig. 2 of Konovalov: the conditional probability
that the second mark falls in the ring gate, (a) against target speed at R = 20 km, (b) at
R = 50 km, (c) against range at v = 200 m/s and (d) at v = 300 m/s, one curve per sensor
error (sigma_R, sigma_az). ``fig5`` is the same for the combined two-stage gate with
P_G = 0.9 (the paper's Fig. 5). ``compare`` plots the unconditional probability (the
paper's ``area`` prior, eq. 3-6) against range for the ring, combined and expanded gates,
with the paper's worked values (0.90 at 20 km and 0.82 at 50 km for the ring,
P'_Sigma = 0.9967 at 50 km for the combined gate) marked.

Every point comes from the operation ``gates.probability_curve``: the requests are plain
JSON dicts (:func:`speed_curve`, :func:`range_curve`, :func:`figure_requests`), run either
in-process or against a live server (:mod:`plotgate.clients.runners`).

Choices the paper leaves open: the first mark lies due north of the radar (azimuth 0) and
the course is 0 (north), so the target moves along the line of sight, where the range
error acts; both marks have the same sigmas; the speed axis spans the gate's own
[v_min, v_max]; the range axes span 5-100 km (conditional) and 10-80 km (unconditional,
15 points, each costing about a second of quadrature). matplotlib is optional
(``pip install "plotgate[plot]"``) and is imported only to draw, with the Agg canvas and
no pyplot state.
"""

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = [
    "FIGURES",
    "SENSOR_ERRORS",
    "MissingMatplotlib",
    "Panel",
    "Setup",
    "figure_requests",
    "matplotlib_classes",
    "plot",
    "range_curve",
    "speed_curve",
]

OPERATION = "gates.probability_curve"
FIGURES = ("fig2", "fig5", "compare")
DEFAULT_FILES = {
    "fig2": "fig2_ring.png",
    "fig5": "fig5_combined.png",
    "compare": "compare_unconditional.png",
}
SENSOR_ERRORS: tuple[tuple[float, float], ...] = ((100.0, 0.25), (200.0, 0.5), (300.0, 1.0))
"""(sigma_r m, sigma_az deg) of the curves of each panel; the paper's example is 200 m, 0.5 deg."""
PAPER_ERROR = (200.0, 0.5)
SPEED_RANGES_KM = (20.0, 50.0)
RANGE_SPEEDS = (200.0, 300.0)
CONDITIONAL_RANGE_KM = (5.0, 100.0)
UNCONDITIONAL_RANGE_KM = (10.0, 80.0)
DEFAULT_POINTS = {"speed": 81, "range": 96, "unconditional": 15}
PAPER_VALUES = {  # Konovalov's worked examples: (gate kind, range km, probability)
    "ring": ((20.0, 0.90), (50.0, 0.82)),
    "combined": ((50.0, 0.9967),),
}
INSTALL_HINT = 'matplotlib is needed to draw figures: pip install "plotgate[plot]"'


class MissingMatplotlib(ImportError):
    """matplotlib is not installed; the message says how to install it."""


@dataclass(frozen=True)
class Setup:
    """The scenario of Konovalov's figures (defaults: the paper's)."""

    tau: float = 5.0
    v_min: float = 100.0
    v_max: float = 500.0
    course_deg: float = 0.0
    az_deg: float = 0.0
    P_G: float = 0.9
    p: float = 0.9

    def gate(self, kind: str) -> dict[str, Any]:
        """The wire ``gate`` of a capture-gate kind (tau travels in the request)."""
        if kind == "ring":
            return {"kind": "ring", "v_min": self.v_min, "v_max": self.v_max}
        if kind == "combined":
            return {"kind": "combined", "v_min": self.v_min, "v_max": self.v_max, "P_G": self.P_G}
        if kind == "expanded":
            return {"kind": "expanded", "v_max": self.v_max, "p": self.p}
        raise ValueError(f"no figure gate of kind {kind!r}")

    def mark(self, r: float, sigma_r: float, sigma_az_deg: float) -> dict[str, Any]:
        """The wire ``mark``: both marks with the same sigmas."""
        return {"r": r, "az_deg": self.az_deg, "sigma_r": sigma_r, "sigma_az_deg": sigma_az_deg}

    def describe(self, conditional: bool = True) -> str:
        course = f"course {self.course_deg:g}°, " if conditional else "uniform heading, "
        return (
            f"τ = {self.tau:g} s, v {self.v_min:g}–{self.v_max:g} m/s, {course}"
            f"first mark at azimuth {self.az_deg:g}°, equal errors on both marks"
        )


def speed_curve(
    gate: dict[str, Any],
    mark: dict[str, Any],
    tau: float,
    speeds: Sequence[float],
    course_deg: float = 0.0,
) -> dict[str, Any]:
    """A conditional ``gates.probability_curve`` request against speed (m/s)."""
    return {
        "gate": gate,
        "mark": mark,
        "tau": tau,
        "against": "speed",
        "values": [float(v) for v in speeds],
        "course_deg": course_deg,
    }


def range_curve(
    gate: dict[str, Any],
    mark: dict[str, Any],
    tau: float,
    ranges: Sequence[float],
    *,
    speed: float | None = None,
    course_deg: float = 0.0,
    prior: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A ``gates.probability_curve`` request against the first mark's range (m).

    With ``speed`` (and ``course_deg``) the curve is conditional; with ``prior``
    (``{"kind": "area" | "speed", "v_min", "v_max"}``) unconditional. Exactly one is given.
    ``mark["r"]`` is replaced by each range; it is set to the first so the mark stays valid.
    """
    if (speed is None) == (prior is None):
        raise ValueError("give exactly one of speed and prior")
    values = [float(r) for r in ranges]
    body: dict[str, Any] = {
        "gate": gate,
        "mark": {**mark, "r": values[0]},
        "tau": tau,
        "against": "range",
        "values": values,
        "course_deg": course_deg,
    }
    if speed is not None:
        body["speed"] = float(speed)
    else:
        body["prior"] = prior
    return body


def _grid(lo: float, hi: float, n: int) -> list[float]:
    if n < 2:
        return [lo]
    return [lo + (hi - lo) * i / (n - 1) for i in range(n)]


@dataclass
class Panel:
    """One axes of a figure: its curves as (label, request) pairs, answers filled in later."""

    title: str
    xlabel: str
    against: str
    curves: list[tuple[str, dict[str, Any]]]
    answers: list[dict[str, Any]] = field(default_factory=list)
    reference: float | None = None  # a horizontal line (P_G of the combined gate)
    marks: dict[str, tuple[tuple[float, float], ...]] = field(default_factory=dict)


def _sigma_label(sigma_r: float, sigma_az_deg: float) -> str:
    return f"σR = {sigma_r:g} m, σα = {sigma_az_deg:g}°"


def figure_requests(
    figure: str, setup: Setup | None = None, points: int | None = None
) -> list[Panel]:
    """The panels of ``figure`` (``fig2``, ``fig5`` or ``compare``) with their requests.

    ``points`` overrides the number of values per curve (default 81 speeds, 96 ranges,
    15 ranges for the unconditional curves).
    """
    setup = setup or Setup()
    if points is not None and points < 2:
        raise ValueError(f"points must be at least 2, got {points}")
    if figure in ("fig2", "fig5"):
        return _conditional_panels("ring" if figure == "fig2" else "combined", setup, points)
    if figure == "compare":
        return _compare_panels(setup, points)
    raise ValueError(f"unknown figure {figure!r}; choose one of {', '.join(FIGURES)}")


def _conditional_panels(kind: str, setup: Setup, points: int | None) -> list[Panel]:
    gate = setup.gate(kind)
    speeds = _grid(setup.v_min, setup.v_max, points or DEFAULT_POINTS["speed"])
    lo, hi = CONDITIONAL_RANGE_KM
    ranges = _grid(lo * 1e3, hi * 1e3, points or DEFAULT_POINTS["range"])
    reference = setup.P_G if kind == "combined" else None
    panels = []
    for letter, r_km in zip("ab", SPEED_RANGES_KM, strict=True):
        curves = [
            (
                _sigma_label(sr, sa),
                speed_curve(
                    gate, setup.mark(r_km * 1e3, sr, sa), setup.tau, speeds, setup.course_deg
                ),
            )
            for sr, sa in SENSOR_ERRORS
        ]
        panels.append(
            Panel(
                f"({letter}) R = {r_km:g} km",
                "target speed v, m/s",
                "speed",
                curves,
                reference=reference,
            )
        )
    for letter, v in zip("cd", RANGE_SPEEDS, strict=True):
        curves = [
            (
                _sigma_label(sr, sa),
                range_curve(
                    gate,
                    setup.mark(ranges[0], sr, sa),
                    setup.tau,
                    ranges,
                    speed=v,
                    course_deg=setup.course_deg,
                ),
            )
            for sr, sa in SENSOR_ERRORS
        ]
        panels.append(
            Panel(
                f"({letter}) v = {v:g} m/s",
                "range of the first mark R, km",
                "range",
                curves,
                reference=reference,
            )
        )
    return panels


def _compare_panels(setup: Setup, points: int | None) -> list[Panel]:
    lo, hi = UNCONDITIONAL_RANGE_KM
    ranges = _grid(lo * 1e3, hi * 1e3, points or DEFAULT_POINTS["unconditional"])
    prior = {"kind": "area", "v_min": setup.v_min, "v_max": setup.v_max}
    names = {
        "ring": "ring",
        "combined": f"combined, P_G = {setup.P_G:g}",
        "expanded": f"expanded, p = {setup.p:g}",
    }
    curves = [
        (
            name,
            range_curve(
                setup.gate(kind),
                setup.mark(ranges[0], *PAPER_ERROR),
                setup.tau,
                ranges,
                prior=prior,
                course_deg=setup.course_deg,
            ),
        )
        for kind, name in names.items()
    ]
    marks = {names[k]: v for k, v in PAPER_VALUES.items()}
    title = f"unconditional (prior: position uniform over the ring), {_sigma_label(*PAPER_ERROR)}"
    return [Panel(title, "range of the first mark R, km", "range", curves, marks=marks)]


def matplotlib_classes() -> tuple[Any, Any]:
    """(Figure, FigureCanvasAgg), or :class:`MissingMatplotlib` with the install hint."""
    try:
        import matplotlib  # noqa: F401
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise MissingMatplotlib(INSTALL_HINT) from exc
    return Figure, FigureCanvasAgg


_TITLE_CHARS_PER_INCH = 10.5
"""Characters of a title's text per inch of figure (DejaVu Sans at matplotlib's "large")."""
_TITLES = {
    "fig2": "Ring gate: conditional probability of gating the second mark (Konovalov, Fig. 2)",
    "fig5": "Combined gate, P_G = {P_G:g}: conditional probability (Konovalov, Fig. 5)",
    "compare": "Ring vs combined vs expanded gate: unconditional probability "
    "(Konovalov, eq. 3-6 and its worked values)",
}


def draw(figure: str, panels: list[Panel], setup: Setup, out: Path) -> Path:
    """Draw answered panels into a PNG at ``out`` (matplotlib, Agg canvas)."""
    Figure, FigureCanvasAgg = matplotlib_classes()
    single = len(panels) == 1
    fig = Figure(figsize=(8.5, 6) if single else (12, 9), layout="constrained")
    FigureCanvasAgg(fig)
    axes = (
        [fig.add_subplot(1, 1, 1)]
        if single
        else [fig.add_subplot(2, 2, i + 1) for i in range(len(panels))]
    )
    ax_width = fig.get_figwidth() / (1 if single else 2)
    for ax, panel in zip(axes, panels, strict=True):
        for (label, _), answer in zip(panel.curves, panel.answers, strict=True):
            x = [v / 1e3 if panel.against == "range" else v for v in answer["values"]]
            style = {"marker": "o", "markersize": 3} if single else {}
            (line,) = ax.plot(x, answer["probability"], label=label, **style)
            for r_km, p in panel.marks.get(label, ()):
                ax.plot(
                    [r_km],
                    [p],
                    marker="*",
                    markersize=13,
                    linestyle="none",
                    color=line.get_color(),
                    markeredgecolor="black",
                    label=f"paper: {p:g} at {r_km:g} km",
                )
        if panel.reference is not None:
            ax.axhline(
                panel.reference,
                color="grey",
                linestyle="--",
                linewidth=1,
                label=f"P_G = {panel.reference:g}",
            )
        ax.set_title(textwrap.fill(panel.title, int(_TITLE_CHARS_PER_INCH * 0.9 * ax_width)))
        ax.set_xlabel(panel.xlabel)
        ax.set_ylabel("probability P")
        ax.set_ylim(top=1.005)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small", loc="center right" if single else "best")
    title = _TITLES[figure].format(P_G=setup.P_G)
    # wrapped to the figure's width: a long suptitle is clipped at both edges, not shrunk
    lines = (title, setup.describe(conditional=figure != "compare"))
    width = int(fig.get_figwidth() * _TITLE_CHARS_PER_INCH)
    fig.suptitle("\n".join(textwrap.fill(line, width) for line in lines))
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    return out


def plot(
    figure: str,
    out: Path | str | None = None,
    *,
    server: str | None = None,
    setup: Setup | None = None,
    points: int | None = None,
    runner: Runner | None = None,
) -> Path:
    """Compute and draw ``figure``; returns the PNG path written.

    Parameters
    ----------
    figure : ``fig2``, ``fig5`` or ``compare``.
    out : the PNG to write (default ``fig2_ring.png`` etc. in the current folder).
    server : base URL of a live plotgate; None computes in-process.
    setup : the scenario (default Konovalov's: tau 5 s, v 100-500 m/s, course 0).
    points : values per curve, to make quick (test) figures.
    runner : run the requests with this instead (overrides ``server``).
    """
    matplotlib_classes()  # fail before computing anything
    setup = setup or Setup()
    panels = figure_requests(figure, setup, points)
    out = Path(out) if out is not None else Path(DEFAULT_FILES[figure])
    if runner is not None:
        return _answer_and_draw(figure, panels, setup, out, runner)
    if server is None:
        return _answer_and_draw(figure, panels, setup, out, in_process_runner(OPERATION))
    from plotgate.clients.client import Client

    with Client(server) as client:
        return _answer_and_draw(figure, panels, setup, out, http_runner(client, OPERATION))


def _answer_and_draw(
    figure: str, panels: list[Panel], setup: Setup, out: Path, runner: Runner
) -> Path:
    for panel in panels:
        panel.answers = [runner(body) for _, body in panel.curves]
    return draw(figure, panels, setup, out)
