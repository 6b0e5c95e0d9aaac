"""``plotgate scenario``: a simulated scenario and its initiated tracks as a PNG.

Like Mu et al.'s figures 6-13: the left panel shows every plot of every scan (clutter
marked per scan: *, x, star, diamond, ...; target detections as circles; the true
positions as +), the right one every track confirmed at any scan, over the faded picture:
true tracks solid green, false tracks dashed red (named F1, F2, ...), and the true paths
of missed targets dotted grey (the rule: :func:`classify_tracks`), with the radar and the
scenario's numbers; below, one zoom per target, where a 75 m track is seen. The scans
come from ``initiation.simulate`` and the tracks from ``initiation.initiate`` called scan
by scan (so a track confirmed and later dropped is still drawn), both run in-process or on
a server (:mod:`plotgate.clients.runners`); matplotlib is optional
(``pip install "plotgate[plot]"``).
"""

import math
from pathlib import Path
from typing import Any, NamedTuple

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = [
    "MAX_ZOOMS",
    "SCAN_MARKERS",
    "ZOOM_HALF_WIDTH",
    "Classification",
    "classify_tracks",
    "confirmed_tracks",
    "default_settings",
    "describe",
    "draw_scenario",
    "scenario_figure",
    "simulate_request",
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


ZOOM_HALF_WIDTH = 120.0
"""Half the side of a target's zoom panel, m, at least: a track of four scans at 25 m/s
is 75 m long, a pixel at the overview's 15 km scale."""
MAX_ZOOMS = 6
"""Zoom panels at most (the first targets); the overview still shows every track."""
_STYLES = {"true track": ("-", "o", "tab:green"), "false track": ("--", "X", "tab:red")}


def _draw_tracks(
    ax: Any,
    sim: dict[str, Any],
    points: list[list[tuple[float, float]]],
    tracks: dict[int, Plots],
    kinds: Classification,
    *,
    legend: bool,
    ms: float,
) -> None:
    """True and false tracks, missed targets' true paths and the true positions; each
    false track is named F1, F2, ... at its last plot, so two that overlap still count
    visibly."""
    for kind, ids in (("true track", list(kinds.true)), ("false track", kinds.false)):
        line, marker, color = _STYLES[kind]
        for n, track in enumerate(ids):
            xy = [points[s][j] for s, j in tracks[track]]
            ax.plot(
                *zip(*xy, strict=True),
                linestyle=line,
                marker=marker,
                ms=ms,
                color=color,
                zorder=5,
                label=kind if legend and not n else None,
            )
            if kind == "false track":
                ax.annotate(
                    f"F{n + 1}",
                    xy[-1],
                    xytext=(4, 4),
                    textcoords="offset points",
                    color=color,
                    fontsize="small",
                    fontweight="bold",
                    annotation_clip=True,
                )
    for n, target in enumerate(kinds.missed):
        path = [step[target] for step in sim["truth"]]
        ax.plot(
            *zip(*path, strict=True),
            ":o",
            ms=ms + 3,
            mfc="none",
            mew=1.5,
            zorder=4,
            color="dimgrey",
            label="missed target" if legend and not n else None,
        )


def _draw_plots(
    ax: Any,
    sim: dict[str, Any],
    points: list[list[tuple[float, float]]],
    alpha: float,
    legend: bool,
) -> None:
    """Every plot of every scan (clutter by scan marker, target plots as blue circles) and
    the true positions."""
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
                label=_clutter_label(i, len(points)) if legend else None,
            )
        if found:
            ax.scatter(
                *zip(*found, strict=True),
                s=40,
                facecolors="none",
                edgecolors="tab:blue",
                alpha=alpha,
                label="target plots" if legend and not i else None,
            )
    truth = [p for step in sim["truth"] for p in step]
    ax.scatter(
        *zip(*truth, strict=True),
        s=30,
        marker="+",
        color="black",
        alpha=max(alpha, 0.6),
        zorder=3,
        label="true positions" if legend else None,
    )


LEGEND_SCANS = 6
"""Scans whose clutter the legend names one by one; more share one entry."""


def _clutter_label(scan: int, scans: int) -> str | None:
    """The legend entry of a scan's clutter: one per scan for a few scans, else one for
    all (forty scans made a legend taller than the figure)."""
    if scans <= LEGEND_SCANS:
        return f"clutter, scan {scan + 1}"
    return "clutter (a marker per scan)" if scan == 0 else None


def _zoom(
    ax: Any,
    sim: dict[str, Any],
    points: list[list[tuple[float, float]]],
    tracks: dict[int, Plots],
    kinds: Classification,
    target: int,
) -> None:
    """One target's neighbourhood at a scale where its track is seen: its true path with
    :data:`ZOOM_HALF_WIDTH` of margin, or more for a long path."""
    path = [step[target] for step in sim["truth"]]
    xs, ys = zip(*path, strict=True)
    cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
    half = max(ZOOM_HALF_WIDTH, (max(xs) - min(xs)) / 2 + 40.0, (max(ys) - min(ys)) / 2 + 40.0)
    _draw_plots(ax, sim, points, alpha=0.6, legend=False)
    _draw_tracks(ax, sim, points, tracks, kinds, legend=False, ms=5)
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect("equal", adjustable="box")
    ax.tick_params(labelsize="x-small")
    ax.grid(True, alpha=0.3)
    counted = [t for t, tgt in kinds.true.items() if tgt == target]
    state = "true track" if counted else "missed" if target in kinds.missed else "not confirmable"
    ax.set_title(f"target {target + 1}: {state}", fontsize="small")


def draw_scenario(
    sim: dict[str, Any],
    tracks: tuple[dict[int, Plots], dict[int, Plots]],
    scenario: dict[str, Any],
    out: Path,
    title: str,
) -> Path:
    """Draw a simulate answer and its confirmed tracks (:func:`confirmed_tracks`) into a PNG;
    ``scenario`` is the simulate request's scenario with every default filled in.

    Top: every plot, and the confirmed tracks over the faded plots (true tracks green
    circles, false ones red crosses named F1, F2, ...: markers, so a 75 m track is seen at
    the 15 km scale). Below: one zoom per target (at most :data:`MAX_ZOOMS`), a few hundred
    metres wide, where a track's line and style can be told apart."""
    from plotgate.clients.gate_figures import matplotlib_classes

    Figure, FigureCanvasAgg = matplotlib_classes()
    targets = min(len(sim["truth"][0]) if sim["truth"] else 0, MAX_ZOOMS)
    fig = Figure(figsize=(13, 10.5 if targets else 7), layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[2.3, 1.0]) if targets else (fig, None)
    points = [[_xy(p) for p in scan["plots"]] for scan in sim["scans"]]
    kinds = classify_tracks(sim, tracks[0])
    left, right = top.subplots(1, 2)
    for ax, faded in ((left, False), (right, True)):
        _draw_plots(ax, sim, points, alpha=0.2 if faded else 0.8, legend=not faded)
        ax.scatter(*scenario["sensor"], s=120, marker="^", color="black", label="radar")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x east, m")
        ax.set_ylabel("y north, m")
        ax.grid(True, alpha=0.3)
    _draw_tracks(right, sim, points, tracks[1], kinds, legend=True, ms=7)
    left.set_title(f"plots of {len(points)} scans")
    right.set_title(
        f"confirmed: {len(kinds.true)} true, {len(kinds.false)} false; "
        f"targets missed: {len(kinds.missed)}"
    )
    left.legend(fontsize="small", loc="upper right", framealpha=0.9)
    right.legend(fontsize="small", loc="upper right", framealpha=0.9)
    if bottom is not None:
        for target, ax in enumerate(bottom.subplots(1, targets, squeeze=False)[0]):
            _zoom(ax, sim, points, tracks[1], kinds, target)
        bottom.suptitle("each target up close (x east, y north, m)", fontsize="medium")
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


def describe(config: dict[str, Any]) -> str:
    """The initiation method of ``config`` (a wire ``InitiationSettings``, defaults filled
    in) in a title's words: frame, capture and confirmation."""
    frame = "polar (Mu et al.)" if config["mode"] == "polar" else "Cartesian"
    capture = f"2/{config['capture_scans']} capture in the {config['capture_gate']} gate"
    if config["confirmation"] == "score":
        confirm = (
            f"score confirmation (false_confirmation {config['false_confirmation']:g}, "
            f"at least {config['confirm_k']} plots)"
        )
    elif config["confirmation"] == "existence":
        confirm = (
            f"existence confirmation (IPDA, at existence {config['existence_confirm']:g}, "
            f"at least {config['confirm_k']} plots)"
        )
    else:
        confirm = f"{config['confirm_k']}/{config['confirm_m']} confirmation"
    return f"{frame} initiation, {capture}, {confirm}"


def default_settings(mode: str = "polar", v_max: float = 30.0) -> dict[str, Any]:
    """``plotgate scenario``'s initiation settings without ``--config``: the combined capture
    gate and the acceleration check of Mu et al.'s polar method (a_max 10 m/s^2, K_A 3)."""
    return {"mode": mode, "v_max": v_max, "capture_gate": "combined", "a_max": 10.0, "K_A": 3.0}


def simulate_request(clutter: float = 250.0, scans: int = 4, seed: int = 3) -> dict[str, Any]:
    """``plotgate scenario``'s ``initiation.simulate`` request: Mu et al.'s scenario."""
    return {"scenario": {"clutter": clutter, "scans": scans}, "seed": seed}


def scenario_figure(
    simulate_request: dict[str, Any],
    config: dict[str, Any],
    out: Path | str,
    *,
    server: str | None = None,
) -> Path:
    """Simulate, initiate scan by scan and draw; returns the PNG written."""
    from plotgate.clients.gate_figures import matplotlib_classes
    from plotgate.service.schemas import InitiationSettings, ScenarioIn

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
    method = describe(InitiationSettings.model_validate(config).model_dump())
    title = f"{method}; seed {simulate_request.get('seed', 0)}"
    return draw_scenario(sim, tracks, scenario, Path(out), title)
