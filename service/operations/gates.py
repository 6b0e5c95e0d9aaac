"""Gate tests (Konovalov; Mu et al.; the secondary-processing textbook).

Plots arrive Cartesian or polar; both become positions z (m) and covariances P (m^2) in
the common frame (:func:`plotgate.service.operations.plots.plot_arrays`, which checks each plot's
covariance on its own, whatever the gate kind, before any sum B = P_first + P_candidate,
and names the plot's own field: ``first.covariance``, ``candidates[2].covariance``,
``pairs[3].second.covariance``, or the polar plot ``candidates[2]`` with its sigmas). The
capture and tracking gates run on those. The polar gates (sector, first association) take
range, azimuth and their sigmas about the *first* plot's sensor, from the same (z, P)
through the polar-to-Cartesian Jacobian, so a polar plot from that sensor keeps its own
sigmas exactly.
"""

import math
from collections.abc import Callable

import numpy as np

from plotgate import core
from plotgate.core import GeometryError, PlotgateError
from plotgate.service.fields import FieldMap, resolve
from plotgate.service.operations.answers import checked
from plotgate.service.operations.gate_conversion import core_gate
from plotgate.service.operations.plots import plot_arrays
from plotgate.service.schemas import (
    MIN_RANGE,
    GatePairsRequest,
    GateResults,
    GateTestRequest,
    Plot,
    PolarPlot,
)
from plotgate.service.schemas.gates import Gate, Stage

__all__ = ["PAIRS_FIELDS", "TEST_FIELDS", "pairs", "test"]

_STAGES: tuple[Stage, ...] = ("none", "ring", "inner_ellipse", "outer_ellipse")
_STATISTICS = {
    "ring": "distance |z2 - z1|, m",
    "expanded": "(dX/a)^2 + (dY/b)^2, dimensionless",
    "combined": "rho = nu^T B^-1 nu to the ring's edge (0 inside the ring)",
    "ellipse": "rho = nu^T S^-1 nu",
    "rectangular": "max(|dx|/sigma_x, |dy|/sigma_y), sigmas",
    "sector": "max(|dr|/(K_R s_r), |d az|/(K_az s_az)), window fractions",
    "first_association": "max(|dr|/W_R, |d az|/W_az), window fractions",
}


def _polar(
    z: np.ndarray, P: np.ndarray, sensor: np.ndarray, side: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Range, azimuth (rad) and their sigmas about ``sensor``.

    ``side`` ("1" or "2") names the plots in errors: ``z1``/``P1`` are the first plots,
    ``z2``/``P2`` the second.

    A plot closer than :data:`MIN_RANGE` to the sensor has no usable azimuth (its azimuth
    variance grows as 1/r^2), as a polar plot could not be that close either.
    """
    rel = z - sensor
    r, az = core.cartesian_to_polar(rel)
    near = np.flatnonzero(np.atleast_1d(r) < MIN_RANGE)
    if near.size:
        index = int(near[0]) if np.ndim(r) else None
        raise GeometryError(
            "z" + side,
            f"is {np.atleast_1d(r)[near[0]]:.3g} m from the sensor of the first plot; "
            f"polar gates need at least {MIN_RANGE:g} m",
            index,
        )
    try:
        C = core.cartesian_covariance_to_polar(rel, P)
    except PlotgateError as exc:
        raise type(exc)("P" + side, exc.reason, exc.index) from exc
    return r, az, np.sqrt(C[..., 0, 0]), np.sqrt(C[..., 1, 1])


def _gate(
    gate: Gate,
    z1: np.ndarray,
    P1: np.ndarray,
    s1: np.ndarray,
    z2: np.ndarray,
    P2: np.ndarray,
) -> core.GateResult:
    """Test second marks (z2, P2) against first marks (z1, P1, sensor s1) in the wire gate.

    The gate is core's (:func:`~plotgate.service.operations.gate_conversion.core_gate`);
    what differs by kind is only the marks its ``test`` takes: positions, covariances
    and, for the tracking gates, S = P1 + P2 about the first plot; the polar gates take
    range, azimuth and their sigmas about the first plot's sensor.
    """
    tau: float = getattr(gate, "tau", math.nan)  # the gates that take tau have it
    match core_gate(gate):
        case core.RingGate() as ring:
            return ring.test(z1, z2, tau)
        case core.ExpandedGate() as expanded:
            _, _, sigma_r, sigma_az = _polar(z1, P1, s1, "1")
            return expanded.test(z1, z2, tau, sigma_r, sigma_az, sensor=s1)
        case core.CombinedGate() as combined:
            return combined.test(z1, P1, z2, P2, tau)
        case core.EllipseGate() as ellipse:
            return ellipse.test(z2, z1, P1 + P2)
        case core.RectangularGate() as rectangular:
            S = P1 + P2
            return rectangular.test(z2, z1, np.sqrt(S[..., 0, 0]), np.sqrt(S[..., 1, 1]))
        case core.SectorGate() as sector:
            r1, az1, sr1, saz1 = _polar(z1, P1, s1, "1")
            r2, az2, sr2, saz2 = _polar(z2, P2, s1, "2")
            return sector.test(r2, az2, r1, az1, sr2, saz2, sr1, saz1)
        case core.FirstAssociationGate() as first:
            r1, az1, sr1, saz1 = _polar(z1, P1, s1, "1")
            r2, az2, sr2, saz2 = _polar(z2, P2, s1, "2")
            return first.test(r1, az1, r2, az2, tau, sr1, saz1, sr2, saz2)
    raise AssertionError(gate.kind)


def _results(gate: Gate, result: core.GateResult) -> GateResults:
    return GateResults(
        kind=gate.kind,
        statistic_name=_STATISTICS[gate.kind],
        threshold=float(result.threshold),
        inside=result.inside.tolist(),
        statistic=result.statistic.tolist(),
        stage=None if result.stage is None else [_STAGES[s] for s in result.stage],
        count_inside=int(np.count_nonzero(result.inside)),
    )


@checked
def test(request: GateTestRequest) -> GateResults:
    """Test the first plot against every candidate."""
    z1, P1, s1 = plot_arrays([request.first], lambda _: "first")
    z2, P2, _ = plot_arrays(request.candidates, lambda i: f"candidates[{i}]")
    return _results(request.gate, _gate(request.gate, z1[0], P1[0], s1[0], z2, P2))


@checked
def pairs(request: GatePairsRequest) -> GateResults:
    """Test every (first, second) pair on its own."""
    z1, P1, s1 = plot_arrays([pair.first for pair in request.pairs], lambda i: f"pairs[{i}].first")
    z2, P2, _ = plot_arrays(
        [pair.second for pair in request.pairs], lambda i: f"pairs[{i}].second"
    )
    return _results(request.gate, _gate(request.gate, z1, P1, s1, z2, P2))


def _with_covariance(path: str, plot: Plot) -> str:
    """A plot's path, down to the ``covariance`` a Cartesian plot sends (a polar plot sends
    sigmas, and is named itself)."""
    return path if isinstance(plot, PolarPlot) else f"{path}.covariance"


def _test_P1(request: GateTestRequest, exc: PlotgateError) -> str:
    return _with_covariance("first", request.first)


def _test_P2(request: GateTestRequest, exc: PlotgateError) -> str:
    if exc.index is None:
        return "candidates"
    return _with_covariance(f"candidates[{exc.index}]", request.candidates[exc.index])


def _pairs_P(side: str) -> Callable[[GatePairsRequest, PlotgateError], str]:
    def field(request: GatePairsRequest, exc: PlotgateError) -> str:
        if exc.index is None:
            return "pairs"
        pair = request.pairs[exc.index]
        return _with_covariance(f"pairs[{exc.index}].{side}", getattr(pair, side))

    return field


def _sigma(
    first: str, second: str
) -> Callable[[GateTestRequest | GatePairsRequest, PlotgateError], str]:
    """sigma_r and sigma_az: the first plot's in the expanded gate, the second's in the sector."""

    def field(request: GateTestRequest | GatePairsRequest, exc: PlotgateError) -> str:
        path = first if request.gate.kind == "expanded" else second
        return resolve({exc.field: path}, request, exc)

    return field


_GATE = ("tau", "v_min", "v_max", "P_G", "p", "k", "K_R", "K_az")
"""Core arguments that are the gate's own parameters."""
_FIRST = (
    "z1",
    "z_pred",
    "r_pred",
    "az_pred",
    "sigma_r_pred",
    "sigma_az_pred",
    "r1",
    "az1",
    "sigma_r1",
    "sigma_az1",
    "sensor",
)
"""Core arguments taken from the first plot (the gate's centre or prediction)."""
_SECOND = ("z2", "z", "r", "az", "sigma_r2", "sigma_az2")
"""Core arguments taken from the second plot (the candidate)."""
_BOTH = ("S", "sigma_x", "sigma_y")
"""Core arguments summed over both plots of a pair: S = P1 + P2 and its sigmas."""

TEST_FIELDS: FieldMap = {
    **{name: f"gate.{name}" for name in _GATE},
    **dict.fromkeys(_FIRST, "first"),
    **dict.fromkeys(_SECOND + _BOTH, "candidates[{i}]"),
    "P1": _test_P1,
    "P2": _test_P2,
    "sigma_r": _sigma("first", "candidates[{i}]"),
    "sigma_az": _sigma("first", "candidates[{i}]"),
}
"""Where core's errors on a ``gates.test`` request point (:mod:`plotgate.service.fields`).

A plot refused for its own covariance (:class:`~plotgate.service.operations.plots.PlotError`)
already names its path, which no entry matches, so it is kept as it is."""

PAIRS_FIELDS: FieldMap = {
    **{name: f"gate.{name}" for name in _GATE},
    **dict.fromkeys(_FIRST, "pairs[{i}].first"),
    **dict.fromkeys(_SECOND, "pairs[{i}].second"),
    **dict.fromkeys(_BOTH, "pairs[{i}]"),
    "P1": _pairs_P("first"),
    "P2": _pairs_P("second"),
    "sigma_r": _sigma("pairs[{i}].first", "pairs[{i}].second"),
    "sigma_az": _sigma("pairs[{i}].first", "pairs[{i}].second"),
}
"""Where core's errors on a ``gates.pairs`` request point, as :data:`TEST_FIELDS`."""
