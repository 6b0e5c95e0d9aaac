"""Plots and platforms of recorded JSON as positions in the radar frame.

The records are read as recorded (plain JSON values, not the pydantic models): a recording
may come from another build, and a picture of what it holds is worth more than a refusal.
A value of an unexpected shape raises ``KeyError``, ``TypeError``, ``IndexError`` or
``ValueError``, which the scene builder turns into a Log message.
"""

import math
from typing import Any

import numpy as np

__all__ = ["mark_position", "plot_position", "plot_positions", "position_of"]


def plot_position(plot: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """A plot's (x, y) and its 2x2 covariance: a Cartesian plot as it is, a polar one
    converted about its sensor with DESIGN section 2's Jacobian."""
    if plot.get("frame") == "cartesian":
        return np.array([plot["x"], plot["y"]], dtype=float), np.asarray(
            plot["covariance"], dtype=float
        )
    return mark_position(plot)


def mark_position(mark: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """A polar mark (``r``, ``az_deg``, ``sigma_r``, ``sigma_az_deg``, optional
    ``sensor``): its (x, y) and covariance ``J diag(sr^2, saz^2) J^T``."""
    r, az = float(mark["r"]), math.radians(float(mark["az_deg"]))
    sensor = np.asarray(mark.get("sensor") or (0.0, 0.0), dtype=float)[:2]
    s, c = math.sin(az), math.cos(az)
    jacobian = np.array([[s, r * c], [c, -r * s]])
    errors = np.diag([float(mark["sigma_r"]) ** 2, math.radians(float(mark["sigma_az_deg"])) ** 2])
    return sensor + r * np.array([s, c]), jacobian @ errors @ jacobian.T


def plot_positions(plots: list[dict[str, Any]]) -> np.ndarray:
    """The (N, 2) positions of plots (covariances not needed), in plain floats: a small
    numpy array per plot cost more than the rest of a gate test's picture."""
    if not plots:
        return np.zeros((0, 2))
    return np.array(
        [
            (float(p["x"]), float(p["y"])) if p.get("frame") == "cartesian" else _polar_xy(p)
            for p in plots
        ],
        dtype=float,
    )


def _polar_xy(plot: dict[str, Any]) -> tuple[float, float]:
    r, az = float(plot["r"]), math.radians(float(plot["az_deg"]))
    x0, y0 = plot.get("sensor") or (0.0, 0.0)
    return float(x0) + r * math.sin(az), float(y0) + r * math.cos(az)


def position_of(platform: Any) -> list[float]:
    """A platform's position: ``[x, y(, z)]`` or ``{"position": [...], ...}``."""
    if isinstance(platform, dict):
        return list(platform["position"])
    return list(platform)
