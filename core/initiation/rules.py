"""The stage functions a configuration selects, once per call of initiation.

Each choice of :class:`~plotgate.core.initiation.config.InitiationConfig` that names an
option (``mode``, ``capture_gate``, ``association``, ``filter``, ``confirmation``) and
the capture window (2/N or 2/T) picks the function or rule one stage of the scan step
(:mod:`plotgate.core.initiation.logic`) calls; :func:`select_rules` picks them all, so
the step itself asks no question of the settings.

- ``mode``: the candidate search over plots (Cartesian positions, or polar (r, az)
  windows), the tracks' gates (:func:`~plotgate.core.initiation.pairs.ellipse_pairs` or
  :func:`~plotgate.core.initiation.pairs.window_pairs`), the capture gate (polar mode's
  first-association windows) and the plausibility check before confirmation (Mu et al.'s
  radial acceleration check in polar mode, none in Cartesian mode).
- ``mode`` and ``confirmation`` together: under the score, Cartesian gates also let in
  every plot inside Blackman's maximum-likelihood gate (the tracks':
  :func:`~plotgate.core.initiation.pairs.likelihood_pairs`; the initiators':
  :class:`~plotgate.core.initiation.capture.LikelyCapture`).
- ``capture_gate``, and 2/N or 2/T: :mod:`plotgate.core.initiation.capture`.
- ``association``: every captured plot starts a track (branch), or only each
  initiator's nearest.
- ``filter``: the Kalman gain or the alpha-beta smoother's.
- ``confirmation``: :mod:`plotgate.core.initiation.confirmation` (which also decides
  which initiators a scan consumes and which plots become initiators).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from plotgate.core.initiation.capture import Capture, CaptureWindow, capture_stage, capture_window
from plotgate.core.initiation.checks import acceleration_ok, every_track
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.confirmation import Confirmation, confirmation_rule
from plotgate.core.initiation.filter import alpha_beta_gain, kalman_gain
from plotgate.core.initiation.pairs import (
    Pairs,
    Prediction,
    ellipse_pairs,
    likelihood_pairs,
    nearest,
    window_coefficients,
    window_pairs,
)
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Tracks

__all__ = ["Rules", "select_rules"]

Gain = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""A filter gain (u, 4, 2) from the updated tracks' plot counts (this plot included),
their dt, predicted covariances P (u, 4, 4) and plot covariances R (u, 2, 2)."""


@dataclass(frozen=True)
class Rules:
    """The functions and rules of one configuration's scan step.

    Attributes
    ----------
    config : InitiationConfig
    index : (scan) -> PlotIndex
        The candidate search over a scan's plots.
    track_pairs : (tracks, prediction, scan, index) -> Pairs
        The plots inside each track's gate.
    capture : Capture
        The capture stage: the pairs inside the initiators' capture gates.
    window : CaptureWindow
    choose : (Pairs) -> Pairs
        Which captured pairs start tracks: all (branch) or each initiator's nearest.
    gain : Gain
    confirmation : Confirmation
    plausible : (tracks) -> (m,) bool
        Tracks that pass the mode's check before they may confirm.
    """

    config: InitiationConfig
    index: Callable[[Scan], PlotIndex]
    track_pairs: Callable[[Tracks, Prediction, Scan, PlotIndex], Pairs]
    capture: Capture
    window: CaptureWindow
    choose: Callable[[Pairs], Pairs]
    gain: Gain
    confirmation: Confirmation
    plausible: Callable[[Tracks], np.ndarray]


def _branch(pairs: Pairs) -> Pairs:
    """Branch association: every captured plot starts its own track."""
    return pairs


def _kalman(
    n: np.ndarray, dt: np.ndarray, P: np.ndarray, R: np.ndarray, config: InitiationConfig
) -> np.ndarray:
    return kalman_gain(P, R)


def _alpha_beta(
    n: np.ndarray, dt: np.ndarray, P: np.ndarray, R: np.ndarray, config: InitiationConfig
) -> np.ndarray:
    return alpha_beta_gain(n, dt, config.alpha_min, config.beta_min)


def _polar_index(scan: Scan, config: InitiationConfig) -> PlotIndex:
    return PlotIndex(scan, window_coefficients(config))


def _cartesian_index(scan: Scan) -> PlotIndex:
    return PlotIndex(scan, None)


_CARTESIAN_TRACK_GATES = {
    "k_of_m": ellipse_pairs,
    "score": likelihood_pairs,
    "existence": ellipse_pairs,
}
"""A Cartesian track's gate by confirmation rule: the chi-square ellipse, or under the
score the ellipse or the maximum-likelihood gate, whichever is wider (existence keeps the
ellipse, whose gating probability P_G its update needs)."""


def select_rules(config: InitiationConfig) -> Rules:
    """The stage functions of ``config``'s choices."""
    polar = config.mode == "polar"
    track_gate = window_pairs if polar else _CARTESIAN_TRACK_GATES[config.confirmation]
    return Rules(
        config=config,
        index=partial(_polar_index, config=config) if polar else _cartesian_index,
        track_pairs=partial(track_gate, config=config),
        capture=capture_stage(config),
        window=capture_window(config),
        choose={"branch": _branch, "nearest": nearest}[config.association],
        gain=partial({"kalman": _kalman, "alpha_beta": _alpha_beta}[config.filter], config=config),
        confirmation=confirmation_rule(config),
        plausible=partial(acceleration_ok, config=config) if polar else every_track,
    )
