"""The accuracy study: its curves are the solvers' own answers, its bounds the bounds'.

The study's numbers are recomputed independently: curves 3 and 4 by calling the public
solvers on the same noise (the documented ``default_rng(seed)`` draw), curve 2 and the
full-track bound by :func:`trajectory_crlb` per prefix (a different code path from the
study's cumulative sums), and the statistical claims (RMSE of an efficient estimator
near the CRLB) within stated Monte Carlo tolerances.
"""

import numpy as np
import pytest

from plotgate.core.errors import GeometryError, ParameterError
from plotgate.core.multistatic import (
    accuracy_study,
    crlb,
    ml_solve,
    platform_positions,
    range_sums,
    trajectory_crlb,
    trajectory_solve,
)
from plotgate.core.multistatic.study import CURVES
from tests.support.identical import assert_identical

SIGMA = 0.5
T = 0.5 * np.arange(12)
TX = platform_positions([9900.0, 1000.0], [-5.0, 8.66], T)[:, None, :]
RX = platform_positions([[150.0, -500.0], [600.0, 1000.0], [150.0, 2500.0]], [5.0, 8.66], T)
X0, V = np.array([5000.0, 500.0]), np.array([0.0, 80.0])
RUNS, SEED = 400, 7


@pytest.fixture(scope="module")
def study():
    return accuracy_study(T, TX, RX, X0, V, SIGMA, RUNS, SEED)


def _noisy():
    x = X0 + (T - T[0])[:, None] * V
    clean = range_sums(x, TX, RX)
    return x, clean + SIGMA * np.random.default_rng(SEED).standard_normal((RUNS, 12, 3))


def test_curves_are_the_public_solvers_on_the_same_noise(study):
    x, L = _noisy()
    tx = np.broadcast_to(TX, (RUNS, 12, 3, 2)).reshape(-1, 3, 2)
    rx = np.broadcast_to(RX, (RUNS, 12, 3, 2)).reshape(-1, 3, 2)
    single = ml_solve(L.reshape(-1, 3), tx, rx, SIGMA).x.reshape(RUNS, 12, 2)
    np.testing.assert_allclose(
        study.rmse["ml_single"], np.sqrt(np.mean((single - x) ** 2, axis=0)), rtol=1e-9
    )
    i = 7  # the track of samples 0..7, at t_7, from trajectory_solve's own start
    track = trajectory_solve(L[:, : i + 1], T[: i + 1], TX[: i + 1], RX[: i + 1], SIGMA)
    pos = track.at(T[i])[0][:, 0]
    np.testing.assert_allclose(
        study.rmse["ml_track"][i], np.sqrt(np.mean((pos - x[i]) ** 2, axis=0)), rtol=1e-6
    )


def test_bounds_are_the_bound_functions(study):
    x = X0 + (T - T[0])[:, None] * V
    np.testing.assert_allclose(study.crlb, crlb(x, TX, RX, SIGMA).sigma, rtol=1e-12)
    for i in (1, 5, 11):
        acc = trajectory_crlb(X0, V, T[: i + 1], TX[: i + 1], RX[: i + 1], SIGMA)
        np.testing.assert_allclose(study.crlb_accumulated[i], acc.position_sigma[-1], rtol=1e-9)
    full = trajectory_crlb(X0, V, T, TX, RX, SIGMA)
    np.testing.assert_allclose(study.full_track_crlb, full.position_sigma, rtol=1e-9)
    np.testing.assert_allclose(study.crlb_accumulated[0], study.crlb[0])


def test_efficient_estimators_sit_on_their_bounds(study):
    # a per-axis RMSE from 400 runs has a relative standard error of 1/sqrt(800) = 3.5 %;
    # 15 % is over 4 standard errors
    tot = lambda a: np.sqrt(np.sum(a * a, axis=-1))  # noqa: E731
    for name, bound in (
        ("ml_single", study.crlb),
        ("linearised", study.crlb),
        ("difference_range", study.crlb_difference),
    ):
        ratio = tot(study.rmse[name]) / tot(bound)
        assert np.all(np.abs(ratio - 1.0) < 0.15), (name, ratio)
    ratio = tot(study.rmse["ml_track"][1:]) / tot(study.crlb_accumulated[1:])
    assert np.all(np.abs(ratio - 1.0) < 0.15), ratio
    # paired with the linearised estimator on the same noise the Monte Carlo noise cancels
    paired = tot(study.rmse["ml_single"]) / tot(study.rmse["linearised"])
    assert np.all(np.abs(paired - 1.0) < 0.03), paired
    assert study.max_distance.max() < 10.0 and study.false_unflagged.sum() == 0
    assert np.isnan(study.rmse["ml_track"][0]).all()
    assert abs(study.noise_sigma[0] - SIGMA) < 0.05 * SIGMA


def test_same_seed_same_study_and_tracks_can_be_skipped(study):
    quick = accuracy_study(T, TX, RX, X0, V, SIGMA, RUNS, SEED, tracks=False)
    for name in CURVES[1:]:
        np.testing.assert_array_equal(quick.rmse[name], study.rmse[name])
    assert np.isnan(quick.rmse["ml_track"]).all() and np.isnan(quick.full_track).all()
    assert (quick.track_inconsistent == 0).all()


def test_the_gradient_vanishes_where_the_target_crosses_a_baseline():
    # fixed platforms: the target crosses the tx - rx_2 baseline (y = 1000) at t = 6.25 s
    t = np.arange(0.0, 12.0, 0.25)
    rx = np.array([[0.0, -3000.0], [0.0, 1000.0], [0.0, 5000.0]])
    s = accuracy_study(
        t, [10000.0, 1000.0], rx, [5000.0, 500.0], [0.0, 80.0], SIGMA, 50, 1, tracks=False
    )
    assert np.argmin(s.gradient[:, 1]) == 25 and s.gradient[25, 1] < 1e-9
    assert s.gradient[:, [0, 2]].min() > 0.1


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"runs": 1}, ParameterError, "runs"),
        ({"runs": 2.5}, ParameterError, "runs"),
        ({"seed": -1}, ParameterError, "seed"),
        ({"t": T[::-1]}, ParameterError, "t"),
        ({"sigma": 0.0}, ParameterError, "sigma"),
        ({"x0": [1.0, 2.0, 3.0]}, ParameterError, "v"),
        ({"x0": [150.0, -500.0], "v": [0.0, 0.0]}, GeometryError, "x"),
        ({"rx": RX[:, :2]}, ParameterError, "rx"),
    ],
)
def test_bad_input_is_refused(kwargs, error, field):
    args = {"t": T, "tx": TX, "rx": RX, "x0": X0, "v": V, "sigma": SIGMA, "runs": 10, "seed": 1}
    args.update(kwargs)
    with pytest.raises(error) as info:
        accuracy_study(**args)
    assert info.value.field == field


def test_its_chunks_give_the_one_chunk_answer_bit_for_bit(study, monkeypatch):
    """400 runs are 4 chunks (run backwards by a map of our own); one chunk of all the
    runs is the study before it was chunked: the same noise, every solver on every run."""
    import plotgate.core.multistatic.study as module

    def backwards(function, items):
        return [function(x) for x in reversed(list(items))][::-1]

    assert RUNS // module.STUDY_CHUNK_RUNS == 4
    spread = accuracy_study(T, TX, RX, X0, V, SIGMA, RUNS, SEED, mapper=backwards)
    monkeypatch.setattr(module, "STUDY_CHUNK_RUNS", RUNS)
    assert_identical(spread, study)
    assert_identical(accuracy_study(T, TX, RX, X0, V, SIGMA, RUNS, SEED), study)


def test_a_short_last_chunk_and_no_tracks_are_chunked_alike(monkeypatch):
    import plotgate.core.multistatic.study as module

    runs = module.STUDY_CHUNK_RUNS + 7
    spread = accuracy_study(T, TX, RX, X0, V, SIGMA, runs, 3, tracks=False)
    monkeypatch.setattr(module, "STUDY_CHUNK_RUNS", runs)
    assert_identical(spread, accuracy_study(T, TX, RX, X0, V, SIGMA, runs, 3, tracks=False))
