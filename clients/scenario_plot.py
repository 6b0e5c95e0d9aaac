"""``plotgate scenario``: a simulated scenario and its initiated tracks as a PNG.

Like Mu et al.'s figures 6-13: the left panel shows every plot of every scan (clutter
marked per scan: *, x, star, diamond, ...; target detections as circles; the true
positions as +), the right one every track confirmed at any scan, over the faded picture:
true tracks solid green, false tracks dashed red, and the true paths of missed targets
dotted grey (the rule: :func:`classify_tracks`), with the radar, the scenario's numbers and
an inset zoomed on the targets. The scans come from ``initiation.simulate`` and the tracks
from ``initiation.initiate`` called scan by scan (so a track confirmed and later dropped is
still drawn), both run in-process or on a server (:mod:`plotgate.clients.runners`);
matplotlib is optional (``pip install "plotgate[plot]"``).
"""

import math
from pathlib import Path
from typing import Any, NamedTuple

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = [
    "SCAN_MARKERS",
    "Classification",
    "classify_tracks",
    "confirmed_tracks",
    "draw_scenario",
    "scenario_figure",
]

SCAN_MARKERS = ("*", "x", "p", "D", "v", "^", "s", "<", ">", "h")
"""Clutter marker of scan i (Mu et al.: *, x, star, diamond for its four scans)."""

Plots = list[list[int]]
"""A track's plots as the initiate answer gives them: [scan number, plot index] pairs."""


class Classification(NamedTuple):
    """Confirmed tracks by :func:`classify_tracks`."""

    true: dict[int, int]
    """True track id -> the target it is counted for."""
    false: list[int]
    """False track ids."""
    missed: list[int]
    """Targets detected in ``min_detections`` scans or more that no true track counts."""


def classify_tracks(
    sim: dict[str, Any], confirmed: dict[int, Plots], min_detections: int = 3
) -> Classification:
    """Score confirmed tracks as plotgate's evaluation does (``evaluate._score``, by labels).

    ``confirmed`` maps track id -> its plots when it was confirmed, in order of confirmation;
    ``sim["labels"][scan][index]`` is a plot's target (-1 clutter). A track is TRUE when more
    than half of its plots (clutter included) come from one target and that target has not
    been counted for an earlier track; every other confirmed track is FALSE. A target
    detected in at least ``min_detections`` scans that no true track counts is MISSED.
    """
    labels: list[list[int]] = sim["labels"]
    true: dict[int, int] = {}
    false: list[int] = []
    for track, plots in confirmed.items():
        sources = [labels[s][j] for s, j in plots]
        counts = {t: sources.count(t) for t in set(sources) if t >= 0}
        target = max(counts, key=counts.__getitem__, default=-1)
        if target >= 0 and 2 * counts[target] > len(plots) and target not in true.values():
            true[track] = target
        else:
            false.append(track)
    scans_seen: dict[int, int] = {}
    for scan in labels:
        for t in set(scan) - {-1}:
            scans_seen[t] = scans_seen.get(t, 0) + 1
    counted = set(true.values())
    missed = sorted(t for t, n in scans_seen.items() if n >= min_detections and t not in counted)
    return Classification(true, false, missed)


def confirmed_tracks(
    run_init: Runner, config: dict[str, Any], scans: list[dict[str, Any]]
) -> tuple[dict[int, Plots], dict[int, Plots]]:
    """Initiate scan by scan; per confirmed track id, its plots at confirmation and the last
    plots known (the answer's ``tracks`` lists only live tracks, so they are kept here)."""
    at_confirmation: dict[int, Plots] = {}
    last: dict[int, Plots] = {}
    state = None
    for scan in scans:
        request = {"config": config, "scans": [scan]}
        answer = run_init(request if state is None else {**request, "state": state})
        state = answer["state"]
        live = {t["id"]: t["plots"] for t in answer["tracks"]}
        for track in answer["scans"][0]["confirmed"]:
            at_confirmation[track] = live[track]
        last.update((i, p) for i, p in live.items() if i in at_confirmation)
    return at_confirmation, last


def _xy(plot: dict[str, Any]) -> tuple[float, float]:
    if plot["frame"] == "cartesian":
        return plot["x"], plot["y"]
    az = math.radians(plot["az_deg"])
    return (
        plot["sensor"][0] + plot["r"] * math.sin(az),
        plot["sensor"][1] + plot["r"] * math.cos(az),
    )


def _draw_tracks(
    ax: Any,
    sim: dict[str, Any],
    points: list[list[tuple[float, float]]],
    tracks: dict[int, Plots],
    kinds: Classification,
    legend: bool,
) -> None:
    """True and false tracks, missed targets' true paths and the true positions."""
    styles = {"true track": ("-o", "tab:green"), "false track": ("--o", "tab:red")}
    for kind, ids in (("true track", list(kinds.true)), ("false track", kinds.false)):
        for n, track in enumerate(ids):
            xy = [points[s][j] for s, j in tracks[track]]
            fmt, color = styles[kind]
            ax.plot(
                *zip(*xy, strict=True),
                fmt,
                ms=5,
                color=color,
                label=kind if legend and not n else None,
            )
    for n, target in enumerate(kinds.missed):
        path = [step[target] for step in sim["truth"]]
        ax.plot(
            *zip(*path, strict=True),
            ":o",
            ms=9,
            mfc="none",
            mew=1.5,
            zorder=4,
            color="dimgrey",
            label="missed target" if legend and not n else None,
        )
    truth = [p for step in sim["truth"] for p in step]
    ax.scatter(*zip(*truth, strict=True), s=30, marker="+", color="black", zorder=3)


def draw_scenario(
    sim: dict[str, Any],
    tracks: tuple[dict[int, Plots], dict[int, Plots]],
    scenario: dict[str, Any],
    out: Path,
    title: str,
) -> Path:
    """Draw a simulate answer and its confirmed tracks (:func:`confirmed_tracks`) into a PNG;
    ``scenario`` is the simulate request's scenario with every default filled in."""
    from plotgate.clients.plots import matplotlib_classes

    Figure, FigureCanvasAgg = matplotlib_classes()
    fig = Figure(figsize=(13, 6.6), layout="constrained")
    FigureCanvasAgg(fig)
    points = [[_xy(p) for p in scan["plots"]] for scan in sim["scans"]]
    kinds = classify_tracks(sim, tracks[0])
    left, right = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    for ax, faded in ((left, False), (right, True)):
        alpha = 0.25 if faded else 0.8
        for i, (xy, labels) in enumerate(zip(points, sim["labels"], strict=True)):
            clutter = [p for p, lab in zip(xy, labels, strict=True) if lab < 0]
            found = [p for p, lab in zip(xy, labels, strict=True) if lab >= 0]
            if clutter:
                ax.scatter(
                    *zip(*clutter, strict=True),
                    s=14,
                    marker=SCAN_MARKERS[i % 10],
                    alpha=alpha,
                    color="grey",
                    label=None if faded else f"clutter, scan {i + 1}",
                )
            if found:
                ax.scatter(
                    *zip(*found, strict=True),
                    s=40,
                    facecolors="none",
                    edgecolors="tab:blue",
                    alpha=alpha,
                    label=None if faded or i else "target plots",
                )
        truth = [p for step in sim["truth"] for p in step]
        ax.scatter(
            *zip(*truth, strict=True),
            s=30,
            marker="+",
            color="black",
            alpha=alpha,
            label=None if faded else "true positions",
        )
        ax.scatter(*scenario["sensor"], s=120, marker="^", color="black", label="radar")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x east, m")
        ax.set_ylabel("y north, m")
        ax.grid(True, alpha=0.3)
    _draw_tracks(right, sim, points, tracks[1], kinds, legend=True)
    xs, ys = zip(*(p for step in sim["truth"] for p in step), strict=True)
    fig.canvas.draw()  # settle the limits the equal aspect chooses, to place the inset
    (x0, x1), (y0, y1) = right.get_xlim(), right.get_ylim()
    box = ((min(xs) - x0) / (x1 - x0), (max(xs) - x0) / (x1 - x0))
    boy = ((min(ys) - y0) / (y1 - y0), (max(ys) - y0) / (y1 - y0))

    def overlap(c: tuple[float, float]) -> float:  # of the inset at corner c and the targets
        w = max(0.0, min(c[0] + 0.35, box[1]) - max(c[0], box[0]))
        return w * max(0.0, min(c[1] + 0.35, boy[1]) - max(c[1], boy[0]))

    corner = min(((0.63, 0.04), (0.63, 0.61), (0.1, 0.61), (0.1, 0.04)), key=overlap)
    inset = right.inset_axes([*corner, 0.35, 0.35])
    for i, xy in enumerate(points):
        if xy:
            inset.scatter(
                *zip(*xy, strict=True), s=10, marker=SCAN_MARKERS[i % 10], color="grey", alpha=0.2
            )
    _draw_tracks(inset, sim, points, tracks[1], kinds, legend=False)
    inset.set_xlim(min(xs) - 300.0, max(xs) + 300.0)
    inset.set_ylim(min(ys) - 300.0, max(ys) + 300.0)
    inset.set_aspect("equal", adjustable="box")
    inset.tick_params(labelsize="x-small")
    right.indicate_inset_zoom(inset, edgecolor="black")
    left.set_title(f"plots of {len(points)} scans")
    right.set_title(
        f"confirmed: {len(kinds.true)} true, {len(kinds.false)} false; "
        f"targets missed: {len(kinds.missed)}"
    )
    left.legend(fontsize="small", loc="best")
    right.legend(fontsize="small", loc="upper right" if corner[0] < 0.5 else "upper left")
    times = [scan["t"] for scan in sim["scans"]]
    period = times[1] - times[0] if len(times) > 1 else scenario["interval"]
    fig.suptitle(
        f"{title}\nradar at ({scenario['sensor'][0]:g}, {scenario['sensor'][1]:g}) m, "
        f"scan period {period:g} s, P_D {scenario['P_D']:g}, "
        f"clutter {scenario['clutter']:g}/scan, {len(times)} scans"
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    return out


def scenario_figure(
    simulate_request: dict[str, Any],
    config: dict[str, Any],
    out: Path | str,
    *,
    server: str | None = None,
) -> Path:
    """Simulate, initiate scan by scan and draw; returns the PNG written."""
    from plotgate.clients.plots import matplotlib_classes
    from plotgate.service.schemas import ScenarioIn

    matplotlib_classes()  # fail before computing
    if server is None:
        sim = in_process_runner("initiation.simulate")(simulate_request)
        tracks = confirmed_tracks(in_process_runner("initiation.initiate"), config, sim["scans"])
    else:
        from plotgate.clients.client import Client

        with Client(server) as client:
            sim = http_runner(client, "initiation.simulate")(simulate_request)
            run_init = http_runner(client, "initiation.initiate")
            tracks = confirmed_tracks(run_init, config, sim["scans"])
    scenario = ScenarioIn.model_validate(simulate_request.get("scenario", {})).model_dump()
    title = f"{config.get('mode', 'cartesian')} initiation, seed {simulate_request.get('seed', 0)}"
    return draw_scenario(sim, tracks, scenario, Path(out), title)
