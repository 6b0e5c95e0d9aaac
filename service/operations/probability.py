"""Gating probabilities, areas, false marks and gate design (Konovalov).

The wire's gate, mark and tau become core's gate region and :class:`plotgate.core.MarkGeometry`;
angles arrive in degrees and go to core in radians. A velocity is speed (sin course,
cos course), course clockwise from north. A conditional curve is one vectorized core
call: the geometry batched over the ranges, or one geometry repeated and the velocity
batched over the speeds. An unconditional curve costs one quadrature of 0.1 s to minutes
per range, so each of its points is a chunk of its own (:func:`unconditional_point`),
mapped by the open cluster's ``map`` (:func:`plotgate.service.cluster.lazy_map`; in this
process without one): core computes each problem alone, so the curve is the same bit for
bit wherever its points run. Conditional curves cost milliseconds and stay in-process.

Core errors name core arguments; :data:`PROBABILITY_FIELDS` and its variants map them to
request paths.
"""

import math
from collections.abc import Callable
from typing import Literal

import numpy as np

from plotgate import core
from plotgate.core import PlotgateError
from plotgate.service.cluster import lazy_map
from plotgate.service.fields import FieldMap, resolve
from plotgate.service.operations.answers import checked
from plotgate.service.operations.gate_conversion import core_gate
from plotgate.service.operations.plots import PlotError, first_thin_polar, polar_ellipse_reason
from plotgate.service.schemas import (
    AreaApproximation,
    FalseMarks,
    GateAnalysisRequest,
    GateAnalysisResult,
    GateDesignRequest,
    GateDesignResult,
    GateProbabilityCurve,
    GateProbabilityCurveRequest,
    GateProbabilityRequest,
    GateProbabilityResult,
    Mark,
    Resolution,
    SpeedPrior,
)

__all__ = [
    "DESIGN_FIELDS",
    "ANALYSIS_FIELDS",
    "CURVE_FIELDS",
    "PROBABILITY_FIELDS",
    "analysis",
    "curve",
    "design",
    "probability",
    "unconditional_point",
]

DESIGN_M_MAX = 5
"""False-mark counts m = 0..5 reported by ``gates.design`` (its request has no m_max)."""


def _own_covariances(mark: Mark, r: np.ndarray, where: Callable[[int], str]) -> None:
    """Check each mark's own covariance (axes sigma_r and r sigma_az) before core forms
    B = P1 + P2, naming the mark (``where(i)`` at range r[i]) and the two sigmas."""
    second = (
        (
            "sigma_r" if mark.sigma_r2 is None else "sigma_r2",
            "sigma_az_deg" if mark.sigma_az2_deg is None else "sigma_az2_deg",
        ),
        mark.sigma_r if mark.sigma_r2 is None else mark.sigma_r2,
        mark.sigma_az_deg if mark.sigma_az2_deg is None else mark.sigma_az2_deg,
    )
    for names, sigma_r, sigma_az_deg in (
        (("sigma_r", "sigma_az_deg"), mark.sigma_r, mark.sigma_az_deg),
        second,
    ):
        i = first_thin_polar(
            r,
            np.full(r.shape, mark.az_deg),
            np.full(r.shape, sigma_r),
            np.full(r.shape, sigma_az_deg),
        )
        if i is not None:
            raise PlotError(
                where(i), polar_ellipse_reason(float(r[i]), sigma_r, sigma_az_deg, names)
            )


def _geometry(
    mark: Mark,
    tau: float,
    r: np.ndarray | None = None,
    where: Callable[[int], str] = lambda _: "mark",
) -> core.MarkGeometry:
    """The mark's geometry; ``r`` (an array: one problem per range, problem i named
    ``where(i)``) replaces ``mark.r``.

    Each mark's own covariance is checked (:func:`_own_covariances`) before core's
    errors: core computes both covariances (P1, P2) with the same arithmetic, so the
    geometry is built first and its P1, P2 checked in one compiled pass; only when that
    or core refuses does the per-mark check run, to raise the error it always raised."""
    ranges = np.array([mark.r]) if r is None else r
    try:
        geometry = core.mark_geometry(
            mark.r if r is None else r,
            math.radians(mark.az_deg),
            mark.sigma_r,
            math.radians(mark.sigma_az_deg),
            tau,
            mark.sigma_r2,
            None if mark.sigma_az2_deg is None else math.radians(mark.sigma_az2_deg),
        )
    except PlotgateError:
        _own_covariances(mark, ranges, where)
        raise
    try:
        core.check_covariance(np.concatenate([geometry.P1, geometry.P2]))
    except PlotgateError:
        _own_covariances(mark, ranges, where)
    return geometry


def _velocity(speed: float | np.ndarray, course_deg: float) -> np.ndarray:
    """v = speed (sin course, cos course), m/s: (2,) or (N, 2) for N speeds."""
    course = math.radians(course_deg)
    return np.multiply.outer(speed, [math.sin(course), math.cos(course)])


def _unconditional(
    gate: core.Gate, geometry: core.MarkGeometry, prior: SpeedPrior
) -> core.GateProbability:
    """Konovalov, eq. 3-6, over the prior's speeds and a uniform heading."""
    return core.unconditional_probability(gate, geometry, prior.v_min, prior.v_max, prior.kind)


def unconditional_point(
    point: tuple[int, core.Gate, core.MarkGeometry, SpeedPrior],
) -> core.GateProbability:
    """One point of an unconditional curve: (its index i, the gate, problem i's geometry,
    the prior). A core error names problem i, as it would in the whole curve's call."""
    i, gate, geometry, prior = point
    try:
        return _unconditional(gate, geometry, prior)
    except PlotgateError as exc:
        if exc.index is None:
            raise
        raise type(exc)(exc.field, exc.reason, i + exc.index) from exc


def _unconditional_curve(
    gate: core.Gate, geometry: core.MarkGeometry, prior: SpeedPrior
) -> core.GateProbability:
    """The unconditional probability of every problem, each one a chunk (its own
    :func:`unconditional_point`) mapped by the open cluster, if any."""
    points = [(i, gate, geometry.take(slice(i, i + 1)), prior) for i in range(geometry.n)]
    parts = lazy_map(unconditional_point, points)
    return core.GateProbability(
        np.concatenate([p.probability for p in parts]), np.concatenate([p.error for p in parts])
    )


def _false_marks(
    area: np.ndarray, r: float, resolution: Resolution, F: float, m_max: int
) -> tuple[float, FalseMarks]:
    """Cells S' = S / (dR R dAz) and the Poisson false marks in them (Konovalov)."""
    cells = core.resolution_cells(area, r, resolution.range, math.radians(resolution.azimuth_deg))
    marks = core.false_marks(cells, F, m_max)
    return float(cells[0]), FalseMarks(
        mean=float(marks.mean[0]),
        probabilities=marks.probabilities[0].tolist(),
        at_least_one=float(marks.at_least_one[0]),
    )


@checked
def probability(request: GateProbabilityRequest) -> GateProbabilityResult:
    """Conditional (Konovalov, eq. 2) or unconditional (eq. 3-6) gating probability."""
    gate = core_gate(request.gate)
    geometry = _geometry(request.mark, request.tau)
    if request.velocity is not None:
        v = request.velocity
        result = core.conditional_probability(gate, geometry, _velocity(v.speed, v.course_deg))
    else:
        assert request.prior is not None  # the schema gives exactly one
        result = _unconditional(gate, geometry, request.prior)
    return GateProbabilityResult(
        conditional=request.velocity is not None,
        probability=float(result.probability[0]),
        error=float(result.error[0]),
    )


@checked
def curve(request: GateProbabilityCurveRequest) -> GateProbabilityCurve:
    """The probability at every value (Konovalov, Fig. 2 and 5): one vectorized core call,
    or for an unconditional curve one chunk per value, on the open cluster if any."""
    gate = core_gate(request.gate)
    values = np.asarray(request.values, dtype=float)
    if request.against == "speed":
        geometry = _geometry(request.mark, request.tau, np.full(values.size, request.mark.r))
        result = core.conditional_probability(
            gate, geometry, _velocity(values, request.course_deg)
        )
    else:
        geometry = _geometry(request.mark, request.tau, values, lambda i: f"values[{i}]")
        if request.prior is not None:
            result = _unconditional_curve(gate, geometry, request.prior)
        else:
            assert request.speed is not None  # the schema gives exactly one
            result = core.conditional_probability(
                gate, geometry, _velocity(request.speed, request.course_deg)
            )
    return GateProbabilityCurve(
        against=request.against,
        values=request.values,
        conditional=request.conditional,
        probability=result.probability.tolist(),
        error=result.error.tolist(),
    )


@checked
def analysis(request: GateAnalysisRequest) -> GateAnalysisResult:
    """Area, cells, false marks and capture probability P_gate P_D1 P_D2 (Konovalov).

    For the combined gate the paper's approximation S_ring + S_ellipse / 2 is given too.
    """
    gate = core_gate(request.gate)
    geometry = _geometry(request.mark, request.tau)
    gated = None if request.prior is None else _unconditional(gate, geometry, request.prior)
    area = core.gate_area(gate, geometry)
    cells, marks = _false_marks(
        area, request.mark.r, request.resolution, request.false_alarm, request.m_max
    )
    approximation = None
    if isinstance(gate, core.CombinedGate):
        approx = core.combined_area_approximation(gate, geometry)
        approx_cells, approx_marks = _false_marks(
            approx, request.mark.r, request.resolution, request.false_alarm, request.m_max
        )
        approximation = AreaApproximation(
            area=float(approx[0]), cells=approx_cells, false_marks=approx_marks
        )
    probabilities = {}
    if gated is not None:
        capture = core.capture_probability(gated.probability, request.P_D1, request.P_D2)
        probabilities = {
            "gate_probability": float(gated.probability[0]),
            "error": float(gated.error[0]),
            "capture": float(capture[0]),
        }
    return GateAnalysisResult(
        area=float(area[0]),
        cells=cells,
        false_marks=marks,
        approximation=approximation,
        **probabilities,
    )


@checked
def design(request: GateDesignRequest) -> GateDesignResult:
    """The combined gate's P_G or the expanded gate's p reaching the wanted capture."""
    prior = request.prior
    gate = core_gate(request.gate)
    assert isinstance(gate, core.CombinedGate | core.ExpandedGate)  # DesignGate's kinds
    found = core.design_gate(
        gate,
        _geometry(request.mark, request.tau),
        request.capture,
        prior.v_min,
        prior.v_max,
        prior.kind,
        request.P_D1,
        request.P_D2,
    )
    parameter: Literal["P_G", "p"]
    if request.gate.kind == "combined":
        parameter, threshold = "P_G", core.gate_threshold(found.parameter, 2)
    else:
        parameter, threshold = "p", core.expansion_coefficient(found.parameter)
    cells, marks = _false_marks(
        np.array([found.area]),
        request.mark.r,
        request.resolution,
        request.false_alarm,
        DESIGN_M_MAX,
    )
    return GateDesignResult(
        parameter=parameter,
        value=found.parameter,
        threshold=float(threshold),
        probability=found.probability,
        error=found.error,
        capture=found.capture,
        area=found.area,
        cells=cells,
        false_marks=marks,
    )


def _speed_bound(request: GateProbabilityRequest | GateAnalysisRequest, exc: PlotgateError) -> str:
    """v_min or v_max: the prior's when its bounds are inconsistent, else the gate's."""
    prior = getattr(request, "prior", None)
    inconsistent = prior is not None and prior.v_min > prior.v_max
    return ("prior." if inconsistent else "gate.") + exc.field


def _against(
    range_path: str, speed_path: str
) -> Callable[[GateProbabilityCurveRequest, PlotgateError], str]:
    """A curve argument's path: one when the values are ranges, another when speeds."""

    def field(request: GateProbabilityCurveRequest, exc: PlotgateError) -> str:
        path = range_path if request.against == "range" else speed_path
        return resolve({exc.field: path}, request, exc)

    return field


PROBABILITY_FIELDS: FieldMap = {
    "tau": "tau",
    "r": "mark.r",
    "az": "mark.az_deg",
    "sigma_r": "mark.sigma_r",
    "sigma_az": "mark.sigma_az_deg",
    "sigma_r2": "mark.sigma_r2",
    "sigma_az2": "mark.sigma_az2_deg",
    "B": "mark",
    "geometry": "mark",
    "P_G": "gate.P_G",
    "p": "gate.p",
    "k": "gate.k",
    "K_R": "gate.K_R",
    "K_az": "gate.K_az",
    "offset": "gate.offset",
    "velocity": "velocity",
    "prior": "prior.kind",
    "capture": "capture",
    "P_D1": "P_D1",
    "P_D2": "P_D2",
    "F": "false_alarm",
    "m_max": "m_max",
    "dR": "resolution.range",
    "dAz": "resolution.azimuth_deg",
    "cells": "resolution",
    "v_min": _speed_bound,
    "v_max": _speed_bound,
}
"""Where core's errors point in a ``gates.probability`` request
(:mod:`plotgate.service.fields`); every other request of the gating probabilities feeds
core the same arguments. Core checks v_min <= v_max with ``ParameterError("v_min", ...)``
both for a gate and for the prior; the error names the one whose bounds are inconsistent
(the prior when both are, as core checks the prior first). A mark refused for its own
covariance (:class:`~plotgate.service.operations.plots.PlotError`) already names its
path, which no entry matches, so it is kept as it is."""

CURVE_FIELDS: FieldMap = {
    **PROBABILITY_FIELDS,
    "r": _against("values[{i}]", "mark.r"),
    "B": _against("values[{i}]", "mark"),
    "velocity": _against("speed", "values[{i}]"),
}
"""As :data:`PROBABILITY_FIELDS`, with the per-value errors named ``values[i]``: against
range the geometry (``r``, ``B``) is per value, against speed the velocity is; against
range a conditional curve's velocity comes from ``speed``."""

ANALYSIS_FIELDS: FieldMap = PROBABILITY_FIELDS
"""Where core's errors point in a ``gates.analysis`` request (as :data:`PROBABILITY_FIELDS`)."""

DESIGN_FIELDS: FieldMap = PROBABILITY_FIELDS
"""Where core's errors point in a ``gates.design`` request (as :data:`PROBABILITY_FIELDS`)."""
