"""Whole pictures and sequential identification with the Z-test of Kvasnov.

* :func:`identify_picture`: P passive and A active tracks at once. The Z matrix
  Z[i, j] = wrap(mean_act_j - mean_pas_i) sqrt(m_j) / sigma_i comes from per-track
  circular means (sums of sines and cosines over each track's valid samples, laid end
  to end, so tracks may have different sample counts at a memory linear in the samples);
  the pairs with |Z| <= z_{1-alpha/2} may be identified, and
  ``scipy.optimize.linear_sum_assignment`` on |Z| picks a one-to-one identification
  among them (each passive track to at most one active track). The rest are unassigned
  on both sides.
* :func:`sequential`: the test repeated as active samples accumulate (Kvasnov's third
  condition: identification repeats every 2-20 s). Stateless: the samples in, the
  decision after each new active sample out, from cumulative sums.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike
from scipy import stats
from scipy.optimize import linear_sum_assignment

from plotgate.core.errors import ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.identification.ztest import MIN_ESTIMATED_SIGMA, bearing_sigma
from plotgate.core.validation import as_array, as_probability

__all__ = ["Picture", "Sequence", "identify_picture", "sequential"]


def _tracks(
    name: str, value: ArrayLike | list[ArrayLike]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every track's valid angles end to end (NaN pads of a (T, K) array dropped), the
    track of each angle, and the (T,) count of each track's angles.

    Memory is linear in the samples: a ragged picture (one track of 100,000 samples among
    thousands of two) is never padded to its longest track.
    """
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        tracks = cast(Iterable[ArrayLike], value)  # ragged: a list of tracks
        rows = [np.asarray(as_array(f"{name}[{i}]", r), float) for i, r in enumerate(tracks)]
        shape: tuple[int, ...] = (len(rows),)
    else:
        rows, shape = list(a) if a.ndim == 2 else [], a.shape
    if not rows or any(r.ndim != 1 for r in rows):
        raise ParameterError(
            name, f"must be a list of tracks, each a list of angles; got shape {shape}"
        )
    angles = np.concatenate(rows)
    track = np.repeat(np.arange(len(rows)), [r.size for r in rows])
    valid = ~np.isnan(angles)
    bad = ~np.isfinite(angles) & valid
    if bad.any():
        raise ParameterError(name, "must be finite angles", int(track[np.argmax(bad)]))
    angles, track = angles[valid], track[valid]
    count = np.bincount(track, minlength=len(rows))
    if (count < 2).any():
        i = int(np.argmax(count < 2))
        raise ParameterError(name, f"track {i} has {count[i]} samples; at least 2 are needed", i)
    return angles, track, count


def _means(angles: np.ndarray, track: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Circular mean of each track's angles."""
    n = count.size
    means: np.ndarray = np.arctan2(
        np.bincount(track, np.sin(angles), n), np.bincount(track, np.cos(angles), n)
    )
    return means


@dataclass(frozen=True)
class Picture:
    """Identification of P passive with A active tracks.

    Attributes
    ----------
    z, p_value : (P, A) ndarray
        Z of every pair and its two-sided p-value.
    critical : float
        z_{1 - alpha/2}.
    passes : (P, A) ndarray of bool
        |Z| <= critical.
    pairs : (K, 2) ndarray of int
        The one-to-one identification (passive index, active index), by minimum total |Z|
        among passing pairs.
    unassigned_passive, unassigned_active : ndarray of int
        Tracks left without a partner.
    sigma : (P,) ndarray
        Bearing sigma of each passive track (given or estimated), rad.
    """

    z: np.ndarray
    p_value: np.ndarray
    critical: float
    passes: np.ndarray
    pairs: np.ndarray
    unassigned_passive: np.ndarray
    unassigned_active: np.ndarray
    sigma: np.ndarray


def identify_picture(
    passive: ArrayLike, active: ArrayLike, sigma: ArrayLike | None = None, alpha: float = 0.05
) -> Picture:
    """Z matrix and one-to-one identification of many passive and active tracks (Kvasnov).

    Parameters
    ----------
    passive : (P, n) array_like or list of P lists
        Bearings of each passive track, rad (NaN or ragged lists for shorter tracks; at
        least 2 each).
    active : (A, m) array_like or list of A lists
        Bearings of each active track, rad (at least 2 each).
    sigma : float or (P,) array_like, optional
        Bearing sigma of the passive tracks, rad; default estimated per track.
    alpha : float, optional
        Level of each pair's test. Default 0.05.

    Returns
    -------
    picture : Picture

    Examples
    --------
    Passive tracks at 10 and 20 degrees, active tracks of the same objects in the other
    order, and a third active track at 15 degrees that matches neither:

    >>> rng = np.random.default_rng(1)
    >>> p = np.radians([10.0, 20.0])[:, None] + np.radians(0.2) * rng.standard_normal((2, 50))
    >>> a = np.radians([20.0, 10.0, 15.0])[:, None] + np.radians(0.2) * rng.standard_normal(
    ...     (3, 5))
    >>> pic = identify_picture(p, a, sigma=np.radians(0.2))
    >>> pic.pairs.tolist(), pic.unassigned_active.tolist()
    ([[0, 1], [1, 0]], [2])
    """
    alpha = float(as_probability("alpha", alpha))
    pa, pt, pn = _tracks("passive", passive)
    aa, at, an = _tracks("active", active)
    mean_p, mean_a = _means(pa, pt, pn), _means(aa, at, an)
    if sigma is None:
        dev = wrap_finite(pa - mean_p[pt])
        s = np.sqrt(np.bincount(pt, dev * dev, pn.size) / (pn - 1))
        if not (s >= MIN_ESTIMATED_SIGMA).all():
            raise ParameterError(
                "sigma",
                "cannot be estimated: a passive track's angles are all equal (to rounding)",
                int(np.argmax(~(s >= MIN_ESTIMATED_SIGMA))),
            )
    else:
        s = np.broadcast_to(as_array("sigma", sigma), mean_p.shape).astype(float)
        if not (s > 0).all():
            raise ParameterError("sigma", "must be positive angles")
    z = wrap_finite(mean_a[None, :] - mean_p[:, None]) * np.sqrt(an)[None, :] / s[:, None]
    crit = float(stats.norm.ppf(1.0 - alpha / 2.0))
    passes = np.abs(z) <= crit
    cost = np.where(passes, np.abs(z), 2.0 * crit * (1 + min(z.shape)) + 1.0)
    rows, cols = linear_sum_assignment(cost)
    keep = passes[rows, cols]
    pairs = np.column_stack([rows[keep], cols[keep]])
    return Picture(
        z=z,
        p_value=2.0 * stats.norm.sf(np.abs(z)),
        critical=crit,
        passes=passes,
        pairs=pairs,
        unassigned_passive=np.setdiff1d(np.arange(z.shape[0]), pairs[:, 0]),
        unassigned_active=np.setdiff1d(np.arange(z.shape[1]), pairs[:, 1]),
        sigma=s,
    )


@dataclass(frozen=True)
class Sequence:
    """Decisions after each active sample (the first entry after 2 samples).

    Attributes
    ----------
    m : (m - 1,) ndarray of int
        Active samples used: 2, 3, ..., m.
    z, p_value : (m - 1,) ndarray
    identified : (m - 1,) ndarray of bool
    first_decision : int
        The m at which the decision took its final value and kept it.
    """

    m: np.ndarray
    z: np.ndarray
    p_value: np.ndarray
    identified: np.ndarray
    first_decision: int


def sequential(
    passive: ArrayLike, active: ArrayLike, sigma: float | None = None, alpha: float = 0.05
) -> Sequence:
    """The Z-test repeated as active samples arrive, one decision per prefix 2..m.

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> p = np.radians(45.0 + 0.3 * rng.standard_normal(60))
    >>> a = np.radians(45.6 + 0.3 * rng.standard_normal(8))
    >>> s = sequential(p, a, sigma=np.radians(0.3))
    >>> s.identified.tolist(), s.first_decision
    ([False, False, False, False, False, False, False], 2)
    """
    alpha = float(as_probability("alpha", alpha))
    pa, pt, pn = _tracks("passive", [passive])
    aa, _, _ = _tracks("active", [active])
    mean_p = _means(pa, pt, pn)[0]
    s = float(bearing_sigma("sigma", sigma, pa))
    m = np.arange(1, aa.size + 1)
    mean_a = np.arctan2(np.cumsum(np.sin(aa)), np.cumsum(np.cos(aa)))
    z = (wrap_finite(mean_a - mean_p) * np.sqrt(m) / s)[1:]
    ident = np.abs(z) <= stats.norm.ppf(1.0 - alpha / 2.0)
    change = np.flatnonzero(ident != ident[-1])
    first = int(m[1:][change[-1] + 1]) if change.size else int(m[1])
    return Sequence(
        m=m[1:],
        z=z,
        p_value=2.0 * stats.norm.sf(np.abs(z)),
        identified=ident,
        first_decision=first,
    )
