"""The pictures of track initiation.

- ``initiation.initiate``: the request's plots, green when a track took them, grey when
  none did; each live track's history (its recent plots of this request's scans) as a
  line, green when confirmed, amber while tentative, its last position with its 1-sigma
  ellipse and its velocity (drawn as the distance covered in 60 s), labelled ``T<id>``
  and, under existence confirmation, a tentative track with its probability of
  existence (``P_E 0.83``);
- ``initiation.simulate``: the simulated plots, green for a target's, grey for clutter,
  and each target's true track in white;
- ``initiation.evaluate`` returns counts, not geometry: the radar at the origin, labelled
  with the runs' true and false tracks (with their standard errors).
"""

from typing import Any

import numpy as np

from plotgate.service.scenes.draw import Canvas, as_points, colors
from plotgate.service.scenes.geometry import plot_positions

__all__ = ["evaluate", "initiate", "simulate", "track_label"]

VELOCITY_SECONDS = 60.0


def _scan_plots(scans: list[dict[str, Any]]) -> list[np.ndarray]:
    return [plot_positions(scan["plots"]) for scan in scans]


def initiate(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    plots = _scan_plots(request["scans"])
    for xy, outcome in zip(plots, result["scans"], strict=False):
        taken = np.asarray(outcome["associated"][: len(xy)], dtype=int) >= 0
        taken = np.pad(taken, (0, len(xy) - len(taken)))
        canvas.plots(xy[taken], colors.INSIDE)
        canvas.plots(xy[~taken], colors.CLUTTER)
    scan_index = {outcome["scan"]: k for k, outcome in enumerate(result["scans"])}
    for track in result["tracks"]:
        color = colors.INSIDE if track["status"] == "confirmed" else colors.GATE
        history = [
            plots[scan_index[scan]][plot]
            for scan, plot in track["plots"]
            if scan in scan_index and 0 <= plot < len(plots[scan_index[scan]])
        ]
        position = np.asarray(track["position"], dtype=float)
        canvas.line([*history, position], color)
        canvas.ellipse(position, track["covariance"], colors.COVARIANCE)
        velocity = VELOCITY_SECONDS * np.asarray(track["velocity"], dtype=float)
        canvas.line([position, position + velocity], color)
        canvas.text(position, track_label(track), color)


def track_label(track: dict[str, Any]) -> str:
    """``T<id> <status>``, and a tentative track's probability of existence where it has
    one (existence confirmation): ``T7 tentative P_E 0.83``."""
    label = f"T{track['id']} {track['status']}"
    existence = track.get("existence")  # absent from answers recorded before issue 38
    if existence is not None and track["status"] == "tentative":
        label += f" P_E {existence:.2f}"
    return label


def simulate(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    for xy, labels in zip(_scan_plots(result["scans"]), result["labels"], strict=False):
        target = np.pad(
            np.asarray(labels[: len(xy)], dtype=int) >= 0, (0, max(0, len(xy) - len(labels)))
        )
        canvas.plots(xy[target], colors.INSIDE)
        canvas.plots(xy[~target], colors.CLUTTER)
    truth = result["truth"]
    if truth:
        tracks = np.asarray(truth, dtype=float)  # scans x targets x 2
        for k in range(tracks.shape[1]):
            canvas.line(tracks[:, k], colors.MARK)
    canvas.plots(as_points([0.0, 0.0]), colors.TRANSMITTER, size=2.0)


def evaluate(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    canvas.plots(as_points([0.0, 0.0]), colors.TRANSMITTER, size=2.0)
    canvas.text(
        [0.0, 0.0],
        f"{result['runs']} runs: {result['mean_true']:.2f} +- {result['se_true']:.2f} true, "
        f"{result['mean_false']:.2f} +- {result['se_false']:.2f} false tracks "
        f"of {result['targets']} targets",
    )
