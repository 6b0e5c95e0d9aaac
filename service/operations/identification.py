"""Passive/active identification by Kvasnov's Z-test.

Degrees on the wire become radians for core and back. Core errors name core arguments
(``passive``, ``active``, ``sigma``, the elevations, ``delta``, ``beta_max``, ...);
:data:`PAIR_FIELDS`, :data:`PICTURE_FIELDS` and :data:`SIMULATE_FIELDS` map them to the
request's fields.
"""

import numpy as np

from plotgate.core.identification import experiment, identify_picture, sequential, z_test
from plotgate.service.cluster import lazy_map
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
    "picture",
    "simulate",
]


def _rad(value: list[float] | float) -> np.ndarray:
    """Angles in degrees as radians."""
    radians: np.ndarray = np.radians(np.asarray(value, dtype=float))
    return radians


def _optional(value: list[float] | float | None) -> np.ndarray | None:
    """Angles in degrees as radians, None staying None."""
    return None if value is None else _rad(value)


def _angle(value: float | None) -> float | None:
    """An angle in degrees as radians (None stays None)."""
    return None if value is None else float(np.radians(value))


@checked
def pair(request: IdentifyPairRequest) -> IdentifyPairResult:
    """Z-test of one passive and one active track, optionally its decision history."""
    r = request
    passive, active = _rad(r.passive_bearings_deg), _rad(r.active_bearings_deg)
    t = z_test(
        passive,
        active,
        _angle(r.sigma_deg),
        r.alpha,
        passive_elevation=_optional(r.passive_elevations_deg),
        active_elevation=_optional(r.active_elevations_deg),
        sigma_elevation=_angle(r.sigma_elevation_deg),
        delta=_angle(r.delta_deg),
        beta_max=r.beta_max,
        ratio=r.ratio,
        normality_alpha=r.normality_alpha,
    )
    history = None
    if r.sequential:
        s = sequential(passive, active, _angle(r.sigma_deg), r.alpha)
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


@checked
def picture(request: IdentifyPictureRequest) -> IdentifyPictureResult:
    """Z matrix and one-to-one identification of many tracks."""
    pic = identify_picture(
        [np.radians(t) for t in request.passive_deg],
        [np.radians(t) for t in request.active_deg],
        _optional(request.sigma_deg),
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


@checked
def simulate(request: IdentifySimulateRequest) -> IdentifySimulateResult:
    """Kvasnov's experiment: realized alpha (separation 0) or beta. The runs go to the open
    cluster, if any, once core has checked the request
    (:func:`plotgate.service.cluster.lazy_map`), with the same numbers bit for bit."""
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
        mapper=lazy_map,
    )
    return IdentifySimulateResult(
        runs=out.runs,
        identified=out.identified,
        rejected=out.rejected,
        standard_error=out.standard_error,
    )


PAIR_FIELDS: FieldMap = {
    "passive": "passive_bearings_deg",
    "active": "active_bearings_deg",
    "sigma": "sigma_deg",
    "passive_elevation": "passive_elevations_deg",
    "active_elevation": "active_elevations_deg",
    "sigma_elevation": "sigma_elevation_deg",
    "delta": "delta_deg",
}
"""Where core's errors on an ``identification.pair`` request point: each angle to its
field in degrees; the rest (``alpha``, ``beta_max``, ...) are named as they are."""

PICTURE_FIELDS: FieldMap = {
    "passive": "passive_deg[{i}]",
    "active": "active_deg[{i}]",
    "sigma": "sigma_deg[{i}]",
}
"""Where core's errors on an ``identification.picture`` request point: a track's bearings
(``passive_deg[2]``), a passive track's sigma; ``alpha`` is named as it is."""

SIMULATE_FIELDS: FieldMap = {"sigma": "sigma_deg", "width": "width_deg"}
"""Where core's errors on an ``identification.simulate`` request point: the two angles in
degrees; the rest are named as they are."""
