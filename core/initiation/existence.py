"""Track existence: integrated probabilistic data association (IPDA) for tentative tracks.

Mušicki, Evans and Stanković, "Integrated probabilistic data association", IEEE TAC 39(6),
1994 (eq. 9-16); the state as the PDA mixture of Bar-Shalom and Tse (1975). Every
tentative track carries its probability of existence P, held as the log-odds
ln(P / (1 - P)) in the track's ``score`` (so neither end of (0, 1) rounds away).

Each scan, for every tentative track:

- the Markov chain carries existence across the scan:
  P(k|k-1) = p11 P(k-1|k-1) + p21 (1 - P(k-1|k-1));
- every plot i in its gate (chi-square ellipse rho <= gamma, of gating probability
  P_G = 1 - exp(-gamma / 2) in 2-D) weighs in by its likelihood ratio
  L_i = N(z_i; z_hat, S_i) / lambda, lambda the clutter density (plots per m^2 per scan);
- delta = P_D P_G - P_D sum_i L_i and
  P(k|k) = (1 - delta) P(k|k-1) / (1 - delta P(k|k-1)), i.e. the odds of existence
  multiply by 1 - delta (eq. 16);
- the state is the mixture of "no plot is the target's" (weight
  beta_0 = (1 - P_D P_G) / (1 - delta), the prediction) and "plot i is" (weight
  beta_i = P_D L_i / (1 - delta), the Kalman update with plot i), reduced to its mean and
  covariance. With one R for all plots this is Bar-Shalom and Tse's PDA update; with a
  covariance per plot each hypothesis keeps its own gain.

The capture of a plot by an initiator is a branch (one tentative track per plausible
plot), scored as the score rule does: the initiator's odds P_D beta_NT / beta_FT times
P_D N / lambda of the captured plot. The clutter density is the configuration's, or
estimated per scan as (plots no confirmed track took) / surveillance_area, floored at one
plot: targets' plots not yet held by a confirmed track count as clutter, so where targets
are dense the estimate is high by their number and existence rises more slowly (a
conservative bias; at 4 targets among 250 clutter plots, 1.6%).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.filter import kalman_gain, update
from plotgate.core.initiation.pairs import Pairs, Prediction, widening
from plotgate.core.initiation.score import log_clutter_density, log_gaussian
from plotgate.core.initiation.state import Tracks
from plotgate.core.sym2 import sym2

__all__ = [
    "Gated",
    "existence",
    "existence_update",
    "gating_probability",
    "ipda",
    "log_odds",
    "markov",
    "mixture",
    "mixture_reference",
]


def log_odds(p: float) -> float:
    """ln(p / (1 - p)).

    >>> round(log_odds(0.99), 6)
    4.59512
    """
    return math.log(p) - math.log1p(-p)


def existence(score: np.ndarray) -> np.ndarray:
    """Probability of existence from the log-odds a track holds: 1 / (1 + exp(-score)).

    >>> existence(np.array([0.0, math.log(99.0)])).round(6).tolist()
    [0.5, 0.99]
    """
    p: np.ndarray = 0.5 * (1.0 + np.tanh(0.5 * np.asarray(score, dtype=float)))
    return p


def markov(score: np.ndarray, p11: float, p21: float) -> np.ndarray:
    """The log-odds of existence carried across one scan by the Markov chain
    P(k|k-1) = p11 P + p21 (1 - P) (Mušicki et al. 1994, eq. 9), computed from
    P and 1 - P each without cancellation.

    >>> math.isclose(markov(np.array([0.0]), 0.98, 0.0)[0], math.log(0.98 / 1.02), rel_tol=1e-12)
    True
    """
    s = np.asarray(score, dtype=float)
    p, q = existence(s), existence(-s)
    alive = p11 * p + p21 * q
    gone = (1.0 - p11) * p + (1.0 - p21) * q
    with np.errstate(divide="ignore"):
        out: np.ndarray = np.log(alive) - np.log(gone)
    return out


def gating_probability(gate_P_G: float, widen: np.ndarray) -> np.ndarray:
    """P_G of each track's chi-square gate (2-D): 1 - exp(-gamma / 2), gamma the gate
    threshold -2 ln(1 - gate_P_G) times the track's widening after misses."""
    gamma = -2.0 * math.log1p(-gate_P_G) * widen
    p: np.ndarray = -np.expm1(-0.5 * gamma)
    return p


def existence_update(
    prior: np.ndarray,
    P_G: np.ndarray,
    P_D: float,
    row: np.ndarray,
    log_ratio: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The IPDA existence update and the PDA weights (Mušicki et al. 1994, eq. 12-16).

    Parameters
    ----------
    prior : (m,) ndarray
        Log-odds of existence after the Markov chain, ln(P(k|k-1) / (1 - P(k|k-1))).
    P_G : (m,) ndarray
        Gating probability of each track's gate.
    P_D : float
        Detection probability.
    row, log_ratio : (E,) ndarray
        The track of each plot in a gate, and ln L_i = ln N(z_i; z_hat, S_i) - ln lambda.

    Returns
    -------
    posterior : (m,) ndarray
        Log-odds of P(k|k) = (1 - delta) P(k|k-1) / (1 - delta P(k|k-1)),
        delta = P_D P_G - P_D sum_i L_i: the prior plus ln(1 - delta).
    beta_0 : (m,) ndarray
        Weight of "no plot in the gate is the target's": (1 - P_D P_G) / (1 - delta).
    beta : (E,) ndarray
        Weight of each plot: P_D L_i / (1 - delta).

    No plot in a gate: ln(1 - delta) = ln(1 - P_D P_G), beta_0 = 1.
    """
    m = prior.shape[0]
    top = np.full(m, -np.inf)
    np.maximum.at(top, row, log_ratio)
    shift = np.where(np.isfinite(top), top, 0.0)
    total = np.bincount(row, np.exp(log_ratio - shift[row]), minlength=m)
    with np.errstate(divide="ignore"):
        log_sum = np.log(total) + shift  # ln sum_i L_i, -inf for an empty gate
    log_miss = np.log1p(-P_D * P_G)
    log_gain = np.logaddexp(log_miss, math.log(P_D) + log_sum)
    beta_0 = np.exp(log_miss - log_gain)
    beta = np.exp(math.log(P_D) + log_ratio - log_gain[row])
    return prior + log_gain, beta_0, beta


def mixture_reference(
    x0: np.ndarray,
    P0: np.ndarray,
    beta_0: np.ndarray,
    row: np.ndarray,
    xi: np.ndarray,
    Pi: np.ndarray,
    beta: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The mean and covariance of each track's mixture (moment matching, a direct sum
    per track): beta_0 N(x0, P0) + sum_i beta_i N(x_i, P_i) over the track's pairs.

    x0 (m, 4), P0 (m, 4, 4), beta_0 (m,); row, beta (E,), xi (E, 4), Pi (E, 4, 4). The
    weights of a track sum to 1."""
    x = beta_0[:, None] * x0
    for e in range(row.size):
        x[row[e]] += beta[e] * xi[e]
    d0 = x0 - x
    P = beta_0[:, None, None] * (P0 + d0[:, :, None] * d0[:, None, :])
    for e in range(row.size):
        d = xi[e] - x[row[e]]
        P[row[e]] += beta[e] * (Pi[e] + np.outer(d, d))
    return x, P


def mixture(
    x0: np.ndarray,
    P0: np.ndarray,
    beta_0: np.ndarray,
    row: np.ndarray,
    xi: np.ndarray,
    Pi: np.ndarray,
    beta: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mixture_reference` vectorized over the pairs (sums by track with
    ``np.add.at``): the PDA state (Bar-Shalom and Tse 1975)."""
    x = beta_0[:, None] * x0
    np.add.at(x, row, beta[:, None] * xi)
    d0 = x0 - x
    P = beta_0[:, None, None] * (P0 + d0[:, :, None] * d0[:, None, :])
    d = xi - x[row]
    np.add.at(P, row, beta[:, None, None] * (Pi + d[:, :, None] * d[:, None, :]))
    return x, P


class Gated(NamedTuple):
    """What the existence update of the tentative tracks takes from the scan step: the
    tentative tracks' gated plots (those no confirmed track took), the scan's plots z
    (n, 2) and R (n, 2, 2), each track's misses in a row before the scan (its gate's
    widening) and the scan's plots no confirmed track took (the clutter estimate's
    count)."""

    pairs: Pairs
    z: np.ndarray
    R: np.ndarray
    misses: np.ndarray
    clutter: int


def ipda(tracks: Tracks, prediction: Prediction, gated: Gated, config: InitiationConfig) -> Tracks:
    """Every tentative track of ``tracks`` (moved on by the scan's nearest-plot
    association, which keeps its plot history and counts) given the IPDA existence and
    the PDA state from all the plots in its gate; confirmed tracks are unchanged."""
    tentative = ~tracks.confirmed
    keep = tentative[gated.pairs.row]
    row, plot = gated.pairs.row[keep], gated.pairs.plot[keep]
    x_pred, P_pred, R = prediction.x[row], prediction.P[row], gated.R[plot]
    nu = gated.z[plot] - x_pred[:, :2]
    S = sym2(P_pred[:, :2, :2] + R)
    log_ratio = log_gaussian(nu[:, 0], nu[:, 1], S) - log_clutter_density(config, gated.clutter)
    prior = markov(tracks.score, config.survival, config.existence_birth)
    P_G = gating_probability(config.gate_P_G, widening(gated.misses, config))
    posterior, beta_0, beta = existence_update(prior, P_G, config.P_D, row, log_ratio)
    xi, Pi = update(x_pred, P_pred, gated.z[plot], R, kalman_gain(P_pred, R))
    x, P = mixture(prediction.x, prediction.P, beta_0, row, xi, Pi, beta)
    return replace(
        tracks,
        x=np.where(tentative[:, None], x, tracks.x),
        P=np.where(tentative[:, None, None], P, tracks.P),
        score=np.where(tentative, posterior, tracks.score),
    )
