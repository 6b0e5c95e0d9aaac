"""Tests of core.multistatic.model (Fadeev et al., eq. 1): range sums, Jacobian, input checks."""

import numpy as np
import pytest

from plotgate.core.errors import GeometryError, NonFiniteError, ParameterError, PlotgateError
from plotgate.core.multistatic import (
    Problem,
    platform_positions,
    range_sum_jacobian,
    range_sums,
    validate_problem,
)
from plotgate.core.multistatic.model import BASELINE_SIGMAS, copy_into

TX2 = [0.0, 0.0]
RX2 = [[6000.0, 0.0], [0.0, 8000.0], [7000.0, 9000.0]]


def random_scene(rng, n, d, p):
    """Transmitter near the origin, P receivers ~10 km away, targets within 20 km."""
    tx = rng.uniform(-2000.0, 2000.0, (n, p, d))
    tx[:] = tx[:, :1]
    rx = tx + rng.uniform(-10000.0, 10000.0, (n, p, d))
    x = rng.uniform(-14000.0, 14000.0, (n, d))
    return x, tx, rx


def scalar_range_sum(x, tx, rx):
    return float(np.linalg.norm(np.subtract(x, rx)) + np.linalg.norm(np.subtract(x, tx)))


# ---------------------------------------------------------------- platform_positions


def test_platform_positions_constant_velocity():
    initial = [[0.0, 0.0], [1000.0, 500.0]]
    velocity = [[10.0, 0.0], [0.0, -5.0]]
    t = np.array([0.0, 1.0, 10.0])
    pos = platform_positions(initial, velocity, t)
    assert pos.shape == (3, 2, 2)
    np.testing.assert_allclose(pos[2], [[100.0, 0.0], [1000.0, 450.0]])
    for i, ti in enumerate(t):
        np.testing.assert_allclose(pos[i], np.add(initial, np.multiply(velocity, ti)))


def test_platform_positions_broadcast_3d_and_scalar_time():
    initial = np.zeros((4, 3, 3))
    pos = platform_positions(initial, [1.0, 2.0, 3.0], np.arange(5.0))
    assert pos.shape == (5, 4, 3, 3)
    np.testing.assert_allclose(pos[4, 2, 1], [4.0, 8.0, 12.0])
    np.testing.assert_allclose(platform_positions([1.0, 1.0], [2.0, 0.0], 3.0), [7.0, 1.0])


@pytest.mark.parametrize(
    ("initial", "velocity", "t", "field", "error"),
    [
        ([0.0, 0.0], [1.0, 0.0, 0.0], [0.0], "velocity", ParameterError),
        ([0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0], "initial", ParameterError),
        ([[0.0, 0.0]] * 2, [[1.0, 0.0]] * 3, [0.0], "velocity", ParameterError),
        ([0.0, 0.0], [1.0, 0.0], [[0.0, 1.0]], "t", ParameterError),
        ([0.0, np.nan], [1.0, 0.0], [0.0], "initial", NonFiniteError),
        ([0.0, 0.0], [1.0, 0.0], [0.0, np.inf], "t", NonFiniteError),
    ],
)
def test_platform_positions_rejects(initial, velocity, t, field, error):
    with pytest.raises(error) as info:
        platform_positions(initial, velocity, t)
    assert info.value.field == field


# ---------------------------------------------------------------- range sums


def test_range_sums_known_values_and_shapes():
    ls = range_sums([3000.0, 4000.0], TX2, RX2)
    assert ls.shape == (3,)
    np.testing.assert_allclose(
        ls, [5000.0 + 5000.0, 5000.0 + 5000.0, 5000.0 + np.hypot(4000.0, 5000.0)]
    )
    # x (N, D) against unbatched platforms; a single transmitter given as (D,).
    x = np.array([[3000.0, 4000.0], [0.0, 0.0]])
    l2 = range_sums(x, TX2, RX2)
    assert l2.shape == (2, 3)
    np.testing.assert_allclose(l2[0], ls)
    np.testing.assert_allclose(l2[1], np.linalg.norm(RX2, axis=1))
    np.testing.assert_allclose(range_sums(x, np.tile(TX2, (2, 3, 1)), np.tile(RX2, (2, 1, 1))), l2)


@pytest.mark.parametrize("d", [2, 3])
def test_range_sums_match_scalar_formula(d):
    rng = np.random.default_rng(10 + d)
    x, tx, rx = random_scene(rng, 20, d, 4)
    ls = range_sums(x, tx, rx)
    assert ls.shape == (20, 4)
    for n in range(20):
        for p in range(4):
            assert ls[n, p] == pytest.approx(scalar_range_sum(x[n], tx[n, p], rx[n, p]), rel=1e-14)


@pytest.mark.parametrize(
    ("x", "tx", "rx", "field", "error"),
    [
        ([0.0, 0.0, 0.0], TX2, RX2, "tx", ParameterError),  # D differs
        ([0.0, 0.0], [[0.0, 0.0]] * 2, RX2, "tx", ParameterError),  # P differs
        ([0.0, 0.0], TX2, [1.0, 2.0], "rx", ParameterError),  # not (P, D)
        ([0.0] * 4, [[0.0] * 4], [[1.0] * 4], "x", ParameterError),  # D = 4
        ([[0.0, 0.0]] * 3, TX2, np.zeros((2, 3, 2)) + 1.0, "x", ParameterError),  # N
        ([np.nan, 0.0], TX2, RX2, "x", NonFiniteError),
        ([0.0, 0.0], TX2, [[1.0, np.inf]] * 3, "rx", NonFiniteError),
    ],
)
def test_range_sums_reject(x, tx, rx, field, error):
    with pytest.raises(error) as info:
        range_sums(x, tx, rx)
    assert info.value.field == field


# ---------------------------------------------------------------- Jacobian


def central_difference(x, tx, rx, step=1e-3):
    x = np.asarray(x, dtype=float)
    cols = []
    for k in range(x.shape[-1]):
        dx = np.zeros_like(x)
        dx[..., k] = step
        cols.append((range_sums(x + dx, tx, rx) - range_sums(x - dx, tx, rx)) / (2 * step))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("d", [2, 3])
def test_jacobian_matches_central_differences(d):
    rng = np.random.default_rng(20 + d)
    x, tx, rx = random_scene(rng, 50, d, 5)
    H = range_sum_jacobian(x, tx, rx)
    assert H.shape == (50, 5, d)
    np.testing.assert_allclose(H, central_difference(x, tx, rx), rtol=1e-6, atol=1e-9)


def test_jacobian_unbatched_and_on_baseline():
    H = range_sum_jacobian([3000.0, 4000.0], TX2, RX2)
    assert H.shape == (3, 2)
    np.testing.assert_allclose(
        H, central_difference([3000.0, 4000.0], TX2, RX2), rtol=1e-6, atol=1e-9
    )
    # On the tx-rx segment the two unit vectors cancel (Fadeev et al.: the ellipse of equal
    # range sum degenerates to the baseline).
    H = range_sum_jacobian([2500.0, 0.0], TX2, [[6000.0, 0.0]])
    np.testing.assert_allclose(H, [[0.0, 0.0]], atol=1e-15)
    # Exactly on a platform the undefined term is 0; the result stays finite.
    H = range_sum_jacobian([6000.0, 0.0], TX2, [[6000.0, 0.0]])
    np.testing.assert_allclose(H, [[1.0, 0.0]])


# ---------------------------------------------------------------- validate_problem


def test_validate_problem_shapes_and_broadcast():
    rng = np.random.default_rng(3)
    x, tx, rx = random_scene(rng, 4, 3, 3)
    ls = range_sums(x, tx, rx)
    prob = validate_problem(ls, tx[0], rx, sigma=0.5)
    assert isinstance(prob, Problem)
    l_out, tx_out, rx_out, sigma = prob
    assert l_out.shape == (4, 3) and tx_out.shape == (4, 3, 3) and rx_out.shape == (4, 3, 3)
    np.testing.assert_array_equal(sigma, np.full((4, 3), 0.5))
    np.testing.assert_array_equal(tx_out[2], tx[0])
    tx_out[0, 0, 0] = 1e9  # new arrays, not views of the input
    assert tx[0, 0, 0] != 1e9
    # Unbatched everything: N = 1; sigma per measurement; a single tx as (D,).
    prob = validate_problem([9000.0, 9000.0], TX2, RX2[:2], [1.0, 2.0])
    assert prob.l.shape == (1, 2) and prob.tx.shape == (1, 2, 2)
    np.testing.assert_array_equal(prob.sigma, [[1.0, 2.0]])
    assert validate_problem([9000.0, 9000.0], TX2, RX2[:2]).sigma is None


def test_validate_problem_allows_shared_receiver_with_two_transmitters():
    tx = [[0.0, 0.0], [1000.0, 1000.0], [0.0, 0.0]]
    rx = [[6000.0, 0.0], [6000.0, 0.0], [0.0, 8000.0]]
    ls = range_sums([3000.0, 4000.0], tx, rx)
    assert validate_problem(ls, tx, rx).l.shape == (1, 3)


def test_validate_problem_baseline_tolerance():
    # Target on the baseline: l equals the baseline; noise may put it just below.
    baseline = 6000.0
    ls = [baseline - 1.0, 9000.0]
    with pytest.raises(GeometryError) as info:
        validate_problem(ls, TX2, RX2[:2])
    assert info.value.field == "l"
    validate_problem(ls, TX2, RX2[:2], sigma=0.5)  # within BASELINE_SIGMAS sigma
    validate_problem(ls, TX2, RX2[:2], baseline_tol=1.0)
    validate_problem([baseline, 9000.0], TX2, RX2[:2])  # exactly on it: fine
    with pytest.raises(GeometryError):
        validate_problem(
            [baseline - BASELINE_SIGMAS * 0.5 - 0.01, 9000.0], TX2, RX2[:2], sigma=0.5
        )
    with pytest.raises(ParameterError) as info:
        validate_problem(ls, TX2, RX2[:2], baseline_tol=-1.0)
    assert info.value.field == "baseline_tol"


def good_batch():
    """Three valid 2D problems (N = 3, P = 3) to corrupt one row at a time."""
    rng = np.random.default_rng(7)
    x, tx, rx = random_scene(rng, 3, 2, 3)
    return range_sums(x, tx, rx), tx, rx, np.full((3, 3), 0.5)


def corrupt(what):
    ls, tx, rx, sigma = good_batch()
    if what == "few":
        return ls[:, :1], tx[:, :1], rx[:, :1], sigma[:, :1]
    if what == "tx_eq_rx":
        rx[1, 2] = tx[1, 2] * (1 + 1e-12)
    elif what == "rx_eq_rx":
        rx[2, 1] = rx[2, 0]
    elif what == "negative":
        ls[1, 0] = -1.0
    elif what == "nan_l":
        ls[2, 1] = np.nan
    elif what == "inf_tx":
        tx[1, 0, 0] = np.inf
    elif what == "short":
        ls[2, 2] = np.linalg.norm(rx[2, 2] - tx[2, 2]) - 10.0  # beyond 5 sigma
    elif what == "sigma0":
        sigma[1, 1] = 0.0
    elif what == "sigma_neg":
        sigma[2, 0] = -0.5
    return ls, tx, rx, sigma


@pytest.mark.parametrize(
    ("what", "error", "field", "index"),
    [
        ("few", ParameterError, "l", None),
        ("tx_eq_rx", GeometryError, "rx", 1),
        ("rx_eq_rx", GeometryError, "rx", 2),
        ("negative", ParameterError, "l", 1),
        ("nan_l", NonFiniteError, "l", 2),
        ("inf_tx", NonFiniteError, "tx", 1),
        ("short", GeometryError, "l", 2),
        ("sigma0", ParameterError, "sigma", 1),
        ("sigma_neg", ParameterError, "sigma", 2),
    ],
)
def test_validate_problem_rejects(what, error, field, index):
    ls, tx, rx, sigma = corrupt(what)
    with pytest.raises(error) as info:
        validate_problem(ls, tx, rx, sigma)
    assert isinstance(info.value, PlotgateError)
    assert info.value.field == field
    assert info.value.index == index
    assert field in str(info.value)


@pytest.mark.parametrize(
    ("ls", "tx", "rx", "sigma", "field"),
    [
        (np.ones((2, 2, 3)), TX2, RX2, None, "l"),  # l 3-D
        (5.0, TX2, RX2, None, "l"),  # l scalar
        ([1e5, 1e5], TX2, RX2, None, "l"),  # P differs from rx
        ([1e5] * 3, TX2, [[1.0, 2.0, 3.0, 4.0]] * 3, None, "rx"),  # D = 4
        ([1e5] * 3, [0.0, 0.0, 0.0], RX2, None, "rx"),  # D differs
        ([1e5] * 3, [[0.0, 0.0]] * 2, RX2, None, "tx"),  # P differs
        ([1e5] * 3, TX2, np.zeros((2, 2, 3, 2)), None, "rx"),  # rx 4-D
        (np.full((2, 3), 1e5), TX2, np.ones((3, 3, 2)) * RX2, None, "rx"),  # N differs
        ([1e5] * 3, TX2, RX2, [1.0, 1.0], "sigma"),  # sigma P
        ([1e5] * 3, TX2, RX2, np.ones((2, 2, 3)), "sigma"),  # sigma 3-D
        (np.full((2, 3), 1e5), TX2, RX2, np.ones((4, 3)), "sigma"),  # sigma N differs
    ],
)
def test_validate_problem_rejects_shapes(ls, tx, rx, sigma, field):
    with pytest.raises(ParameterError) as info:
        validate_problem(ls, tx, rx, sigma)
    assert info.value.field == field


def test_validate_problem_rejects_fewer_measurements_than_unknowns_3d():
    with pytest.raises(ParameterError, match="unknowns") as info:
        validate_problem([1e5, 1e5], [0.0, 0.0, 0.0], [[1e4, 0.0, 0.0], [0.0, 1e4, 0.0]])
    assert info.value.field == "l"


def test_validate_problem_rejects_non_numeric():
    with pytest.raises(ParameterError) as info:
        validate_problem(["a", "b"], TX2, RX2[:2])
    assert info.value.field == "l"


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (([[1.0, 2.0], [3.0]], TX2, RX2[:2]), "l"),
        (([1e5, 1e5], [[0.0, 0.0], [1.0]], RX2[:2]), "tx"),
        (([1e5, 1e5], TX2, [[1.0, 0.0], [0.0]]), "rx"),
    ],
)
def test_validate_problem_rejects_ragged(args, field):
    with pytest.raises(ParameterError, match="regular array") as info:
        validate_problem(*args)
    assert info.value.field == field


def test_a_read_only_tolerance_of_every_range_sum_is_taken():
    """A per-range-sum baseline_tol arrives as a read-only array (a broadcast, or a frozen
    request's); the compiled check takes it as numpy does (it once raised a TypeError)."""
    range_sums = np.array([[10000.0, 9000.0]])
    tol = np.broadcast_to(np.array([[1.0, 2.0]]), (1, 2))
    assert not tol.flags.writeable
    rx = [[6000.0, 0.0], [0.0, 6000.0]]
    p = validate_problem(range_sums, [0.0, 0.0], rx, baseline_tol=tol)
    assert p.l.shape == (1, 2)


def test_copy_into_is_numpys_slice_assignment():
    rng = np.random.default_rng(40)
    for size in (0, 1, 2, 7):
        src, dst = rng.normal(size=size), rng.normal(size=size)
        want = dst.copy()
        want[:] = src
        copy_into(src, dst)
        np.testing.assert_array_equal(dst, want)
