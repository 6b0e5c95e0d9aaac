"""``plotgate scenario``: a simulated scenario and its initiated tracks as a PNG.

Like Mu et al.'s figures 6-13: the left panel shows every plot of every scan (clutter
marked per scan: *, x, star, diamond, ...; target detections as circles; the true
positions as +), the right one the plots of the confirmed tracks, joined in time order,
over the faded picture. The scans come from ``initiation.simulate`` and the tracks from
``initiation.initiate``, both run in-process or on a server (:mod:`plotgate.clients.runners`);
matplotlib is optional (``pip install "plotgate[plot]"``).
"""

import math
from pathlib import Path
from typing import Any

from plotgate.clients.runners import Runner, http_runner, in_process_runner

__all__ = ["SCAN_MARKERS", "draw_scenario", "scenario_figure"]

SCAN_MARKERS = ("*", "x", "p", "D", "v", "^", "s", "<", ">", "h")
"""Clutter marker of scan i (Mu et al.: *, x, star, diamond for its four scans)."""


def _xy(plot: dict[str, Any]) -> tuple[float, float]:
    if plot["frame"] == "cartesian":
        return plot["x"], plot["y"]
    az = math.radians(plot["az_deg"])
    return (
        plot["sensor"][0] + plot["r"] * math.sin(az),
        plot["sensor"][1] + plot["r"] * math.cos(az),
    )


def draw_scenario(sim: dict[str, Any], result: dict[str, Any], out: Path, title: str) -> Path:
    """Draw a simulate answer and the initiate answer on its scans into a PNG."""
    from plotgate.clients.plots import matplotlib_classes

    Figure, FigureCanvasAgg = matplotlib_classes()
    fig = Figure(figsize=(13, 6.2), layout="constrained")
    FigureCanvasAgg(fig)
    points = [[_xy(p) for p in scan["plots"]] for scan in sim["scans"]]
    left, right = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2, sharex=None)
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
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x east, m")
        ax.set_ylabel("y north, m")
        ax.grid(True, alpha=0.3)
    confirmed = [t for t in result["tracks"] if t["status"] == "confirmed"]
    for k, track in enumerate(confirmed):
        xy = [points[s][j] for s, j in track["plots"]]
        right.plot(
            *zip(*xy, strict=True),
            "-o",
            markersize=5,
            color=f"C{k % 10}",
            label=f"track {track['id']}",
        )
    left.set_title(f"plots of {len(points)} scans")
    right.set_title(f"{len(confirmed)} confirmed tracks")
    left.legend(fontsize="small", loc="best")
    if confirmed:
        right.legend(fontsize="small", loc="best")
    fig.suptitle(title)
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
    """Simulate, initiate and draw; returns the PNG written."""
    from plotgate.clients.plots import matplotlib_classes

    matplotlib_classes()  # fail before computing
    if server is None:
        run_sim: Runner = in_process_runner("initiation.simulate")
        run_init: Runner = in_process_runner("initiation.initiate")
        sim = run_sim(simulate_request)
        result = run_init({"config": config, "scans": sim["scans"]})
    else:
        from plotgate.clients.client import Client

        with Client(server) as client:
            sim = http_runner(client, "initiation.simulate")(simulate_request)
            result = http_runner(client, "initiation.initiate")(
                {"config": config, "scans": sim["scans"]}
            )
    scenario = simulate_request.get("scenario", {})
    title = (
        f"{config.get('mode', 'cartesian')} initiation, clutter "
        f"{scenario.get('clutter', 20):g} per scan, seed {simulate_request.get('seed', 0)}"
    )
    return draw_scenario(sim, result, Path(out), title)
