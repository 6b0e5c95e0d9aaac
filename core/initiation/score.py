"""The sequential track score: a log-likelihood ratio, target against clutter, per track.

Blackman and Popoli, "Design and Analysis of Modern Tracking Systems" (1999), ch. 6
(the track score, its recursion and the sequential probability ratio test); Bar-Shalom,
Willett and Tian, "Tracking and Data Fusion" (2011), the log-likelihood ratio of a track.
The score L of a track is the log of

    P(its plots | one target) / P(its plots | all clutter),

with the prior of a new target folded into its first plot:

- first plot: ln(P_D beta_NT / beta_FT);
- the second plot, tau seconds later, before any velocity is known:
  ln(P_D N(z_2 - z_1; 0, S) / beta_FT), S = R_1 + R_2 + (v_max tau)^2 / 4 I + q Q_xy
  (the first plot's state with the velocity prior, zero mean and the per-axis variance
  v_max^2 / 4 of speeds uniform over the disc |v| <= v_max, predicted tau ahead:
  :func:`plotgate.core.initiation.filter.one_point`);
- each later plot: ln(P_D N(nu; 0, S) / beta_FT), nu and S the track filter's
  innovation and its covariance, S = H P^- H^T + R;
- each scan without a plot (between the first two plots too): ln(1 - P_D).

A plot raises a track's score above the miss's only inside Blackman's maximum-likelihood
gate (:func:`ml_gate`): outside it the score itself prefers "missed, and the plot is
clutter", so under score confirmation the gates let in every plot inside it (the
configured chi-square gate at P_G 0.99 would throw away 1% of a target's plots at every
gate a track passes, in scenes where the score has no use for that cut).

P_D is the detection probability, beta_FT the clutter density (false plots per m^2 per
scan) and beta_NT the new-target density (per m^2 per scan). Wald's sequential test
confirms at L >= ln((1 - beta) / alpha) and drops at L <= ln(beta / (1 - alpha)),
alpha the wanted probability of confirming a false track and beta of dropping a true
one (Blackman and Popoli, sec. 6.2).
"""

from __future__ import annotations

import math

import numpy as np

from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.sym2 import Sym2, quadratic_form, sym2

__all__ = [
    "capture_score",
    "log_clutter_density",
    "first_plot_score",
    "log_gaussian",
    "miss_score",
    "ML_GATE_CEILING",
    "ml_gate",
    "update_score",
    "wald_thresholds",
]

_LN_2PI = math.log(2.0 * math.pi)
ML_GATE_CEILING = -2.0 * math.log(1e-9)
"""The widest :func:`ml_gate`, rho <= 41.4: the 2-D chi-square gate of P_G 1 - 10^-9. A
target's plot lies beyond it once in 10^9 scans, and without a ceiling a clutter density
of 10^-300 (which the settings accept) would put every plot of a scan in every gate."""


def wald_thresholds(config: InitiationConfig) -> tuple[float, float]:
    """Wald's confirmation and deletion thresholds of the score.

    .. math:: T_c = \\ln\\frac{1 - \\beta}{\\alpha}, \\quad T_d = \\ln\\frac{\\beta}{1 - \\alpha}

    with alpha = config.false_confirmation and beta = config.true_deletion.

    >>> c, d = wald_thresholds(InitiationConfig(false_confirmation=0.01, true_deletion=0.1))
    >>> round(c, 4), round(d, 4)
    (4.4998, -2.2925)
    """
    alpha, beta = config.false_confirmation, config.true_deletion
    return math.log1p(-beta) - math.log(alpha), math.log(beta) - math.log1p(-alpha)


def log_clutter_density(config: InitiationConfig, plots: int) -> float:
    """ln beta_FT of a scan of ``plots`` plots (beta_FT per m^2): the config's, or estimated.

    Estimated as max(plots, 1) / surveillance_area: the scan's own plot count over the
    area (floored at one plot, so an empty scan does not make every plot infinitely
    unlikely to be clutter). Logarithms throughout, so no density over- or underflows
    (an area of 1e-300 m^2 is a density of 1e300, whose log is 690.8).

    >>> round(log_clutter_density(InitiationConfig(surveillance_area=1e6), 250), 6)
    -8.29405
    """
    if config.clutter_density is not None:
        return math.log(config.clutter_density)
    assert config.surveillance_area is not None  # the config refuses neither
    return math.log(max(plots, 1)) - math.log(config.surveillance_area)


def miss_score(config: InitiationConfig) -> float:
    """ln(1 - P_D): the score's change for a scan without a plot."""
    return math.log1p(-config.P_D)


def ml_gate(det_S: np.ndarray, config: InitiationConfig, log_density: float) -> np.ndarray:
    """Blackman's maximum-likelihood gate: the largest rho = nu^T S^-1 nu (2-D) at which a
    plot still scores at least a miss.

    .. math:: \\ln\\frac{P_D\\,N(\\nu; 0, S)}{\\beta_{FT}} \\ge \\ln(1 - P_D)
              \\iff \\rho \\le G_{ML} = 2\\ln\\frac{P_D}{(1 - P_D)\\,\\beta_{FT}\\,2\\pi
              \\sqrt{|S|}}

    (Blackman and Popoli, 1999, ch. 6, the maximum-likelihood gate; M = 2). It widens
    where clutter is sparse and narrows where it is dense: for the tracks of Mu et al.'s
    scenario a scan after their start (|S| about (25 m)^4, the documented score
    configuration) it is a 99.99% gate at 20 clutter plots per scan and 99.8% at 250
    and 500, wider than the 99% chi-square gate throughout. det_S is |S| (m^4, per
    pair); log_density is ln beta_FT. Negative where no plot can beat a miss; at most
    :data:`ML_GATE_CEILING`.

    >>> cfg = InitiationConfig(P_D=0.8, clutter_density=1e-6)
    >>> round(float(ml_gate(np.array([1e6]), cfg, math.log(1e-6))[0]), 4)
    12.9123
    """
    log_odds = math.log(config.P_D) - math.log1p(-config.P_D)
    gate: np.ndarray = np.minimum(
        2.0 * (log_odds - log_density - _LN_2PI) - np.log(det_S), ML_GATE_CEILING
    )
    return gate


def first_plot_score(config: InitiationConfig, log_density: float) -> float:
    """ln(P_D beta_NT / beta_FT): the score of a single plot (an initiator); log_density
    is ln beta_FT."""
    return math.log(config.P_D) + math.log(config.new_target_density) - log_density


def log_gaussian(nu_x: np.ndarray, nu_y: np.ndarray, S: Sym2) -> np.ndarray:
    """ln N(nu; 0, S) of 2-vectors nu, S positive definite (m^2).

    .. math:: -\\ln 2\\pi - \\tfrac12 \\ln|S| - \\tfrac12 \\nu^T S^{-1} \\nu

    >>> from plotgate.core.sym2 import sym2
    >>> float(log_gaussian(np.array([0.0]), np.array([0.0]), sym2(np.eye(2)[None]))[0])
    -1.8378770664093453
    """
    value: np.ndarray = -_LN_2PI - 0.5 * np.log(S.det) - 0.5 * quadratic_form(nu_x, nu_y, S)
    return value


def update_score(
    nu_x: np.ndarray, nu_y: np.ndarray, S: Sym2, config: InitiationConfig, log_density: float
) -> np.ndarray:
    """ln(P_D N(nu; 0, S) / beta_FT): the score's change for a plot with innovation nu;
    log_density is ln beta_FT."""
    change: np.ndarray = math.log(config.P_D) - log_density + log_gaussian(nu_x, nu_y, S)
    return change


def capture_score(
    nu: np.ndarray, S: np.ndarray, gaps: np.ndarray, config: InitiationConfig, log_density: float
) -> np.ndarray:
    """The change of an initiator's score when a later plot starts a track with it.

    gaps scans without a plot between the two (ln(1 - P_D) each), then
    ln(P_D N(nu; 0, S) / beta_FT), nu the second plot less the initiator's and S their
    covariances plus the velocity prior's spread over the interval
    (:func:`plotgate.core.initiation.filter.one_point`, predicted).

    Parameters
    ----------
    nu : (m, 2) ndarray
        z_2 - z_1, m.
    S : (m, 2, 2) ndarray
        Its covariance, m^2.
    gaps : (m,) ndarray of int
        Scans between the two plots.
    config : InitiationConfig
    log_density : float
        ln beta_FT of the second plot's scan (beta_FT per m^2).

    Returns
    -------
    change : (m,) ndarray
    """
    change: np.ndarray = gaps * miss_score(config) + update_score(
        nu[:, 0], nu[:, 1], sym2(S), config, log_density
    )
    return change
