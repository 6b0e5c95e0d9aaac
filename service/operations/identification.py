"""Passive/active identification by the Z-test of seed 004 (DESIGN section 7).

Degrees on the wire become radians for core and back. Core errors name core arguments
(``passive``, ``active``, ``sigma``, the elevations, ``delta``, ``beta_max``, ...);
:func:`pair_field` and :func:`picture_field` map them to the request's fields.
"""

import numpy as np

from plotgate.core import PlotgateError
from plotgate.core.identification import experiment, identify_picture, sequential, z_test
from plotgate.service.fields import FieldMap
from plotgate.service.operations.answers import checked
from plotgate.service.schemas import (
    IdentifyPairRequest,
    IdentifyPairResult,
    IdentifyPictureRequest,
    IdentifyPictureResult,
    IdentifySimulateRequest,
    IdentifySimulateResult,
    SequentialHistory,
)

__all__ = [
    "SIMULATE_FIELDS",
    "PICTURE_FIELDS",
    "PAIR_FIELDS",
    "pair",
    "pair_field",
    "picture",
    "picture_field",
    "simulate",
    "simulate_field",
]


def _rad(value: list[float] | float | None) -> np.ndarray | float | None:
    return None if value is None else np.radians(np.asarray(value, dtype=float))


@checked
def pair(request: IdentifyPairRequest) -> IdentifyPairResult:
    """Z-test of one passive and one active track, optionally its decision history."""
    r = request
    passive, active = _rad(r.passive_bearings_deg), _rad(r.active_bearings_deg)
    t = z_test(
        passive,
        active,
        _rad(r.sigma_deg),
        r.alpha,
        passive_elevation=_rad(r.passive_elevations_deg),
        active_elevation=_rad(r.active_elevations_deg),
        sigma_elevation=_rad(r.sigma_elevation_deg),
        delta=_rad(r.delta_deg),
        beta_max=r.beta_max,
        ratio=r.ratio,
        normality_alpha=r.normality_alpha,
    )
    history = None
    if r.sequential:
        s = sequential(passive, active, _rad(r.sigma_deg), r.alpha)
        history = SequentialHistory(
            m=s.m.tolist(),
            z=s.z.tolist(),
            identified=s.identified.tolist(),
            first_decision=s.first_decision,
        )
    return IdentifyPairResult(
        z=t.z.tolist(),
        p_value=t.p_value.tolist(),
        critical=t.critical,
        identified=t.identified,
        difference_deg=np.degrees(t.difference).tolist(),
        sigma_deg=np.degrees(t.sigma).tolist(),
        n=t.n,
        m=t.m,
        n_over_m=t.n_over_m,
        large_population=t.large_population,
        normality_p=[None if np.isnan(p) else float(p) for p in t.normality_p],
        normal=t.normal,
        beta=t.beta,
        m_required=t.m_required,
        history=history,
    )


_PAIR_FIELDS = {
    "passive": "passive_bearings_deg",
    "active": "active_bearings_deg",
    "sigma": "sigma_deg",
    "passive_elevation": "passive_elevations_deg",
    "active_elevation": "active_elevations_deg",
    "sigma_elevation": "sigma_elevation_deg",
    "delta": "delta_deg",
}


def pair_field(request: IdentifyPairRequest, exc: PlotgateError) -> str:
    """The request field of a core error."""
    return _PAIR_FIELDS.get(exc.field, exc.field)


@checked
def picture(request: IdentifyPictureRequest) -> IdentifyPictureResult:
    """Z matrix and one-to-one identification of many tracks."""
    pic = identify_picture(
        [np.radians(t) for t in request.passive_deg],
        [np.radians(t) for t in request.active_deg],
        _rad(request.sigma_deg),
        request.alpha,
    )
    return IdentifyPictureResult(
        z=pic.z.tolist(),
        p_value=pic.p_value.tolist(),
        critical=pic.critical,
        passes=pic.passes.tolist(),
        pairs=pic.pairs.tolist(),
        unassigned_passive=pic.unassigned_passive.tolist(),
        unassigned_active=pic.unassigned_active.tolist(),
        sigma_deg=np.degrees(pic.sigma).tolist(),
    )


def picture_field(request: IdentifyPictureRequest, exc: PlotgateError) -> str:
    """``passive_deg[i]``, ``active_deg[j]`` or ``sigma_deg``."""
    name = {"passive": "passive_deg", "active": "active_deg", "sigma": "sigma_deg"}.get(
        exc.field, exc.field
    )
    return name if exc.index is None else f"{name}[{exc.index}]"


@checked
def simulate(request: IdentifySimulateRequest) -> IdentifySimulateResult:
    """Seed 004's experiment: realized alpha (separation 0) or beta."""
    r = request
    out = experiment(
        r.n,
        r.m,
        np.radians(r.sigma_deg),
        np.radians(r.separation_deg),
        np.radians(r.width_deg),
        r.runs,
        r.seed,
        r.alpha,
        r.law,
        r.estimate_sigma,
    )
    return IdentifySimulateResult(
        runs=out.runs,
        identified=out.identified,
        rejected=out.rejected,
        standard_error=out.standard_error,
    )


def simulate_field(request: IdentifySimulateRequest, exc: PlotgateError) -> str:
    """The request field of a core error."""
    return {"sigma": "sigma_deg", "width": "width_deg"}.get(exc.field, exc.field)


PAIR_FIELDS: FieldMap = {"*": pair_field}
"""Where core's errors point in the request (:mod:`plotgate.service.fields`)."""

PICTURE_FIELDS: FieldMap = {"*": picture_field}
"""Where core's errors point in the request (:mod:`plotgate.service.fields`)."""

SIMULATE_FIELDS: FieldMap = {"*": simulate_field}
"""Where core's errors point in the request (:mod:`plotgate.service.fields`)."""
