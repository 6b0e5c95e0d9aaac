"""The Z-test of Kvasnov: numbers against scipy.stats.norm, wrap-around, beta against
Monte Carlo, the assignment of a hand-made picture, the sequential mode, bad input."""

import numpy as np
import pytest
from scipy import stats

from plotgate.core.errors import NonFiniteError, ParameterError
from plotgate.core.frames import wrap_finite
from plotgate.core.identification import (
    experiment,
    identify_picture,
    required_samples,
    sequential,
    type_two_error,
    z_test,
)
from plotgate.core.identification.simulate import chunk_runs
from plotgate.core.identification.ztest import circular_mean

DEG = np.pi / 180.0


def test_z_p_and_critical_values_are_the_normal_distributions():
    rng = np.random.default_rng(1)
    passive = (30.0 + 0.5 * rng.standard_normal(60)) * DEG
    active = (30.3 + 0.5 * rng.standard_normal(6)) * DEG
    t = z_test(passive, active, sigma=0.5 * DEG, alpha=0.05)
    # the circular mean differs from the arithmetic one by O(spread^3): 1e-5 here
    z = (active.mean() - passive.mean()) / (0.5 * DEG / np.sqrt(6))
    assert t.z[0] == pytest.approx(z, rel=1e-4)
    assert t.p_value[0] == pytest.approx(2 * stats.norm.sf(abs(t.z[0])), rel=1e-12)
    assert t.critical == pytest.approx(stats.norm.ppf(0.975), rel=1e-15)
    assert t.identified == (abs(z) <= stats.norm.ppf(0.975))
    assert (t.n, t.m, t.n_over_m, t.large_population) == (60, 6, 10.0, True)
    t99 = z_test(passive, active, sigma=0.5 * DEG, alpha=0.01)
    assert t99.critical == pytest.approx(2.5758293035489, rel=1e-12)


def test_bearings_either_side_of_north_are_one_object():
    rng = np.random.default_rng(2)
    passive = np.mod((359.9 + 0.4 * rng.standard_normal(50)) * DEG, 2 * np.pi)
    active = np.mod((0.05 + 0.4 * rng.standard_normal(5)) * DEG, 2 * np.pi)
    assert (passive > np.pi).any() and (passive < 1.0).any()  # both sides of 0/360
    t = z_test(passive, active)  # sigma estimated across the wrap
    assert t.identified
    assert t.difference[0] == pytest.approx(0.15 * DEG, abs=0.4 * DEG)
    assert t.sigma[0] == pytest.approx(0.4 * DEG, rel=0.3)
    far = z_test(passive, np.mod((3.0 + 0.4 * rng.standard_normal(5)) * DEG, 2 * np.pi))
    assert not far.identified and far.p_value[0] < 1e-6


def test_elevations_are_tested_at_alpha_over_two():
    rng = np.random.default_rng(3)
    pb, ab = 0.3 * DEG * rng.standard_normal(50), 0.3 * DEG * rng.standard_normal(5)
    pe, ae = (2 + 0.2 * rng.standard_normal(50)) * DEG, (2 + 0.2 * rng.standard_normal(5)) * DEG
    t = z_test(pb, ab, passive_elevation=pe, active_elevation=ae)
    assert t.z.shape == (2,) and t.critical == pytest.approx(stats.norm.ppf(1 - 0.05 / 4))
    assert t.identified
    off = z_test(pb, ab, passive_elevation=pe, active_elevation=ae + 1.0 * DEG)
    assert not off.identified and abs(off.z[1]) > off.critical


def test_type_two_error_formula_against_monte_carlo():
    # normal bearings, n = 50 passive and m active: Z ~ N(delta sqrt(m) / sigma, 1 + m/n);
    # with n = 10^4 >> m the population-mean formula is the same to 0.3 %
    sigma = 1.0 * DEG
    for m, delta, seed in ((5, 0.5, 1), (5, 1.0, 2), (20, 0.75, 3), (20, 1.0, 4)):
        beta = float(type_two_error(delta * DEG, sigma, m, 0.05, n=50))
        mc = experiment(50, m, sigma, delta * DEG, 1.0, 20000, seed=seed, law="normal")
        assert abs(mc.identified - beta) < 4 * mc.standard_error, (m, delta, mc, beta)
    big = float(type_two_error(DEG, sigma, 5, 0.05))
    assert abs(float(type_two_error(DEG, sigma, 5, 0.05, n=10**4)) - big) < 0.003 * big
    same = experiment(50, 5, sigma, 0.0, 1.0, 20000, seed=9, law="normal")
    expected = 2 * stats.norm.sf(stats.norm.ppf(0.975) / np.sqrt(1 + 5 / 50))
    assert abs(same.rejected - expected) < 4 * same.standard_error


def test_required_samples_is_the_smallest_m():
    for delta, beta_max in ((0.5, 0.05), (0.2, 0.01), (2.0, 0.2)):
        m = required_samples(delta * DEG, 1.0 * DEG, 0.05, beta_max)
        assert type_two_error(delta * DEG, DEG, m, 0.05) <= beta_max
        assert m == 1 or type_two_error(delta * DEG, DEG, m - 1, 0.05) > beta_max
    t = z_test(
        np.linspace(-1, 1, 50) * DEG, [0.0, 0.1 * DEG], sigma=DEG, delta=0.5 * DEG, beta_max=0.05
    )
    assert t.m_required == required_samples(0.5 * DEG, DEG, 0.05, 0.05, n=50)
    assert t.beta == pytest.approx(float(type_two_error(0.5 * DEG, DEG, 2, 0.05, n=50)))
    for n in (20, 500):  # with the passive mean's error, more active samples are needed
        m = required_samples(0.5 * DEG, DEG, 0.05, 0.05, n=n)
        assert type_two_error(0.5 * DEG, DEG, m, 0.05, n=n) <= 0.05
        assert type_two_error(0.5 * DEG, DEG, m - 1, 0.05, n=n) > 0.05
        assert m > required_samples(0.5 * DEG, DEG, 0.05, 0.05)


def test_conditions_are_reported_with_numbers():
    rng = np.random.default_rng(4)
    normal = z_test(rng.normal(0, DEG, 200), rng.normal(0, DEG, 40), ratio=10.0)
    assert normal.normal and normal.normality_p[0] > 0.05
    assert normal.n_over_m == 5.0 and not normal.large_population
    lumpy = np.concatenate(
        [rng.normal(-3 * DEG, 0.2 * DEG, 100), rng.normal(3 * DEG, 0.2 * DEG, 100)]
    )
    two_peaks = z_test(lumpy, rng.normal(0, DEG, 5))
    assert not two_peaks.normal and two_peaks.normality_p[0] < 1e-6


def test_a_hand_made_picture_is_assigned_one_to_one():
    rng = np.random.default_rng(5)
    centres_p = np.array([10.0, 20.0, 30.0, 40.0])
    centres_a = np.array([30.0, 10.0, 55.0])  # passive 1 and 3 have no partner; 55 is new
    passive = (centres_p[:, None] + 0.2 * rng.standard_normal((4, 50))) * DEG
    active = [
        (c + 0.2 * rng.standard_normal(k)) * DEG for c, k in zip(centres_a, (5, 3, 8), strict=True)
    ]
    pic = identify_picture(passive, active, sigma=0.2 * DEG)
    assert pic.z.shape == (4, 3)
    assert sorted(pic.pairs.tolist()) == [[0, 1], [2, 0]]
    assert pic.unassigned_passive.tolist() == [1, 3] and pic.unassigned_active.tolist() == [2]
    # the matrix is each pair's own z_test
    t = z_test(passive[2], active[0], sigma=0.2 * DEG)
    assert pic.z[2, 0] == pytest.approx(t.z[0], rel=1e-12)
    # two passive tracks both close to one active one: only the closer is assigned
    twins = (np.array([[10.0], [10.1]]) + 0.1 * rng.standard_normal((2, 50))) * DEG
    pic = identify_picture(twins, [np.full(4, 10.0 * DEG)], sigma=0.2 * DEG)
    assert pic.passes.sum() == 2 and pic.pairs.tolist() == [[0, 0]]


def test_sequential_decisions_are_the_prefix_tests():
    rng = np.random.default_rng(6)
    passive = (45.0 + 0.3 * rng.standard_normal(60)) * DEG
    active = (45.1 + 0.3 * rng.standard_normal(12)) * DEG
    seq = sequential(passive, active, sigma=0.3 * DEG)
    assert seq.m.tolist() == list(range(2, 13))
    for k in (2, 7, 12):
        t = z_test(passive, active[:k], sigma=0.3 * DEG)
        assert seq.z[k - 2] == pytest.approx(t.z[0], rel=1e-9)
        assert seq.identified[k - 2] == t.identified


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"active": [0.1]}, ParameterError, "active"),
        ({"passive": [0.1]}, ParameterError, "passive"),
        ({"sigma": 0.0}, ParameterError, "sigma"),
        ({"sigma": -0.01}, ParameterError, "sigma"),
        ({"alpha": 1.0}, ParameterError, "alpha"),
        ({"alpha": 0.0}, ParameterError, "alpha"),
        ({"active": [0.1, np.nan]}, NonFiniteError, "active"),
        ({"passive": [0.1, np.inf, 0.2]}, NonFiniteError, "passive"),
        ({"passive_elevation": [0.1, 0.2, 0.3]}, ParameterError, "active_elevation"),
        ({"beta_max": 0.05}, ParameterError, "beta_max"),
        ({"delta": 0.0, "beta_max": 0.05}, ParameterError, "delta"),
        # m ~ ((z_a + z_b) sigma / delta)^2 overflows: refused, not an OverflowError
        ({"delta": 1e-300, "beta_max": 0.05}, ParameterError, "beta_max"),
        ({"delta": 1e-6, "beta_max": 0.05}, ParameterError, "beta_max"),
        # angles equal to rounding: a sigma of 5e-324 would make Z infinite
        ({"passive": [0.0, 5e-324, 0.0]}, ParameterError, "sigma"),
    ],
)
def test_bad_input_is_named(kwargs, error, field):
    args = {"passive": [0.1, 0.2, 0.15], "active": [0.12, 0.14]}
    args.update(kwargs)
    with pytest.raises(error) as info:
        z_test(**args)
    assert info.value.field == field


def test_bad_pictures_are_named():
    with pytest.raises(ParameterError) as info:
        identify_picture([[0.1, 0.2], [0.3]], [[0.1, 0.2]])
    assert info.value.field == "passive" and info.value.index == 1
    with pytest.raises(ParameterError) as info:
        identify_picture([[0.1, 0.2]], [[0.1, np.inf]])
    assert info.value.field == "active"
    with pytest.raises(ParameterError) as info:
        identify_picture([[0.1, 0.1]], [[0.1, 0.2]])
    assert info.value.field == "sigma"
    with pytest.raises(ParameterError) as info:
        identify_picture([[0.1, 0.2], [0.0, 1e-300]], [[0.1, 0.2]])
    assert info.value.field == "sigma" and info.value.index == 1


def test_a_ragged_picture_takes_memory_linear_in_its_samples():
    """One long track among many short ones is not padded to a (tracks, longest) matrix
    (issue 24: 9,000 tracks with one of 100,000 samples would have taken 7 GB)."""
    import tracemalloc

    rng = np.random.default_rng(24)
    passive = [rng.normal(0.0, 0.01, 2) for _ in range(499)] + [rng.normal(0.0, 0.01, 20_000)]
    active = [rng.normal(0.0, 0.01, 3) for _ in range(3)]
    tracemalloc.start()
    try:
        pic = identify_picture(passive, active)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10 * 2**20  # padded: 500 x 20,000 x 8 bytes = 80 MB, twice
    padded = np.full((500, 20_000), np.nan)
    for i, track in enumerate(passive):
        padded[i, : track.size] = track
    np.testing.assert_allclose(pic.z, identify_picture(padded, active).z, rtol=1e-12)


def _unchunked(n, m, sigma, separation, width, runs, seed, alpha=0.05, law="uniform"):
    """Kvasnov's experiment as it was before chunks: every run from one default_rng(seed),
    all passive bearings first (the numbers every experiment of one chunk keeps)."""
    rng = np.random.default_rng(seed)
    bearing = np.radians(1.5)
    passive = bearing + sigma * rng.standard_normal((runs, n))
    centre = bearing + separation
    if law == "uniform":
        active = rng.uniform(centre - width / 2, centre + width / 2, (runs, m))
    else:
        active = centre + sigma * rng.standard_normal((runs, m))
    difference = wrap_finite(circular_mean(active, axis=1) - circular_mean(passive, axis=1))
    z = difference * np.sqrt(m) / sigma
    return float(np.mean(np.abs(z) <= stats.norm.ppf(1.0 - alpha / 2.0)))


@pytest.mark.parametrize("law", ["uniform", "normal"])
def test_an_experiment_of_one_chunk_keeps_its_unchunked_numbers(law):
    sigma, width = np.radians(1.0), np.radians(3.0)
    runs = chunk_runs(50, 5)
    assert runs == 18181  # the default request's 10,000 runs are one chunk
    got = experiment(50, 5, sigma, 0.01, width, runs, 8, law=law)
    assert got.identified == _unchunked(50, 5, sigma, 0.01, width, runs, 8, law=law)


def test_chunks_are_cut_by_n_plus_m_alone_and_run_in_any_order_alike(monkeypatch):
    import plotgate.core.identification.simulate as module

    def backwards(function, items):
        return [function(x) for x in reversed(list(items))][::-1]

    monkeypatch.setattr(module, "SAMPLES_PER_CHUNK", 55 * 1000)  # 1,000 runs a chunk
    args = (50, 5, np.radians(1.0), 0.0, np.radians(3.0), 4321, 6)
    spread = experiment(*args, mapper=backwards)
    assert spread == experiment(*args)
    monkeypatch.setattr(module, "SAMPLES_PER_CHUNK", 55 * 10_000)  # one chunk: another stream
    assert experiment(*args).identified == _unchunked(*args)
    assert experiment(*args) != spread
