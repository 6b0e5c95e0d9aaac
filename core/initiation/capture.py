"""Capture: the plots of a scan inside each initiator's capture gate.

An initiator (a single plot) may be captured by a plot of a later scan within its
window: the next capture_scans - 1 scans (criterion 2/N, :class:`ScansWindow`) or
capture_time seconds (2/T, :class:`TimeWindow`). Its capture gate is Konovalov's ring,
expanded or combined gate (Cartesian) or Mu et al.'s first-association windows (polar):
:class:`RingCapture`, :class:`ExpandedCapture`, :class:`CombinedCapture`,
:class:`FirstAssociationCapture`. Each bounds its gate for the candidate search
(the search radii only bound it; the polar windows at the scan's largest sigmas) and
then tests the candidates with the gate of :mod:`plotgate.core.gates`, once per
initiator time on all its candidate pairs (the gates take one tau).

Every function here takes a scan of at least one plot: initiation handles an empty scan
before it looks for captures.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from plotgate.core.gates.capture import CombinedGate, ExpandedGate, RingGate
from plotgate.core.gates.polar import FirstAssociationGate, bearing_turn
from plotgate.core.gates.thresholds import expansion_coefficient, gate_threshold
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.pairs import Pairs, window_coefficients
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Initiators

__all__ = [
    "CaptureGate",
    "CaptureWindow",
    "CombinedCapture",
    "DiscCapture",
    "ExpandedCapture",
    "FirstAssociationCapture",
    "RingCapture",
    "ScansWindow",
    "TimeWindow",
    "capture_gate",
    "capture_pairs",
    "capture_window",
]


class CaptureWindow(Protocol):
    """Which initiators a scan at (number k, time t) may capture, and which a later may."""

    def reaches(self, ini: Initiators, k: int, t: float) -> np.ndarray: ...

    def outlives(self, ini: Initiators, k: int, t: float) -> np.ndarray: ...


@dataclass(frozen=True)
class ScansWindow:
    """Criterion 2/N: captured by a plot of the next ``scans`` - 1 scans."""

    scans: int

    def reaches(self, ini: Initiators, k: int, t: float) -> np.ndarray:
        reached: np.ndarray = k - ini.scan <= self.scans - 1
        return reached

    def outlives(self, ini: Initiators, k: int, t: float) -> np.ndarray:
        alive: np.ndarray = (k - ini.scan) < self.scans - 1
        return alive


@dataclass(frozen=True)
class TimeWindow:
    """Criterion 2/T: captured by a plot at most ``seconds`` later."""

    seconds: float

    def reaches(self, ini: Initiators, k: int, t: float) -> np.ndarray:
        reached: np.ndarray = t - ini.t <= self.seconds
        return reached

    def outlives(self, ini: Initiators, k: int, t: float) -> np.ndarray:
        alive: np.ndarray = t - ini.t < self.seconds
        return alive


def capture_window(config: InitiationConfig) -> CaptureWindow:
    """The window the settings name: 2/T when capture_time is set, else 2/N."""
    if config.capture_time is None:
        return ScansWindow(config.capture_scans)
    return TimeWindow(config.capture_time)


class CaptureGate(Protocol):
    """A capture gate: a bound of it for the candidate search, and its exact test."""

    def candidates(
        self, ini: Initiators, tau: np.ndarray, scan: Scan, index: PlotIndex
    ) -> tuple[np.ndarray, np.ndarray]:
        """(initiator, plot) pairs possibly in the gates of initiators ``tau`` s old."""
        ...

    def inside(
        self, ini: Initiators, first: np.ndarray, scan: Scan, plot: np.ndarray, tau: float
    ) -> np.ndarray:
        """The gate's decision on pairs (ini[first], scan[plot]), all ``tau`` s apart."""
        ...


@dataclass(frozen=True)
class DiscCapture:
    """A Cartesian capture gate, searched as the disc of radius :meth:`radius` about each
    initiator (widened by a hair for rounding), which bounds the gate."""

    config: InitiationConfig

    def radius(self, ini: Initiators, tau: np.ndarray, scan: Scan) -> np.ndarray:
        raise NotImplementedError

    def candidates(
        self, ini: Initiators, tau: np.ndarray, scan: Scan, index: PlotIndex
    ) -> tuple[np.ndarray, np.ndarray]:
        return index.ball(ini.z, self.radius(ini, tau, scan) * (1 + 1e-9) + 1e-9)


@dataclass(frozen=True)
class RingCapture(DiscCapture):
    """Konovalov's ring gate, v_min tau <= |d| <= v_max tau."""

    def radius(self, ini: Initiators, tau: np.ndarray, scan: Scan) -> np.ndarray:
        R_max: np.ndarray = self.config.v_max * tau
        return R_max

    def inside(
        self, ini: Initiators, first: np.ndarray, scan: Scan, plot: np.ndarray, tau: float
    ) -> np.ndarray:
        gate = RingGate(self.config.v_min, self.config.v_max)
        return gate.test(ini.z[first], scan.z[plot], tau).inside


@dataclass(frozen=True)
class ExpandedCapture(DiscCapture):
    """Konovalov's expanded ellipse gate, on each initiator's line of sight."""

    def radius(self, ini: Initiators, tau: np.ndarray, scan: Scan) -> np.ndarray:
        K_g = float(expansion_coefficient(self.config.capture_p))
        semi_axis: np.ndarray = self.config.v_max * tau + K_g * np.maximum(
            ini.sigma_r, ini.r * ini.sigma_az
        )
        return semi_axis

    def inside(
        self, ini: Initiators, first: np.ndarray, scan: Scan, plot: np.ndarray, tau: float
    ) -> np.ndarray:
        gate = ExpandedGate(self.config.v_max, self.config.capture_p)
        return gate.test(
            ini.z[first],
            scan.z[plot],
            tau,
            ini.sigma_r[first],
            ini.sigma_az[first],
            sensor=ini.sensor[first],
        ).inside


@dataclass(frozen=True)
class CombinedCapture(DiscCapture):
    """Konovalov's two-stage combined gate: the ring, else an ellipse on its nearest circle."""

    def radius(self, ini: Initiators, tau: np.ndarray, scan: Scan) -> np.ndarray:
        gamma = gate_threshold(self.config.capture_P_G, 2)
        big = np.trace(scan.R, axis1=1, axis2=2).max()
        spread = np.sqrt(gamma * (np.trace(ini.R, axis1=1, axis2=2) + big))
        reach: np.ndarray = self.config.v_max * tau + spread
        return reach

    def inside(
        self, ini: Initiators, first: np.ndarray, scan: Scan, plot: np.ndarray, tau: float
    ) -> np.ndarray:
        c = self.config
        gate = CombinedGate(c.v_min, c.v_max, c.capture_P_G)
        return gate.test(ini.z[first], ini.R[first], scan.z[plot], scan.R[plot], tau).inside


@dataclass(frozen=True)
class FirstAssociationCapture:
    """Mu et al.'s first-association windows (polar), eq. 3-4."""

    config: InitiationConfig

    def candidates(
        self, ini: Initiators, tau: np.ndarray, scan: Scan, index: PlotIndex
    ) -> tuple[np.ndarray, np.ndarray]:
        K_R, K_az = window_coefficients(self.config)
        R_max = self.config.v_max * tau
        W_R = R_max + K_R * np.sqrt(ini.sigma_r**2 + scan.sigma_r.max() ** 2)
        W_az = bearing_turn(R_max, ini.r) + K_az * np.sqrt(
            ini.sigma_az**2 + scan.sigma_az.max() ** 2
        )
        return index.window(ini.r, ini.az, W_R, W_az)

    def inside(
        self, ini: Initiators, first: np.ndarray, scan: Scan, plot: np.ndarray, tau: float
    ) -> np.ndarray:
        K_R, K_az = window_coefficients(self.config)
        return (
            FirstAssociationGate(self.config.v_max, K_R, K_az)
            .test(
                ini.r[first],
                ini.az[first],
                scan.r[plot],
                scan.az[plot],
                tau,
                ini.sigma_r[first],
                ini.sigma_az[first],
                scan.sigma_r[plot],
                scan.sigma_az[plot],
            )
            .inside
        )


_CARTESIAN: dict[str, Callable[[InitiationConfig], CaptureGate]] = {
    "ring": RingCapture,
    "expanded": ExpandedCapture,
    "combined": CombinedCapture,
}


def capture_gate(config: InitiationConfig) -> CaptureGate:
    """The capture gate the settings name: polar mode's windows, else capture_gate's."""
    if config.mode == "polar":
        return FirstAssociationCapture(config)
    return _CARTESIAN[config.capture_gate](config)


def capture_pairs(
    ini: Initiators,
    scan: Scan,
    index: PlotIndex,
    allowed: np.ndarray,
    k: int,
    gate: CaptureGate,
    window: CaptureWindow,
) -> Pairs:
    """(initiator, plot, distance) of the allowed plots inside each initiator's gate.

    Only initiators within their window at scan number k, and from an earlier time,
    take part; ``allowed`` (n,) marks the plots that may be captured (those no confirmed
    track took).
    """
    tau = scan.t - ini.t
    waiting = np.flatnonzero((tau > 0) & window.reaches(ini, k, scan.t))
    found_row, found_plot = gate.candidates(ini.take(waiting), tau[waiting], scan, index)
    free = allowed[found_plot]
    row, plot = waiting[found_row[free]], found_plot[free]
    inside = np.zeros(row.size, dtype=bool)
    for t in np.unique(tau[row]):  # a few initiator times
        same = np.flatnonzero(tau[row] == t)
        inside[same] = gate.inside(ini, row[same], scan, plot[same], t)
    distance = np.linalg.norm(scan.z[plot[inside]] - ini.z[row[inside]], axis=1)
    return Pairs(row[inside], plot[inside], distance)
