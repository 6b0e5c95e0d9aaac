"""Confirmation rules: k plots within m scans, or the track score against Wald's thresholds.

The rule the settings name (``confirmation``) decides, for initiation's scan step
(:mod:`plotgate.core.initiation.logic`): the state a captured pair starts a track with,
how an association changes a track's score, which tentative tracks are ready to confirm,
which of the ready tracks win a clash, which tentative tracks lapse, which initiators a
scan consumes, which of its plots become initiators, and the score of a new initiator.

- :class:`KOfM` (the secondary-processing textbook; Mu et al.'s 3/4): the two-point
  state, no score, ready with k plots within the first m scans, the smaller mean gate
  statistic first, lapsed (``"window"``) once k is out of reach within m.
- :class:`ScoreRule` (Blackman and Popoli, ch. 6; :mod:`plotgate.core.initiation.score`):
  the first plot with the velocity prior updated with the second, the sequential
  log-likelihood ratio, ready at ln((1 - beta) / alpha) with at least k plots, the
  higher score first, lapsed (``"score"``) at ln(beta / (1 - alpha)).
- :class:`ExistenceRule` (IPDA, Mušicki, Evans and Stanković 1994;
  :mod:`plotgate.core.initiation.existence`): the score rule's start and initiators, the
  score the log-odds of existence, updated each scan from every plot in a tentative
  track's gate; ready at existence tau_c, lapsed (``"existence"``) at tau_d.

The initiators: under k/m (the textbook's) a capture consumes its initiator and every
plot a track took or started is spent. Under the score, every plot no confirmed track
holds becomes an initiator, and an initiator lives out its window, captured or not,
until a confirmed track holds its plot (issue 28): a plot a clutter initiator captured
or a tentative track took may still be the first of its own target's track (a target
seen in scans 2, 3 and 4 whose scan-2 plot a clutter plot of scan 1 captured), and an
initiator whose capture took a clutter plot may still capture its target's plot a scan
later; tracks sharing plots are resolved by their scores at confirmation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.existence import Gated, ipda, log_odds
from plotgate.core.initiation.filter import kalman_gain, one_point, predict, two_point, update
from plotgate.core.initiation.pairs import Pairs, Prediction
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.score import (
    capture_score,
    first_plot_score,
    log_clutter_density,
    miss_score,
    update_score,
    wald_thresholds,
)
from plotgate.core.initiation.state import Initiators, Tracks
from plotgate.core.sym2 import sym2

__all__ = ["Confirmation", "ExistenceRule", "KOfM", "ScoreRule", "confirmation_rule"]


class Confirmation(Protocol):
    """What a confirmation rule decides in a scan (k is the scan's number)."""

    def start(
        self, ini: Initiators, captured: Pairs, scan: Scan, k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """State x (c, 4), covariance P (c, 4, 4) and score (c,) of the captured pairs'
        new tracks."""
        ...

    def rescore(
        self, tracks: Tracks, prediction: Prediction, plot: np.ndarray, scan: Scan
    ) -> np.ndarray:
        """The tracks' scores after the scan; plot (m,) is each one's plot, -1 for none."""
        ...

    def ready(self, tracks: Tracks, k: int) -> np.ndarray:
        """Tentative tracks that may confirm in this scan."""
        ...

    def merit(self, tracks: Tracks, rows: np.ndarray) -> np.ndarray:
        """Key of the tracks at ``rows``: the smaller, the better (wins a clash)."""
        ...

    def lapsed(self, tracks: Tracks, k: int) -> tuple[str, np.ndarray]:
        """The rule's drop reason, and the tentative tracks it drops."""
        ...

    @property
    def holders(self) -> str:
        """Which tracks' plots no initiator may be: "track" or "confirmed track"."""
        ...

    def held(self, tracks: Tracks) -> np.ndarray:
        """The plot ids (-1 where a history has none yet) no initiator may be."""
        ...

    def consumed(self, ini: Initiators, captured: Pairs, tracks: Tracks) -> np.ndarray:
        """Initiators (i,) the scan ends before their window does; ``tracks`` are the
        scan's tracks after confirmation, before any is dropped."""
        ...

    def seeds(self, ids: np.ndarray, owners: np.ndarray, tracks: Tracks) -> np.ndarray:
        """Plots (n,) of the scan, ids ``ids``, that become initiators; ``owners`` is
        each plot's track (updated or started, -1 for none), ``tracks`` as in
        :meth:`consumed`."""
        ...

    def initiator_score(self, plots: int) -> float:
        """Score of a new initiator in a scan of ``plots`` plots."""
        ...

    def mixed(self, tracks: Tracks, prediction: Prediction, gated: Gated) -> Tracks:
        """The tracks after the scan's association, their tentative ones re-weighted from
        every plot in their gates (existence); the others' rules keep them as they are."""
        ...


def _age(tracks: Tracks, k: int) -> np.ndarray:
    """Scans since each track's first plot, scan k included."""
    age: np.ndarray = k - tracks.first_scan + 1
    return age


@dataclass(frozen=True)
class KOfM:
    """Confirmation k/m: confirm_k plots within the first confirm_m scans."""

    config: InitiationConfig

    @property
    def holders(self) -> str:
        return "track"

    def held(self, tracks: Tracks) -> np.ndarray:
        """Every track's plots: a plot a track took or started is spent."""
        return tracks.plots

    def start(
        self, ini: Initiators, captured: Pairs, scan: Scan, k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        first, plot = captured.row, captured.plot
        tau = scan.t - ini.t[first]
        x, P = two_point(ini.z[first], ini.R[first], scan.z[plot], scan.R[plot], tau)
        return x, P, np.zeros(first.size)

    def rescore(
        self, tracks: Tracks, prediction: Prediction, plot: np.ndarray, scan: Scan
    ) -> np.ndarray:
        return tracks.score

    def ready(self, tracks: Tracks, k: int) -> np.ndarray:
        c = self.config
        ready: np.ndarray = (
            ~tracks.confirmed & (tracks.n >= c.confirm_k) & (_age(tracks, k) <= c.confirm_m)
        )
        return ready

    def merit(self, tracks: Tracks, rows: np.ndarray) -> np.ndarray:
        mean_statistic: np.ndarray = tracks.cost[rows] / (tracks.n[rows] - 1)
        return mean_statistic

    def lapsed(self, tracks: Tracks, k: int) -> tuple[str, np.ndarray]:
        c = self.config
        reachable = tracks.n + (c.confirm_m - _age(tracks, k)) >= c.confirm_k
        return "window", ~tracks.confirmed & ~reachable

    def consumed(self, ini: Initiators, captured: Pairs, tracks: Tracks) -> np.ndarray:
        """A captured initiator is spent."""
        spent = np.zeros(ini.size, dtype=bool)
        spent[captured.row] = True
        return spent

    def seeds(self, ids: np.ndarray, owners: np.ndarray, tracks: Tracks) -> np.ndarray:
        """The plots no track took or started."""
        unused: np.ndarray = owners < 0
        return unused

    def initiator_score(self, plots: int) -> float:
        return 0.0

    def mixed(self, tracks: Tracks, prediction: Prediction, gated: Gated) -> Tracks:
        return tracks


@dataclass(frozen=True)
class ScoreRule:
    """Score confirmation: the sequential track score against Wald's thresholds."""

    config: InitiationConfig

    @property
    def holders(self) -> str:
        return "confirmed track"

    def held(self, tracks: Tracks) -> np.ndarray:
        """The confirmed tracks' plots: only a confirmed track owns its plots."""
        confirmed: np.ndarray = tracks.plots[tracks.confirmed]
        return confirmed

    def start(
        self, ini: Initiators, captured: Pairs, scan: Scan, k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The speed bound as a prior on the first plot, updated with the second."""
        c, first, plot = self.config, captured.row, captured.plot
        x1, P1 = one_point(ini.z[first], ini.R[first], c.v_max)
        x2, P2 = predict(x1, P1, scan.t - ini.t[first], c.q)
        R2 = scan.R[plot]
        innovation = scan.z[plot] - x2[:, :2]
        x, P = update(x2, P2, scan.z[plot], R2, kalman_gain(P2, R2))
        gaps = k - ini.scan[first] - 1
        density = log_clutter_density(c, scan.size)
        gained = capture_score(innovation, P2[:, :2, :2] + R2, gaps, c, density)
        return x, P, ini.score[first] + gained

    def rescore(
        self, tracks: Tracks, prediction: Prediction, plot: np.ndarray, scan: Scan
    ) -> np.ndarray:
        hit = plot >= 0
        score = tracks.score + np.where(hit, 0.0, miss_score(self.config))
        if hit.any():
            taken = plot[hit]
            nu = scan.z[taken] - prediction.x[hit, :2]
            S = sym2(prediction.P[hit, :2, :2] + scan.R[taken])
            density = log_clutter_density(self.config, scan.size)
            score[hit] += update_score(nu[:, 0], nu[:, 1], S, self.config, density)
        return score

    def ready(self, tracks: Tracks, k: int) -> np.ndarray:
        confirm_at, _ = wald_thresholds(self.config)
        ready: np.ndarray = (
            ~tracks.confirmed & (tracks.score >= confirm_at) & (tracks.n >= self.config.confirm_k)
        )
        return ready

    def merit(self, tracks: Tracks, rows: np.ndarray) -> np.ndarray:
        higher_first: np.ndarray = -tracks.score[rows]
        return higher_first

    def lapsed(self, tracks: Tracks, k: int) -> tuple[str, np.ndarray]:
        _, delete_at = wald_thresholds(self.config)
        return "score", ~tracks.confirmed & (tracks.score <= delete_at)

    def consumed(self, ini: Initiators, captured: Pairs, tracks: Tracks) -> np.ndarray:
        """Only a confirmed track's plot ends its initiator: the score decides."""
        spent: np.ndarray = np.isin(ini.plot, self.held(tracks))
        return spent

    def seeds(self, ids: np.ndarray, owners: np.ndarray, tracks: Tracks) -> np.ndarray:
        """Every plot no confirmed track holds."""
        free: np.ndarray = ~np.isin(ids, self.held(tracks))
        return free

    def initiator_score(self, plots: int) -> float:
        return first_plot_score(self.config, log_clutter_density(self.config, plots))

    def mixed(self, tracks: Tracks, prediction: Prediction, gated: Gated) -> Tracks:
        return tracks


@dataclass(frozen=True)
class ExistenceRule(ScoreRule):
    """Existence confirmation (IPDA, :mod:`plotgate.core.initiation.existence`): the score
    rule's initiators and captures, the score holding the log-odds of existence; each
    scan a tentative track's existence and state come from every plot in its gate;
    ready at existence >= tau_c with at least confirm_k plots, the likelier first,
    lapsed (``"existence"``) at existence <= tau_d."""

    def rescore(
        self, tracks: Tracks, prediction: Prediction, plot: np.ndarray, scan: Scan
    ) -> np.ndarray:
        """Unchanged here: :meth:`mixed` updates existence from all the gate's plots."""
        return tracks.score

    def mixed(self, tracks: Tracks, prediction: Prediction, gated: Gated) -> Tracks:
        return ipda(tracks, prediction, gated, self.config)

    def ready(self, tracks: Tracks, k: int) -> np.ndarray:
        confirm_at = log_odds(self.config.existence_confirm)
        ready: np.ndarray = (
            ~tracks.confirmed & (tracks.score >= confirm_at) & (tracks.n >= self.config.confirm_k)
        )
        return ready

    def lapsed(self, tracks: Tracks, k: int) -> tuple[str, np.ndarray]:
        delete_at = log_odds(self.config.existence_delete)
        return "existence", ~tracks.confirmed & (tracks.score <= delete_at)


def confirmation_rule(config: InitiationConfig) -> Confirmation:
    """The rule the settings name."""
    rules: dict[str, Callable[[InitiationConfig], Confirmation]] = {
        "k_of_m": KOfM,
        "score": ScoreRule,
        "existence": ExistenceRule,
    }
    return rules[config.confirmation](config)
