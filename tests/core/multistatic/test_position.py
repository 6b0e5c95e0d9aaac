"""The fused single-shot kernel of ml_solve against its numpy reference (Fadeev et al., eq. 6).

:func:`ml_solve` checks each problem, takes the closed form's roots, runs Gauss-Newton from
every start and chooses the solution and its alternative in one compiled pass;
:func:`ml_solve_reference` does each stage as a batched numpy pass. From the same start
they take the same iterations to the same minimum (to rounding); from the closed form's
roots (LAPACK's SVD against Jacobi rotations, which differ by rounding where the
receivers are nearly collinear) to within the solver's tolerance. Every draw is seeded.
"""

import numpy as np
import pytest

from plotgate.core.errors import PlotgateError
from plotgate.core.multistatic.model import (
    platform_positions,
    range_sums,
    validate_problem,
    validate_problem_reference,
)
from plotgate.core.multistatic.position import MLSolution, ml_solve, ml_solve_reference


def study_problems(n, rng, spread=False):
    """n single shots of the accuracy study's geometry (Fadeev et al., Fig. 2), sigma 0.5 m."""
    t = 0.1 * rng.integers(0, 200, n)
    rx0 = [[150.0, 500.0], [600.0, 1000.0], [150.0, 1500.0]]
    if spread:
        rx0 = [[150.0, -1500.0], [600.0, 1000.0], [150.0, 3500.0]]
    heading_rx, heading_tx = np.pi / 6, -np.pi / 6
    rx = platform_positions(rx0, 10.0 * np.array([np.cos(heading_rx), np.sin(heading_rx)]), t)
    tx = platform_positions(
        [9900.0, 1000.0], 10.0 * np.array([np.cos(heading_tx), np.sin(heading_tx)]), t
    )
    tx = np.repeat(tx[:, None], 3, axis=1)
    x = np.array([5000.0, 201.0]) + t[:, None] * [0.0, 80.0]
    return range_sums(x, tx, rx) + 0.5 * rng.standard_normal((n, 3)), tx, rx, x


def assert_same_minima(new: MLSolution, ref: MLSolution, exact: bool) -> None:
    """The same minima: to rounding when ``exact``, else to the solver's tolerance.

    Tolerance: Mahalanobis distance below 1e-4 (by the solution's covariance) and costs
    equal to 1e-9 (1 + cost).
    """
    np.testing.assert_array_equal(new.has_alternative, ref.has_alternative)
    np.testing.assert_array_equal(new.consistent, ref.consistent)
    np.testing.assert_array_equal(new.converged, ref.converged)
    dx = new.x - ref.x
    J = np.linalg.inv(ref.covariance)
    assert (np.einsum("ni,nij,nj->n", dx, J, dx) <= 1e-8).all()
    assert (np.abs(new.cost - ref.cost) <= 1e-9 * (1.0 + ref.cost)).all()
    if exact:
        np.testing.assert_array_equal(new.iterations, ref.iterations)
        scale = 1.0 + np.abs(ref.x).max(axis=1)
        assert (np.abs(dx).max(axis=1) <= 1e-12 * scale).all()
        np.testing.assert_allclose(new.residuals, ref.residuals, atol=1e-8)
        np.testing.assert_allclose(new.covariance, ref.covariance, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("seed", [11, 12])
def test_from_the_same_start_the_kernel_takes_the_reference_steps(seed):
    rng = np.random.default_rng(seed)
    ls, tx, rx, x = study_problems(3000, rng)  # the baseline crossings included
    start = x + rng.normal(0.0, 300.0, x.shape)
    kwargs = {"x0": start, "closed_form_starts": False}
    assert_same_minima(
        ml_solve(ls, tx, rx, 0.5, **kwargs), ml_solve_reference(ls, tx, rx, 0.5, **kwargs), True
    )


@pytest.mark.parametrize("spread", [False, True])
def test_from_the_closed_form_roots_the_same_solutions_and_alternatives(spread):
    rng = np.random.default_rng(13)
    ls, tx, rx, x = study_problems(4000, rng, spread)  # >= 2048: the parallel loop
    new, ref = ml_solve(ls, tx, rx, 0.5), ml_solve_reference(ls, tx, rx, 0.5)
    assert_same_minima(new, ref, False)
    assert (new.iterations == ref.iterations).mean() >= (0.99 if spread else 0.7)
    with_x0 = ml_solve(ls, tx, rx, 0.5, x0=x + 500.0)
    assert_same_minima(with_x0, ml_solve_reference(ls, tx, rx, 0.5, x0=x + 500.0), False)


def test_two_roots_several_transmitters_and_too_few_pairs_of_the_first():
    rng = np.random.default_rng(14)
    rx = np.array([[6000.0, 0.0], [0.0, 8000.0], [7000.0, 9000.0], [-3000.0, 4000.0]])
    truth = rng.uniform(-5e3, 5e3, (50, 2))
    # two receivers: both ellipse intersections are exact (the alternative)
    two = range_sums(truth, [0.0, 0.0], rx[:2])
    assert_same_minima(
        ml_solve(two, [0.0, 0.0], rx[:2], 0.5),
        ml_solve_reference(two, [0.0, 0.0], rx[:2], 0.5),
        False,
    )
    # a second transmitter for the last two pairs: the first one's pairs give the roots
    tx = np.array([[0.0, 0.0], [0.0, 0.0], [2000.0, -1000.0], [2000.0, -1000.0]])
    ls = range_sums(truth, tx, rx) + 0.5 * rng.standard_normal((50, 4))
    new = ml_solve(ls, tx, rx, 0.5)
    assert_same_minima(new, ml_solve_reference(ls, tx, rx, 0.5), False)
    # the first transmitter has one pair only: the platforms' centroid is the start
    tx1 = np.array([[0.0, 0.0], [2000.0, -1000.0], [2000.0, -1000.0], [2000.0, -1000.0]])
    ls1 = range_sums(truth, tx1, rx) + 0.5 * rng.standard_normal((50, 4))
    assert_same_minima(ml_solve(ls1, tx1, rx, 0.5), ml_solve_reference(ls1, tx1, rx, 0.5), False)
    np.testing.assert_allclose(new.x, truth, atol=10.0)


def test_three_dimensional_problems():
    rng = np.random.default_rng(15)
    n, p = 300, 4
    tx = np.broadcast_to(rng.uniform(-5e3, 5e3, (n, 1, 3)), (n, p, 3)).copy()
    rx = rng.uniform(-1e4, 1e4, (n, p, 3))
    x = rng.uniform(-2e4, 2e4, (n, 3))
    ls = range_sums(x, tx, rx) + rng.standard_normal((n, p))
    new, ref = ml_solve(ls, tx, rx, 1.0), ml_solve_reference(ls, tx, rx, 1.0)
    np.testing.assert_array_equal(new.consistent, ref.consistent)
    assert (np.abs(new.cost - ref.cost) <= 1e-6 * (1.0 + ref.cost)).mean() >= 0.99


def with_entry(a, index, value):
    """A copy of a with one entry set."""
    out = np.array(a)
    out[index] = value
    return out


BAD = {
    "negative range sum": (0, (5, 0), -1.0),
    "receiver on its transmitter": (2, (7, 1), "tx"),
    "repeated pair": (2, (3, 2), "rx0"),
    "range sum below its baseline": (0, (9, 2), 0.0),
    "zero sigma": (3, (4, 1), 0.0),
}


@pytest.mark.parametrize("name", BAD)
def test_a_bad_problem_is_named_as_the_reference_names_it(name):
    rng = np.random.default_rng(16)
    ls, tx, rx, _ = study_problems(20, rng)
    args = [ls, tx, rx, np.full(ls.shape, 0.5)]
    which, index, value = BAD[name]
    if value == "tx":
        value = tx[index]
    elif value == "rx0":
        value = rx[index[0], 0]
    args[which] = with_entry(args[which], index, value)
    with pytest.raises(PlotgateError) as ref:
        validate_problem_reference(*args)
    for solve in (validate_problem, ml_solve):
        with pytest.raises(PlotgateError) as new:
            solve(*args)
        assert type(new.value) is type(ref.value)
        assert (new.value.field, new.value.index, str(new.value)) == (
            ref.value.field,
            ref.value.index,
            str(ref.value),
        )
