"""Tests of what every gate shares (core.gates): GateResult, batching, purity, errors."""

import contextlib
import dataclasses
from unittest import mock

import numpy as np
import pytest
from gate_helpers import (
    assert_kernel_matches_reference,
    combined_inputs,
    polar_inputs,
    random_spd,
)

from plotgate.core import (
    CombinedGate,
    CovarianceError,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    GateResult,
    GeometryError,
    NonFiniteError,
    ParameterError,
    RectangularGate,
    RingGate,
    SectorGate,
    check_covariance,
    expansion_coefficient,
    gate_threshold,
)
from plotgate.core.gates import thresholds
from plotgate.core.validation import first_invalid_covariance, valid_covariances

# ---------------------------------------------------------------- broadcasting and purity


def test_one_first_mark_against_many_candidates_equals_tiled_input():
    rng = np.random.default_rng(109)
    _, _, z2, P2 = combined_inputs(rng, 200)
    z1 = z2[0] + 10.0
    P1 = random_spd(rng, 1, 40.0)[0]
    tiled = CombinedGate(30.0, 100.0, 0.9).test(
        np.tile(z1, (200, 1)), np.tile(P1, (200, 1, 1)), z2, P2, 5.0
    )
    broadcast = CombinedGate(30.0, 100.0, 0.9).test(z1, P1, z2, P2, 5.0)
    for field in ("inside", "statistic", "stage"):
        np.testing.assert_array_equal(getattr(broadcast, field), getattr(tiled, field))
    ring = RingGate(30.0, 100.0).test(z1, z2, 5.0)
    np.testing.assert_array_equal(
        ring.inside, RingGate(30.0, 100.0).test(np.tile(z1, (200, 1)), z2, 5.0).inside
    )
    ellipse = EllipseGate(0.9).test(z2, z1, P1)
    np.testing.assert_array_equal(
        ellipse.statistic, EllipseGate(0.9).test(z2, np.tile(z1, (200, 1)), P1).statistic
    )


@pytest.mark.parametrize(
    "call",
    [
        lambda: RingGate(20.0, 500.0).test([0.0, 0.0], [300.0, 400.0], 5.0),
        lambda: CombinedGate(0.0, 9.0, 0.9).test(
            [0.0, 0.0], np.eye(2), [3.0, 4.0], np.eye(2), 1.0
        ),
        lambda: EllipseGate(0.9).test([1.0, 1.0], [0.0, 0.0], np.eye(2)),
        lambda: ExpandedGate(100.0, 0.9).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 0.001),
        lambda: RectangularGate(3.0).test([1.0, 1.0], [0.0, 0.0], 1.0, 1.0),
        lambda: SectorGate(3.0, 3.0).test(1e3, 0.1, 1e3, 0.1, 1.0, 1e-3, 1.0, 1e-3),
        lambda: FirstAssociationGate(5.0, 3.0, 3.0).test(
            1e3, 0.1, 1e3, 0.1, 1.0, 1.0, 1e-3, 1.0, 1e-3
        ),
    ],
    ids=["ring", "combined", "ellipse", "expanded", "rectangular", "sector", "first"],
)
def test_unbatched_input_gives_one_pair(call):
    res = call()
    assert isinstance(res, GateResult)
    assert res.inside.shape == res.statistic.shape == (1,)
    assert isinstance(res.threshold, float)
    assert res.inside.tolist() == [True]


@pytest.mark.parametrize(
    "call",
    [
        lambda e, E, o: RingGate(0.0, 1.0).test([0.0, 0.0], e, 1.0),
        lambda e, E, o: CombinedGate(0.0, 1.0, 0.9).test([0.0, 0.0], np.eye(2), e, E, 1.0),
        lambda e, E, o: EllipseGate(0.9).test(e, [0.0, 0.0], E),
        lambda e, E, o: ExpandedGate(1.0, 0.9).test([0.0, 1.0], e, 1.0, 1.0, 0.1),
        lambda e, E, o: RectangularGate(3.0).test(e, [0.0, 0.0], 1.0, 1.0),
        lambda e, E, o: SectorGate(3.0, 3.0).test(o, o, 1.0, 0.0, 1.0, 0.1, 1.0, 0.1),
        lambda e, E, o: FirstAssociationGate(1.0, 3.0, 3.0).test(
            1.0, 0.0, o, o, 1.0, 1.0, 0.1, 1.0, 0.1
        ),
    ],
    ids=["ring", "combined", "ellipse", "expanded", "rectangular", "sector", "first"],
)
def test_no_candidates_gives_empty_result(call):
    res = call(np.empty((0, 2)), np.empty((0, 2, 2)), np.empty(0))
    assert res.inside.shape == res.statistic.shape == (0,)


def test_gate_result_is_frozen():
    res = RingGate(0.0, 2.0).test([0.0, 0.0], [1.0, 0.0], 1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.threshold = 3.0


def test_gates_accept_read_only_inputs_and_leave_them_unchanged():
    rng = np.random.default_rng(111)
    inputs = combined_inputs(rng, 50)
    saved = [a.copy() for a in inputs]
    for a in inputs:
        a.flags.writeable = False
    z1, P1, z2, P2 = inputs
    CombinedGate(30.0, 100.0, 0.9).test(z1, P1, z2, P2, 5.0)
    EllipseGate(0.9).test(z2, z1, P1)
    ExpandedGate(100.0, 0.9).test(z1, z2, 5.0, 10.0, 0.001)
    for a, b in zip(inputs, saved, strict=True):
        np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------- validation errors


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (
            lambda: ExpandedGate(100.0, 0.9).test(
                [0.0, 1e4], [[0.0, 1e4]] * 3, 5.0, [10.0, -1.0, 2.0], 0.001
            ),
            ParameterError,
            r"^sigma_r\[1\]: must be positive",
        ),
        (
            lambda: ExpandedGate(100.0, 0.9).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 0.0),
            ParameterError,
            r"^sigma_az: must be positive, got 0.0",
        ),
        (
            lambda: ExpandedGate(-1.0, 0.9).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 1e-3),
            ParameterError,
            r"^v_max: must be non-negative",
        ),
        (
            lambda: ExpandedGate(100.0, 1.2).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 1e-3),
            ParameterError,
            r"^p: must lie in the open interval",
        ),
        (
            lambda: ExpandedGate(100.0, [0.9, 0.9]).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 1e-3),
            ParameterError,
            r"^p: must be a scalar",
        ),
        (
            lambda: ExpandedGate(100.0, 0.9).test(
                [[0.0, 1e4], [5.0, 5.0]], [0.0, 1e4], 5.0, 10.0, 1e-3, sensor=[5.0, 5.0]
            ),
            GeometryError,
            r"^z1\[1\]: is at the sensor",
        ),
        (
            lambda: EllipseGate(0.9).test([0.0, 1.0], [0.0, 0.0], np.zeros((2, 2))),
            CovarianceError,
            r"^S: is not positive definite",
        ),
        # axis ratio 1e7 > 1e6: rotating it would lose the small axis to rounding
        (
            lambda: EllipseGate(0.9).test(
                [[0.0, 1.0]] * 2, [0.0, 0.0], [np.eye(2), np.diag([1e14, 1.0])]
            ),
            CovarianceError,
            r"^S\[1\]: is numerically singular: eigenvalues 1 and 1e\+14",
        ),
        (
            lambda: RectangularGate(0.0).test([0.0, 1.0], [0.0, 0.0], 1.0, 1.0),
            ParameterError,
            r"^k: must be positive, got 0.0",
        ),
        (
            lambda: RectangularGate(3.0).test([0.0, 1.0], [0.0, 0.0], 1.0, [1.0, np.nan]),
            NonFiniteError,
            r"^sigma_y\[1\]: must be finite, got nan",
        ),
        (
            lambda: SectorGate(3.0, 3.0).test(-1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3),
            ParameterError,
            r"^r: must be non-negative, got -1.0",
        ),
        (
            lambda: SectorGate(3.0, 3.0).test(1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, -1e-3),
            ParameterError,
            r"^sigma_az_pred: must be positive",
        ),
        (
            lambda: SectorGate(3.0, 0.0).test(1.0, 0.0, 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3),
            ParameterError,
            r"^K_az: must be positive",
        ),
        (
            lambda: SectorGate(3.0, 3.0).test(
                np.ones(3), np.zeros(2), 1.0, 0.0, 1.0, 1e-3, 1.0, 1e-3
            ),
            ParameterError,
            r"^az: has batch length 2 but r has 3",
        ),
        (
            lambda: FirstAssociationGate(5.0, 3.0, 3.0).test(
                1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1e-3, 1.0, 1e-3
            ),
            ParameterError,
            r"^tau: must be positive",
        ),
        (
            lambda: FirstAssociationGate(5.0, -3.0, 3.0).test(
                1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1e-3, 1.0, 1e-3
            ),
            ParameterError,
            r"^K_R: must be positive",
        ),
        (
            lambda: RingGate(3.0, 2.0).test([0.0, 0.0], [1.0, 1.0], 1.0),
            ParameterError,
            r"^v_min: v_min \(3.0\) exceeds v_max \(2.0\)",
        ),
    ],
    ids=[
        "sigma_r-row",
        "sigma_az-zero",
        "v_max-negative",
        "p>1",
        "p-array",
        "z1-at-sensor",
        "singular-S",
        "ill-conditioned-S",
        "k=0",
        "nan-sigma_y",
        "negative-range",
        "sigma_az_pred",
        "K_az=0",
        "sector-lengths",
        "first-tau",
        "first-K_R",
        "ring-speeds",
    ],
)
def test_gate_validation_errors(call, error, message):
    with pytest.raises(error, match=message):
        call()


# ---------------------------------------------------------------- cached scalar thresholds


@contextlib.contextmanager
def computations():
    """Count the chi-square quantiles and the expansion coefficients actually computed."""
    counts = {"chi2": 0, "expansion": 0}
    ppf, log1p = thresholds.special.gammaincinv, thresholds.np.log1p

    def counted_ppf(*args, **kwargs):
        counts["chi2"] += 1
        return ppf(*args, **kwargs)

    def counted_log1p(*args, **kwargs):
        counts["expansion"] += 1
        return log1p(*args, **kwargs)

    with (
        mock.patch.object(thresholds.special, "gammaincinv", counted_ppf),
        mock.patch.object(thresholds.np, "log1p", counted_log1p),
    ):
        yield counts


@pytest.mark.parametrize("P_G", [1e-9, 0.5, 0.9, 0.95, 0.99, 1.0 - 1e-12])
def test_cached_thresholds_equal_the_uncached_array_values_exactly(P_G):
    for _ in range(2):  # computed, then looked up
        assert gate_threshold(P_G, 2) == gate_threshold(np.array([P_G]), 2)[0]
        assert expansion_coefficient(P_G) == expansion_coefficient(np.array([P_G]))[0]
        combined = CombinedGate(0.0, 9.0, P_G).test(
            [0.0, 0.0], np.eye(2), [1.0, 0.0], np.eye(2), 1.0
        )
        ellipse = EllipseGate(P_G).test([1.0, 0.0], [0.0, 0.0], np.eye(2))
        assert combined.threshold == ellipse.threshold == gate_threshold(P_G)


def test_each_probability_is_computed_once():
    P_G = 0.9012345  # a value no other test uses, so its first call computes it
    with computations() as counts:
        for value in (P_G, np.float64(P_G), np.array(P_G), P_G):
            EllipseGate(value).test([1.0, 0.0], [0.0, 0.0], np.eye(2))
            ExpandedGate(100.0, value).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 0.001)
    assert counts == {"chi2": 1, "expansion": 1}


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: EllipseGate(1.0).test([1.0, 0.0], [0.0, 0.0], np.eye(2)),
            r"^P_G: must lie in the open interval \(0, 1\), got 1.0$",
        ),
        (
            lambda: EllipseGate(np.array([0.9])).test([1.0, 0.0], [0.0, 0.0], np.eye(2)),
            r"^P_G: must be a scalar, got shape \(1,\)$",
        ),
        (
            lambda: CombinedGate(0.0, 9.0, None).test(
                [0.0, 0.0], np.eye(2), [1.0, 0.0], np.eye(2), 1.0
            ),
            r"^P_G: must lie in the open interval \(0, 1\), got nan$",
        ),
        (
            lambda: ExpandedGate(100.0, True).test([0.0, 1e4], [0.0, 1e4], 5.0, 10.0, 0.001),
            r"^p: must lie in the open interval \(0, 1\), got 1.0$",
        ),
    ],
    ids=["P_G=1", "P_G-array", "P_G-None", "p-True"],
)
def test_probabilities_are_validated_before_the_cache(call, message):
    with computations() as counts:
        for _ in range(2):
            with pytest.raises(ParameterError, match=message):
                call()
    assert counts == {"chi2": 0, "expansion": 0}


def test_public_thresholds_take_arrays_uncached():
    assert not hasattr(gate_threshold, "cache_info")
    assert not hasattr(expansion_coefficient, "cache_info")
    P_G = np.array([0.9, 0.99])
    for p in P_G:  # the scalars are looked up below
        gate_threshold(p), expansion_coefficient(p)
    with computations() as counts:
        for _ in range(2):
            np.testing.assert_array_equal(gate_threshold(P_G), [gate_threshold(p) for p in P_G])
            np.testing.assert_array_equal(
                expansion_coefficient(P_G), [expansion_coefficient(p) for p in P_G]
            )
    assert counts["chi2"] == counts["expansion"] == 2  # the arrays, each time; scalars cached


# ---------------------------------------------------------------- compiled kernels


def ellipse_inputs(rng, n):
    z_pred = rng.uniform(-1e4, 1e4, (n, 2))
    S = random_spd(rng, n, 40.0)
    z = z_pred + rng.normal(0.0, 80.0, (n, 2))
    z[:5] = z_pred[:5]  # nu = 0
    return z, z_pred, S


def ellipse_calls(z, z_pred, S):
    gate = EllipseGate(0.9)
    return gate.test(z, z_pred, S), gate.test_reference(z, z_pred, S)


def combined_calls(z1, P1, z2, P2):
    gate = CombinedGate(10.0, 50.0, 0.9)
    return gate.test(z1, P1, z2, P2, 5.0), gate.test_reference(z1, P1, z2, P2, 5.0)


def sector_calls(r, az, r_pred, az_pred, sigmas):
    gate = SectorGate(3.0, 2.5)
    args = (r, az, r_pred, az_pred, *sigmas)
    return gate.test(*args), gate.test_reference(*args)


def first_association_calls(r1, az1, r2, az2, sigmas):
    gate = FirstAssociationGate(10.0, 3.0, 2.5)
    args = (r1, az1, r2, az2, 5.0, *sigmas)
    return gate.test(*args), gate.test_reference(*args)


def all_kernel_calls(rng, n):
    polar = polar_inputs(rng, n)
    return [
        ellipse_calls(*ellipse_inputs(rng, n)),
        combined_calls(*combined_inputs(rng, n)),
        sector_calls(*polar),
        first_association_calls(*polar),
    ]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_kernels_match_the_numpy_references_on_random_batches(seed):
    rng = np.random.default_rng(seed)
    for result, reference in all_kernel_calls(rng, 3000):
        assert_kernel_matches_reference(result, reference)
        assert 0 < reference.inside.sum() < 3000


def test_combined_kernel_matches_on_the_ring_edges_and_at_z1():
    z1 = np.zeros((6, 2))
    z2 = np.array([[0.0, 0.0], [50.0, 0.0], [250.0, 0.0], [0.0, 250.0], [1e-160, 0.0], [3.0, 4.0]])
    P = np.diag([1e4, 4e4])
    result, reference = combined_calls(z1, P, z2, P)
    assert_kernel_matches_reference(result, reference)
    assert result.stage.tolist() == [2, 1, 1, 1, 2, 2]


@pytest.mark.parametrize("n", [0, 1, 2, 40000])
def test_kernels_match_on_every_batch_size(n):
    for result, reference in all_kernel_calls(np.random.default_rng(n), n):
        assert_kernel_matches_reference(result, reference)
        assert result.statistic.shape == (n,)


def test_kernels_match_on_unbatched_and_shared_inputs():
    rng = np.random.default_rng(5)
    z, z_pred, S = ellipse_inputs(rng, 20)
    for args in [
        (z[0], z_pred[0], S[0]),
        (z, z_pred[0], S[0]),
        (z[0], z_pred, S),
        (z, z_pred, S[3]),
    ]:
        assert_kernel_matches_reference(*ellipse_calls(*args))
    z1, P1, z2, P2 = combined_inputs(rng, 20)
    for args in [(z1[0], P1[0], z2[0], P2[0]), (z1[0], P1[0], z2, P2), (z1, P1, z2[0], P2[0])]:
        assert_kernel_matches_reference(*combined_calls(*args))
    r1, az1, r2, az2, sigmas = polar_inputs(rng, 20)
    shared = [s[0] for s in sigmas]
    for args in [
        (r1[30 % 20], az1[0], r2, az2, shared),
        (r1, az1, r2[0], az2[0], sigmas),
        (float(r1[7]), float(az1[7]), float(r2[7]), float(az2[7]), [float(s) for s in shared]),
    ]:
        assert_kernel_matches_reference(*sector_calls(*args))
        assert_kernel_matches_reference(*first_association_calls(*args))


def bad_row(x, row, value):
    y = np.array(x, dtype=float)
    y[row] = value
    return y


@pytest.mark.parametrize(
    ("gate", "args", "field"),
    [
        (EllipseGate(0.9), lambda z, zp, S: (z, zp, bad_row(S, 7, [[1.0, 2.0], [2.0, 1.0]])), "S"),
        (EllipseGate(0.9), lambda z, zp, S: (z, zp, bad_row(S, 7, [[1.0, 0.0], [0.1, 1.0]])), "S"),
        (
            EllipseGate(0.9),
            lambda z, zp, S: (z, zp, bad_row(S, 7, [[1.0, 0.0], [0.0, 1e-13]])),
            "S",
        ),
        (EllipseGate(0.9), lambda z, zp, S: (bad_row(z, 7, np.nan), zp, S), "z"),
        (EllipseGate(0.9), lambda z, zp, S: (z, bad_row(zp, 7, np.inf), S), "z_pred"),
        (EllipseGate(0.9), lambda z, zp, S: (bad_row(z, 7, np.nan), zp[:3], S), "z"),
    ],
)
def test_ellipse_kernel_errors_are_the_references(gate, args, field):
    inputs = args(*ellipse_inputs(np.random.default_rng(6), 20))
    with pytest.raises(Exception) as expected:
        gate.test_reference(*inputs)
    with pytest.raises(type(expected.value)) as raised:
        gate.test(*inputs)
    assert raised.value.field == expected.value.field == field
    assert str(raised.value) == str(expected.value)
    assert raised.value.index == expected.value.index


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda z1, P1, z2, P2: (z1, P1, z2, bad_row(P2, 9, [[1.0, 2.0], [2.0, 1.0]])), "P2"),
        (lambda z1, P1, z2, P2: (z1, bad_row(P1, 9, np.nan), z2, P2), "P1"),
        (lambda z1, P1, z2, P2: (z1, P1, bad_row(z2, 9, -np.inf), P2), "z2"),
    ],
)
def test_combined_kernel_errors_are_the_references(change, field):
    gate = CombinedGate(10.0, 50.0, 0.9)
    inputs = change(*combined_inputs(np.random.default_rng(7), 20))
    with pytest.raises(Exception) as expected:
        gate.test_reference(*inputs, 5.0)
    with pytest.raises(type(expected.value)) as raised:
        gate.test(*inputs, 5.0)
    assert raised.value.field == expected.value.field == field
    assert str(raised.value) == str(expected.value)


@pytest.mark.parametrize(
    ("position", "value", "field"),
    [(0, -1.0, "r1"), (2, np.nan, "r2"), (3, np.inf, "az2"), (5, 0.0, "sigma_az1")],
)
def test_polar_kernel_errors_are_the_references(position, value, field):
    r1, az1, r2, az2, sigmas = polar_inputs(np.random.default_rng(8), 20)
    values = [r1, az1, r2, az2, *sigmas]
    values[position] = bad_row(values[position], 11, value)
    r1, az1, r2, az2, *sigmas = values
    gate = FirstAssociationGate(10.0, 3.0, 2.5)
    args = (r1, az1, r2, az2, 5.0, *sigmas)
    with pytest.raises(Exception) as expected:
        gate.test_reference(*args)
    with pytest.raises(type(expected.value)) as raised:
        gate.test(*args)
    assert raised.value.field == expected.value.field == field
    assert str(raised.value) == str(expected.value)
    sector = SectorGate(3.0, 2.5)
    sector_field = {"r1": "r", "r2": "r_pred", "az2": "az_pred", "sigma_az1": "sigma_az"}[field]
    if sector_field == "r_pred":  # the sector gate allows any predicted range sign, not NaN
        values[2] = bad_row(values[2], 11, np.nan)
    args = (values[0], values[1], values[2], values[3], *values[4:])
    with pytest.raises(Exception) as expected:
        sector.test_reference(*args)
    with pytest.raises(type(expected.value)) as raised:
        sector.test(*args)
    assert raised.value.field == expected.value.field == sector_field
    assert str(raised.value) == str(expected.value)


def test_kernels_hand_an_overflowing_difference_to_the_reference():
    z, z_pred, S = np.array([[1e308, 0.0]]), np.array([[-1e308, 0.0]]), np.eye(2)
    with np.errstate(over="ignore", invalid="ignore"):  # nu overflows to inf, 0 * inf
        result, reference = ellipse_calls(z, z_pred, S)
    assert_kernel_matches_reference(result, reference)
    assert np.isnan(result.statistic[0]) and not result.inside[0]


def covariance_edge_rows():
    """Rows on each side of every covariance check, and non-finite ones."""
    c = 1e12
    return np.array(
        [
            [[4.0, 1.0], [1.0, 3.0]],
            [[1.0, 2.0], [2.0, 1.0]],  # indefinite
            [[-1.0, 0.0], [0.0, -1.0]],  # negative definite
            [[0.0, 0.0], [0.0, 1.0]],  # singular
            [[1.0, 0.5 + 1e-10], [0.5, 1.0]],  # asymmetric within the tolerance
            [[1.0, 0.5 + 1e-8], [0.5, 1.0]],  # asymmetric beyond it
            [[1.0, 0.0], [0.0, 4.0 / c]],  # condition near the limit: det c = 4 ~ trace^2
            [[1.0, 0.0], [0.0, 3.0 / c]],
            [[1.0, 0.0], [0.0, 5.0 / c]],
            [[1e-300, 0.0], [0.0, 1e-300]],  # det underflows to 0
            [[np.nan, 0.0], [0.0, 1.0]],
            [[1.0, np.inf], [np.inf, 1.0]],
            [[1e200, 0.0], [0.0, 1e200]],  # det overflows to inf
        ]
    )


def test_covariance_kernel_matches_the_numpy_check_row_by_row():
    rng = np.random.default_rng(9)
    random = random_spd(rng, 2000, 30.0)
    random[::7, 0, 1] += rng.normal(0.0, 1e-6, random[::7].shape[0])  # some asymmetric
    random[::11, 1, 1] = -random[::11, 1, 1]  # some indefinite
    P = np.concatenate([covariance_edge_rows(), random])
    finite = np.isfinite(P).all(axis=(1, 2))
    with np.errstate(invalid="ignore", over="ignore"):
        expected = finite & valid_covariances(P)
    rows = P.reshape(-1, 4)
    got = np.array([first_invalid_covariance(rows[i : i + 1]) == -1 for i in range(len(P))])
    np.testing.assert_array_equal(got, expected)
    assert 0 < expected.sum() < len(P)
    assert first_invalid_covariance(rows) == np.argmin(expected)
    assert first_invalid_covariance(rows[expected]) == -1
    assert first_invalid_covariance(rows[:0]) == -1


@pytest.mark.parametrize("row", range(13))
def test_covariance_errors_name_the_bad_row(row):
    edge = covariance_edge_rows()[row]
    P = random_spd(np.random.default_rng(10), 10, 30.0)
    P[6] = edge
    with np.errstate(invalid="ignore", over="ignore"):
        valid = np.isfinite(edge).all() and bool(valid_covariances(edge))
    if valid:
        np.testing.assert_array_equal(check_covariance(P, "R"), P)
        return
    error = NonFiniteError if not np.isfinite(edge).all() else CovarianceError
    with pytest.raises(error) as raised:
        check_covariance(P, "R")
    assert raised.value.field == "R" and raised.value.index == 6
    assert raised.value.reason.endswith(f"{edge.tolist()}")


def test_a_non_finite_covariance_is_reported_before_an_earlier_invalid_one():
    P = random_spd(np.random.default_rng(11), 10, 30.0)
    P[2] = [[1.0, 2.0], [2.0, 1.0]]
    P[5, 0, 0] = np.nan
    with pytest.raises(NonFiniteError) as raised:
        check_covariance(P, "R")
    assert raised.value.index == 5
