"""A request's plots as arrays, each plot's covariance checked on its own before any use.

Cartesian plots carry their covariance; a polar plot (range, azimuth and their sigmas
about its sensor) gets its covariance through the Jacobian of docs/architecture.md (core),
P = J diag(sigma_r^2, sigma_az^2) J^T, whose error ellipse has the axes sigma_r and
r sigma_az. Every covariance passes :func:`plotgate.core.check_covariance` (symmetric positive
definite, axis ratio below about 10^6) here, before an operation adds two of them
(B = P1 + P2, S = P_first + P_candidate) and whatever the gate kind: a sum can be
positive definite when a term is not, and an error about the sum names neither input.
So a refused covariance is named by the plot's own field, ``first.covariance``,
``candidates[2].covariance``, ``pairs[3].second.covariance``,
``scans[0].plots[4].covariance``, with its own matrix in the reason; a polar plot has no
covariance field, so the error names the plot and the two sigmas that make its ellipse
too thin.
"""

from collections.abc import Callable, Sequence

import numpy as np

from plotgate import core
from plotgate.core import CovarianceError
from plotgate.service.schemas import Plot, PolarPlot

__all__ = ["PlotError", "first_thin_polar", "plot_arrays", "polar_ellipse_reason"]


class PlotError(CovarianceError):
    """A plot refused for its own covariance; ``field`` is the request path it names."""


def polar_ellipse_reason(
    r: float,
    sigma_r: float,
    sigma_az_deg: float,
    names: tuple[str, str] = ("sigma_r", "sigma_az_deg"),
) -> str:
    """Why a polar measurement's own covariance is refused, in terms of its sigmas.

    Its error ellipse has the axes sigma_r and r sigma_az; ``names`` are the request's
    names of the two sigmas.
    """
    across = r * np.radians(sigma_az_deg)
    ratio = max(sigma_r, across) / min(sigma_r, across)
    return (
        f"{names[0]} = {sigma_r:.6g} m and {names[1]} = {sigma_az_deg:.6g} "
        f"(r sigma_az = {across:.6g} m at r = {r:.6g} m) make an error ellipse with "
        f"axis ratio {ratio:.3g}; it must stay below about "
        f"{np.sqrt(core.MAX_CONDITION):.0e}, or its covariance is numerically singular"
    )


def first_thin_polar(
    r: np.ndarray, az_deg: np.ndarray, sigma_r: np.ndarray, sigma_az_deg: np.ndarray
) -> int | None:
    """Index of the first polar measurement (batched over ranges, azimuths, sigmas) whose
    own covariance fails :func:`plotgate.core.check_covariance`, the check core applies to every
    covariance; None when all pass."""
    P = core.polar_covariance_to_cartesian(
        r, np.radians(az_deg), sigma_r, np.radians(sigma_az_deg)
    )
    try:
        core.check_covariance(P)
    except CovarianceError as exc:
        return 0 if exc.index is None else exc.index
    return None


def _refused(plot: Plot, path: str, exc: CovarianceError) -> PlotError:
    if isinstance(plot, PolarPlot):
        return PlotError(path, polar_ellipse_reason(plot.r, plot.sigma_r, plot.sigma_az_deg))
    return PlotError(f"{path}.covariance", exc.reason)


def plot_arrays(
    plots: Sequence[Plot], path: Callable[[int], str]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (N, 2), covariances (N, 2, 2) and sensor positions (N, 2) of the plots.

    ``path(i)`` is plot i's request path (``candidates[2]``); a covariance that fails
    :func:`plotgate.core.check_covariance` raises :class:`PlotError` naming it.
    """
    n = len(plots)
    z = np.empty((n, 2))
    P = np.empty((n, 2, 2))
    sensor = np.array([p.sensor for p in plots], dtype=float).reshape(n, 2)
    polar = np.array([isinstance(p, PolarPlot) for p in plots], dtype=bool)
    cart = [p for p in plots if not isinstance(p, PolarPlot)]
    if cart:
        z[~polar] = [(p.x, p.y) for p in cart]
        P[~polar] = [p.covariance for p in cart]
    if polar.any():
        r, az_deg, s_r, s_az_deg = np.array(
            [(p.r, p.az_deg, p.sigma_r, p.sigma_az_deg) for p in plots if isinstance(p, PolarPlot)]
        ).T
        az, s_az = np.radians(az_deg), np.radians(s_az_deg)
        z[polar] = core.polar_to_cartesian(r, az) + sensor[polar]
        P[polar] = core.polar_covariance_to_cartesian(r, az, s_r, s_az)
    try:
        core.check_covariance(P)
    except CovarianceError as exc:
        i = 0 if exc.index is None else exc.index
        raise _refused(plots[i], path(i), exc) from exc
    return z, P, sensor
