"""The pictures of the multistatic solves: transmitters (blue), receivers (cyan) and the
baselines between them, solved positions (yellow) with their 1-sigma covariance or CRLB
ellipses, tracks as lines.

- ``solves.position``: each problem's platforms and its solution (an alternative root of
  the closed form in grey); an unsolvable problem's platforms only;
- ``solves.trajectory``: the platforms at their given positions, the estimated positions at
  the requested times as a track with their ellipses, and the fitted velocity from the
  reference position (the distance travelled in one second, drawn 60 times longer);
- ``solves.crlb``: each target with its single-shot CRLB ellipse and GDOP;
- ``solves.noise``: the positions given, and the smoothed ones as a track;
- ``solves.study``: the target's track, and at each sample the CRLB's sigmas as an
  ellipse on the axes.
"""

from typing import Any

import numpy as np

from plotgate.service.scenes.draw import Canvas, as_points, colors
from plotgate.service.scenes.geometry import position_of

__all__ = ["crlb", "noise", "position", "study", "trajectory"]

VELOCITY_SECONDS = 60.0
"""A velocity is drawn as the distance it covers in this time."""
MAX_PROBLEMS = 200
"""Problems of one ``solves.position`` exchange drawn with their platforms."""


def _platforms(canvas: Canvas, transmitter: Any, receivers: list[Any]) -> None:
    """The transmitter, the receivers and the baselines from one to the others."""
    tx = np.asarray(position_of(transmitter), dtype=float)
    rx = as_points([position_of(r) for r in receivers])
    canvas.plots(tx, colors.TRANSMITTER, size=2.0)
    canvas.plots(rx, colors.RECEIVER, size=2.0)
    canvas.segments(np.broadcast_to(tx, rx.shape), rx, colors.TRANSMITTER)


def position(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    problems, solutions = request["problems"], result["solutions"]
    canvas.left_out += max(0, len(problems) - MAX_PROBLEMS)
    for problem, solution in zip(problems[:MAX_PROBLEMS], solutions, strict=False):
        if problem.get("transmitter") is not None:
            _platforms(canvas, problem["transmitter"], problem["receivers"])
        else:
            canvas.plots(as_points(problem["receivers"]), colors.RECEIVER, size=2.0)
        if not solution.get("solvable", True) or solution.get("position") is None:
            continue
        canvas.plots(solution["position"], colors.SOLUTION, size=1.5)
        if solution.get("covariance") is not None:
            canvas.ellipse(solution["position"], solution["covariance"], colors.COVARIANCE)
        if solution.get("alternative") is not None:
            canvas.plots(solution["alternative"], colors.CLUTTER)
    canvas.text([0.0, 0.0], f"{result['count_solvable']} of {len(problems)} solved")


def trajectory(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    _platforms(canvas, request["transmitter"], request["receivers"])
    positions = as_points(result.get("positions") or [])
    canvas.line(positions, colors.SOLUTION)
    canvas.plots(positions, colors.SOLUTION)
    for at, cov in zip(positions, result.get("covariances") or [], strict=False):
        canvas.ellipse(at, cov, colors.COVARIANCE)
    state = result["state"]
    start = np.asarray(state["position"], dtype=float)
    end = start + VELOCITY_SECONDS * np.asarray(state["velocity"], dtype=float)
    canvas.plots(start, colors.SOLUTION, size=1.5)
    canvas.line([start, end], colors.SOLUTION)
    speed = float(np.linalg.norm(state["velocity"]))
    canvas.text(start, f"t_ref {result['t_ref']:g} s, {speed:.1f} m/s")


def crlb(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    _platforms(canvas, request["transmitter"], request["receivers"])
    shot = result["single_shot"]
    for at, cov, gdop in zip(result["positions"], shot["covariance"], shot["gdop"], strict=False):
        canvas.plots(at, colors.SOLUTION)
        canvas.ellipse(at, cov, colors.COVARIANCE)
        canvas.text(at, f"GDOP {gdop:.3g}")


def noise(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    if request.get("positions") is not None:
        canvas.plots(request["positions"], colors.MARK)
    smoothed = as_points(result.get("smoothed_positions") or [])
    canvas.line(smoothed, colors.SOLUTION)
    sigma = ", ".join(f"{s:.3g}" for s in result["sigma"])
    canvas.text(smoothed[0] if len(smoothed) else [0.0, 0.0], f"noise sigma {sigma} m")


def study(canvas: Canvas, request: dict[str, Any], result: dict[str, Any]) -> None:
    _platforms(canvas, request["transmitter"], request["receivers"])
    samples = result["samples"]
    track = as_points([s["position"] for s in samples])
    canvas.line(track, colors.MARK)
    canvas.plots(track, colors.MARK)
    for sample in samples:
        sigma = np.asarray(sample["crlb"], dtype=float)
        canvas.ellipse(sample["position"], np.diag(sigma**2), colors.COVARIANCE)
    canvas.text(
        track[0] if len(track) else [0.0, 0.0],
        f"{result['runs']} runs, noise sigma {result['noise_sigma']:.3g} m",
    )
