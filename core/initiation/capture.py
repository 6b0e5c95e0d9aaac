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

The capture stage (:class:`GateCapture`) takes the pairs inside the configured gate;
under score confirmation in Cartesian mode (:class:`LikelyCapture`) also every pair
inside Blackman's maximum-likelihood gate of the capture score
(:func:`likely_captures`), where the score has a use for the plot that the configured
gate at its fixed gating probability would throw away.

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
from plotgate.core.gates.tracking import EllipseGate
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.filter import one_point, predict
from plotgate.core.initiation.pairs import Pairs, likelihood_gate_bound, window_coefficients
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.score import log_clutter_density, ml_gate
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Initiators
from plotgate.core.sym2 import sym2

__all__ = [
    "Capture",
    "CaptureGate",
    "CaptureWindow",
    "CombinedCapture",
    "DiscCapture",
    "ExpandedCapture",
    "FirstAssociationCapture",
    "GateCapture",
    "LikelyCapture",
    "RingCapture",
    "ScansWindow",
    "TimeWindow",
    "capture_gate",
    "capture_pairs",
    "capture_stage",
    "capture_window",
    "likely_captures",
    "waiting",
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


def waiting(ini: Initiators, scan: Scan, k: int, window: CaptureWindow) -> np.ndarray:
    """Indices of the initiators scan number k may capture: within their window, and
    from an earlier time."""
    tau = scan.t - ini.t
    return np.flatnonzero((tau > 0) & window.reaches(ini, k, scan.t))


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

    Only the :func:`waiting` initiators take part; ``allowed`` (n,) marks the plots that
    may be captured (those no confirmed track took).
    """
    tau = scan.t - ini.t
    later = waiting(ini, scan, k, window)
    found_row, found_plot = gate.candidates(ini.take(later), tau[later], scan, index)
    free = allowed[found_plot]
    row, plot = later[found_row[free]], found_plot[free]
    inside = np.zeros(row.size, dtype=bool)
    for t in np.unique(tau[row]):  # a few initiator times
        same = np.flatnonzero(tau[row] == t)
        inside[same] = gate.inside(ini, row[same], scan, plot[same], t)
    distance = np.linalg.norm(scan.z[plot[inside]] - ini.z[row[inside]], axis=1)
    return Pairs(row[inside], plot[inside], distance)


def likely_captures(
    ini: Initiators,
    scan: Scan,
    index: PlotIndex,
    config: InitiationConfig,
    allowed: np.ndarray,
    later: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(initiator, plot) pairs, initiators among ``later``, allowed plots, inside the
    maximum-likelihood gate of the capture score.

    The pair's S is the capture score's (:func:`plotgate.core.initiation.score.capture_score`):
    the initiator's one-point state with its velocity prior
    (:func:`~plotgate.core.initiation.filter.one_point`), predicted to the scan, plus the
    plot's R. A target's pair lies inside with the probability of the gate, which grows
    as clutter thins: the configured capture gate alone (the combined gate's ellipse at
    capture_P_G 0.99) loses about 1% of them per capture.
    """
    x1, P1 = one_point(ini.z[later], ini.R[later], config.v_max)
    xp, Pp = predict(x1, P1, scan.t - ini.t[later], config.q)
    P_xy = Pp[:, :2, :2]
    bound = likelihood_gate_bound(P_xy, scan, config)
    r_max = np.trace(scan.R, axis1=1, axis2=2).max(initial=0.0)
    radius = np.sqrt(np.fmax(bound, 0.0) * (np.trace(P_xy, axis1=1, axis2=2) + r_max))
    rows, cols = index.ball(xp[:, :2], radius)
    keep = allowed[cols]
    rows, cols = rows[keep], cols[keep]
    nu = scan.z[cols] - xp[rows, :2]
    S = sym2(P_xy[rows] + scan.R[cols])
    density = log_clutter_density(config, scan.size)
    inside = EllipseGate.statistic(nu[:, 0], nu[:, 1], S) <= ml_gate(S.det, config, density)
    return later[rows[inside]], cols[inside]


Capture = Callable[[Initiators, Scan, PlotIndex, np.ndarray, int], Pairs]
"""The capture stage: (initiators, scan, index, allowed plots, scan number k) -> the
(initiator, plot, distance) pairs captured, before the association's choice."""


@dataclass(frozen=True)
class GateCapture:
    """The pairs inside the configured capture gate (:func:`capture_pairs`)."""

    gate: CaptureGate
    window: CaptureWindow

    def __call__(
        self, ini: Initiators, scan: Scan, index: PlotIndex, allowed: np.ndarray, k: int
    ) -> Pairs:
        return capture_pairs(ini, scan, index, allowed, k, self.gate, self.window)


@dataclass(frozen=True)
class LikelyCapture:
    """Score confirmation, Cartesian: the pairs inside the configured capture gate or
    the capture score's maximum-likelihood gate (:func:`likely_captures`), ordered by
    initiator, then plot."""

    config: InitiationConfig
    gate: CaptureGate
    window: CaptureWindow

    def __call__(
        self, ini: Initiators, scan: Scan, index: PlotIndex, allowed: np.ndarray, k: int
    ) -> Pairs:
        gated = capture_pairs(ini, scan, index, allowed, k, self.gate, self.window)
        later = waiting(ini, scan, k, self.window)
        likely_row, likely_plot = likely_captures(ini, scan, index, self.config, allowed, later)
        n = scan.size
        key = np.unique(
            np.concatenate([gated.row, likely_row]) * n + np.r_[gated.plot, likely_plot]
        )
        row, plot = key // n, key % n
        return Pairs(row, plot, np.linalg.norm(scan.z[plot] - ini.z[row], axis=1))


def capture_stage(config: InitiationConfig) -> Capture:
    """The capture stage the settings name: the capture gate's pairs, widened by the
    maximum-likelihood gate under score or existence confirmation in Cartesian mode (polar mode's
    windows keep the paper's first association)."""
    gate, window = capture_gate(config), capture_window(config)
    if config.mode == "cartesian" and config.confirmation in ("score", "existence"):
        return LikelyCapture(config, gate, window)
    return GateCapture(gate, window)
