"""A state's tentative tracks checked against the plots they were made of.

A state carries the plots its tentative tracks hold
(:class:`~plotgate.core.initiation.state.HeldPlots`), so a tentative track can be made
again from them: started as the confirmation rule starts it (k/m: the two-point state of
its first two plots, :func:`~plotgate.core.initiation.filter.two_point`; the score: the
one-point prior of its first plot, predicted and updated with the second), then predicted
to each later plot and updated with the settings' gain, then predicted to the state's
time. The constant-velocity model with white acceleration composes exactly (a prediction
over a + b is the prediction over a, then over b), so the scans a track missed need not be
known. The track's ``x`` and ``P`` must be the ones made again within
:data:`REMADE_TOLERANCE`; otherwise the state is refused naming ``state.tracks.x`` or
``state.tracks.P`` at the track's row.

Not made again, because the state does not carry what it would take: a track whose first
plot has left its history (``n`` above ``config.history``, possible under score
confirmation only) and, under the alpha-beta filter, a track that missed a scan between
two of its plots (the gain takes the scan interval, which the state does not keep). Nor,
under existence confirmation, any tentative track: its state is the PDA mixture of every
plot of every gate it passed (Bar-Shalom and Tse), and the state carries only the nearest
plot of each scan; its existence is held to (tau_d, tau_c) by the state's own checks.

The held plots themselves: ids increasing, exactly those the tentative tracks hold, each
covariance symmetric positive definite, and each track's last plot at the range and
azimuth the track keeps of it (``state.plots.<name>``, ``state.tracks.<name>``).
"""

from __future__ import annotations

import numpy as np

from plotgate.core.errors import CovarianceError, ParameterError
from plotgate.core.frames import wrap_angle
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.filter import (
    alpha_beta_gain,
    kalman_gain,
    one_point,
    predict,
    two_point,
    update,
)
from plotgate.core.initiation.state import PLOT_STRIDE, InitiationState
from plotgate.core.validation import as_covariance, require

__all__ = ["REMADE_TOLERANCE", "check_held_plots", "remade_tracks"]

REMADE_TOLERANCE = 1e-6
"""How far a tentative track's state and covariance may lie from the ones made again from
its plots: each element of x within 1e-6 of |x| + its sigma, each element P_ij within 1e-6
of |P_ij| + sqrt(P_ii P_jj) (of the ones made again). Making a track again rounds where
initiation rounded, but for the predictions over missed scans composed into one (about
1e-15 of the values); a tampered track is off by far more (a position moved by 1 m in
10 km is 1e-4 of it)."""


def _check_table(state: InitiationState) -> None:
    """The held plots are exactly the tentative tracks' plots, ids increasing."""
    held, tr = state.plots, state.tracks
    require(
        "state.plots.plot",
        np.concatenate([[True], held.plot[1:] > held.plot[:-1]]),
        lambda i: f"is {held.plot[i]}, not above the id before it; ids increase",
    )
    as_covariance("state.plots.R", held.R)
    tentative = ~tr.confirmed[:, None] & (tr.plots >= 0)
    known = np.isin(tr.plots, held.plot)
    require(
        "state.tracks.plots",
        (known | ~tentative).all(axis=1),
        lambda i: (
            f"is {tr.plots[i].tolist()}: a tentative track's plot that state.plots does not "
            "carry (a state carries every plot of its tentative tracks)"
        ),
    )
    require(
        "state.plots.plot",
        np.isin(held.plot, tr.plots[tentative]),
        lambda i: f"is {held.plot[i]}, a plot no tentative track holds",
    )


def _check_last_plots(state: InitiationState) -> None:
    """A tentative track's last plot lies at the range and azimuth the track keeps of it
    from its sensor (to 1e-9 of the distances involved, as an initiator's copies)."""
    tr, held = state.tracks, state.plots
    rows = np.flatnonzero(~tr.confirmed)
    z = held.z[np.searchsorted(held.plot, tr.plots[rows, -1])]
    rel = z - tr.sensor[rows]
    r, az = np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 0], rel[:, 1])
    kept = tr.ranges[rows, -1]
    near = 1e-9 * (np.abs(z).sum(axis=1) + np.abs(tr.sensor[rows]).sum(axis=1) + kept)
    bad_r = np.abs(kept - r) > near
    bad_az = np.abs(wrap_angle(tr.az[rows] - az)) * kept > near
    for name, bad, said in (("ranges", bad_r, r), ("az", bad_az, az)):
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            raise ParameterError(
                f"state.tracks.{name}",
                f"disagrees with the track's last plot in state.plots, {said[j]} from its "
                f"sensor {tr.sensor[rows[j]].tolist()}",
                int(rows[j]),
            )


def _start(
    config: InitiationConfig, z1: np.ndarray, R1: np.ndarray, t1: np.ndarray,
    z2: np.ndarray, R2: np.ndarray, t2: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The state of a track born of plots 1 and 2, as the confirmation rule starts it
    (:meth:`~plotgate.core.initiation.confirmation.Confirmation.start`)."""
    if config.confirmation == "score":
        x1, P1 = one_point(z1, R1, config.v_max)
        x2, P2 = predict(x1, P1, t2 - t1, config.q)
        return update(x2, P2, z2, R2, kalman_gain(P2, R2))
    return two_point(z1, R1, z2, R2, t2 - t1)


def remade_tracks(
    state: InitiationState, config: InitiationConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tentative tracks made again from their held plots.

    Returns
    -------
    rows : (c,) ndarray
        The rows of ``state.tracks`` made again (tentative, not excepted; the module's
        docstring).
    x, P : (c, 4), (c, 4, 4) ndarray
        Their state [x, y, vx, vy] (m, m/s) and covariance at the state's time.
    """
    tr, held, H = state.tracks, state.plots, state.tracks.plots.shape[1]
    plots = tr.plots
    present = plots >= 0
    scan = np.where(present, plots // PLOT_STRIDE, -1)
    gap = (present[:, :-1] & (scan[:, 1:] - scan[:, :-1] > 1)).any(axis=1)
    ok = ~tr.confirmed & (tr.n <= H) & ~(gap & (config.filter == "alpha_beta"))
    rows = np.flatnonzero(ok)
    at = np.searchsorted(held.plot, plots[rows])
    at = np.minimum(at, max(held.size - 1, 0))
    z, R = held.z[at], held.R[at]
    t = tr.times[rows]
    c, n = rows.size, tr.n[rows]
    x, P = np.zeros((c, 4)), np.zeros((c, 4, 4))
    first = H - n  # column of each row's first plot
    last_t = np.zeros(c)
    for j in range(H):  # a history's width: a few columns
        second = np.flatnonzero(first + 1 == j)
        if second.size:
            x[second], P[second] = _start(
                config,
                z[second, j - 1], R[second, j - 1], t[second, j - 1],
                z[second, j], R[second, j], t[second, j],
            )  # fmt: skip
        later = np.flatnonzero(first + 1 < j)
        if later.size:
            dt = t[later, j] - last_t[later]
            xp, Pp = predict(x[later], P[later], dt, config.q)
            Rj = R[later, j]
            if config.filter == "kalman":
                K = kalman_gain(Pp, Rj)
            else:
                taken = j - first[later] + 1.0  # plots after this one's update
                K = alpha_beta_gain(taken, dt, config.alpha_min, config.beta_min)
            x[later], P[later] = update(xp, Pp, z[later, j], Rj, K)
        last_t[first <= j] = t[first <= j, j]
    now = np.full(c, state.t if state.t is not None else 0.0)
    x, P = predict(x, P, now - last_t, config.q)
    return rows, x, P


def _check_remade(state: InitiationState, config: InitiationConfig) -> None:
    """Each tentative track's x and P those made again from its plots."""
    tr = state.tracks
    with np.errstate(all="ignore"):
        rows, x, P = remade_tracks(state, config)
    if rows.size == 0:
        return
    sigma = np.sqrt(np.abs(np.diagonal(P, axis1=1, axis2=2)))
    off_x = np.abs(tr.x[rows] - x) > REMADE_TOLERANCE * (np.abs(x) + sigma)
    scale = np.abs(P) + sigma[:, :, None] * sigma[:, None, :]
    off_P = np.abs(tr.P[rows] - P) > REMADE_TOLERANCE * scale
    for name, off, made, error in (
        ("x", off_x.any(axis=1), x, ParameterError),
        ("P", off_P.any(axis=(1, 2)), P, CovarianceError),
    ):
        if off.any():
            j = int(np.flatnonzero(off)[0])
            raise error(
                f"state.tracks.{name}",
                f"is {getattr(tr, name)[rows[j]].tolist()}, but its plots in state.plots make "
                f"{made[j].tolist()} (within {REMADE_TOLERANCE:g} of its values and sigmas): "
                "a tentative track is what its plots make it",
                int(rows[j]),
            )


def check_held_plots(state: InitiationState, config: InitiationConfig) -> None:
    """Check the held plots, and every tentative track against them (the module's
    docstring); raises ParameterError or CovarianceError naming the field and row."""
    _check_table(state)
    _check_last_plots(state)
    if config.confirmation != "existence":
        _check_remade(state, config)
