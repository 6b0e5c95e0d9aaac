"""The multistatic accuracy study of Fadeev et al., Fig. 3 (``solves.study``).

The wire's platforms become per-sample arrays (T, P, D) exactly as in
:mod:`plotgate.service.operations.solves` (a moving platform's position is the one at
``sample_times[0]``); :func:`plotgate.core.multistatic.study.accuracy_study` runs the Monte Carlo,
and its per-sample arrays become one :class:`~plotgate.service.schemas.StudySample` per sample
time. NaN entries (the track curves at sample 0, or without tracks) go on the wire as
null.

Core errors name core arguments; :data:`STUDY_FIELDS` maps them to the request: ``x0``,
``v`` and ``x`` (a target passing through a platform) to ``target``, ``tx`` to
``transmitter``, ``rx`` and ``l`` (too few pairs) to ``receivers``, ``t`` to
``sample_times``.
"""

import numpy as np

from plotgate.core.multistatic.study import accuracy_study
from plotgate.service.cluster import lazy_map
from plotgate.service.fields import FieldMap
from plotgate.service.operations.answers import checked
from plotgate.service.operations.solves import platform_array, sample_errors
from plotgate.service.schemas import StudyRequest, StudyResult, StudySample

__all__ = ["STUDY_FIELDS", "study"]


def _rows(a: np.ndarray) -> list[list[float] | None]:
    """(T, D) per-axis values as lists, a row with NaN as null."""
    return [None if np.isnan(row).any() else row.tolist() for row in a]


def _scalars(a: np.ndarray) -> list[float | None]:
    return [None if np.isnan(v) else float(v) for v in a]


@checked
def study(request: StudyRequest) -> StudyResult:
    """Fadeev et al., Fig. 3 curves 1-6 and their diagnostics, by seeded Monte Carlo. The
    runs' solves go to the open cluster, if any, once core has checked the request
    (:func:`plotgate.service.cluster.lazy_map`), with the same numbers bit for bit."""
    t = np.asarray(request.sample_times, dtype=float)
    tx = platform_array(request.transmitter, t, t.size)[:, None, :]
    rx = np.stack([platform_array(q, t, t.size) for q in request.receivers], axis=-2)
    with sample_errors(t, moving=True):
        s = accuracy_study(
            t,
            tx,
            rx,
            request.target.position,
            request.target.velocity,
            request.sigma,
            request.runs,
            request.seed,
            alpha=request.alpha,
            tracks=request.tracks,
            mapper=lazy_map,
        )
    columns = {
        "t": s.t.tolist(),
        "position": s.x.tolist(),
        "crlb": s.crlb.tolist(),
        "crlb_accumulated": s.crlb_accumulated.tolist(),
        "crlb_difference": s.crlb_difference.tolist(),
        **{
            name: _rows(s.rmse[name])
            for name in (
                "ml_track",
                "ml_single",
                "sum_range",
                "difference_range",
                "linearised",
                "linearised_track",
            )
        },
        "full_track": _rows(s.full_track),
        "full_track_crlb": _rows(s.full_track_crlb),
        "ml_single_se": s.rmse_se.tolist(),
        "max_distance": s.max_distance.tolist(),
        "max_track_distance": _scalars(s.max_track_distance),
        "gradient": s.gradient.tolist(),
        **{
            name: getattr(s, name).tolist()
            for name in (
                "inconsistent",
                "not_converged",
                "false_minima",
                "false_unflagged",
                "track_inconsistent",
                "track_not_converged",
                "sum_range_unsolvable",
                "difference_range_unsolvable",
            )
        },
    }
    samples = [StudySample(**{k: v[i] for k, v in columns.items()}) for i in range(t.size)]
    return StudyResult(
        runs=s.runs,
        seed=s.seed,
        sigma=request.sigma,
        noise_sigma=s.noise_sigma[0],
        noise_sigma_spread=s.noise_sigma[1],
        samples=samples,
    )


STUDY_FIELDS: FieldMap = {
    "x0": "target.position",
    "v": "target.velocity",
    "x": "target",
    "tx": "transmitter",
    "rx": "receivers",
    "l": "receivers",
    "t": "sample_times",
}
"""Where core's errors on a ``solves.study`` request point (:mod:`plotgate.service.fields`)."""
