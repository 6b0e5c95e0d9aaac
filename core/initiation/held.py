"""The plots a state's tentative tracks hold, carried from scan to scan.

A tentative track is made of its plots: its first (an initiator's), its second (the
scan that captured it) and every plot it took since. The state keeps those plots' positions
and covariances (:class:`~plotgate.core.initiation.state.HeldPlots`) while any tentative
track holds them, so that a state sent back can be checked against the plots its tracks
were born from (:mod:`plotgate.core.initiation.held_checks`).
"""

from __future__ import annotations

import numpy as np

from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.state import HeldPlots, Initiators, Tracks

__all__ = ["held_plots"]


def held_plots(
    before: HeldPlots, ini: Initiators, scan: Scan, ids: np.ndarray, tracks: Tracks
) -> HeldPlots:
    """The plots the tentative ``tracks`` hold after a scan, ids increasing.

    Each is one the tentative tracks held before the scan (``before``), an initiator's
    (``ini``, the initiators before the scan: a new track's first plot) or one of the
    scan's (``ids``, its plot ids). A plot held in two places is the same plot, so the
    first of its copies is taken.
    """
    tentative = tracks.plots[~tracks.confirmed]
    wanted = np.unique(tentative[tentative >= 0])
    if wanted.size == 0:
        return HeldPlots(wanted, np.zeros((0, 2)), np.zeros((0, 2, 2)))
    plot = np.concatenate([before.plot, ini.plot, ids])
    known, first = np.unique(plot, return_index=True)
    pick = first[np.searchsorted(known, wanted)]
    z = np.concatenate([before.z, ini.z, scan.z])[pick]
    R = np.concatenate([before.R, ini.R, scan.R])[pick]
    return HeldPlots(wanted, z, R)
