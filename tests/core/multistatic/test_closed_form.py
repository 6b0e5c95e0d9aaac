"""Tests of core.multistatic.closed_form (Fadeev et al.): sum-range and difference-range solves."""

import dataclasses

import numpy as np
import pytest

from plotgate.core.errors import GeometryError, NonFiniteError, ParameterError
from plotgate.core.multistatic import (
    ClosedFormSolution,
    difference_range_solve,
    range_sums,
    sum_range_solve,
)
from plotgate.core.multistatic.closed_form import sum_range_roots, sum_range_roots_reference
from plotgate.core.multistatic.model import validate_problem

ATOL = 1e-6  # metres: exact on noise-free data
SOLVERS = [sum_range_solve, difference_range_solve]
MIN_P = {sum_range_solve: 0, difference_range_solve: 1}  # P >= D + MIN_P


def scene(seed, n, d, p):
    """N problems: one transmitter, P receivers ~10 km from it, targets within 20 km.

    Receivers are spread in azimuth around the transmitter (3D: altitudes within
    +-3 km, so the platforms are not coplanar); targets anywhere within 20 km.
    """
    rng = np.random.default_rng(seed)
    tx = rng.uniform(-2000.0, 2000.0, (n, d))
    step = 2.0 * np.pi / max(p, 3)
    az = step * np.arange(p) + rng.uniform(-0.3, 0.3, (n, p)) + rng.uniform(0, 7, (n, 1))
    radius = rng.uniform(8000.0, 12000.0, (n, p))
    rx = np.repeat(tx[:, None, :], p, axis=1)
    rx[..., 0] += radius * np.cos(az)
    rx[..., 1] += radius * np.sin(az)
    if d == 3:
        rx[..., 2] += rng.uniform(-3000.0, 3000.0, (n, p))
    u = rng.normal(size=(n, d))
    x = tx + u / np.linalg.norm(u, axis=1, keepdims=True) * rng.uniform(500.0, 20000.0, (n, 1))
    tx = np.repeat(tx[:, None, :], p, axis=1)
    return x, tx, rx, range_sums(x, tx, rx)


def dist(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b), axis=-1)


def assert_well_formed(sol, n, d):
    assert isinstance(sol, ClosedFormSolution)
    for name in ("x", "alternative"):
        assert getattr(sol, name).shape == (n, d)
    for name in ("has_alternative", "solvable", "residual", "alternative_residual"):
        assert getattr(sol, name).shape == (n,)
    assert sol.solvable.dtype == bool and sol.has_alternative.dtype == bool
    for field in dataclasses.fields(sol):
        assert np.isfinite(getattr(sol, field.name)).all(), field.name
    assert not (sol.has_alternative & ~sol.solvable).any()
    np.testing.assert_array_equal(
        sol.alternative[~sol.has_alternative], sol.x[~sol.has_alternative]
    )


# ---------------------------------------------------------------- exact, overdetermined


@pytest.mark.parametrize("solve", SOLVERS)
@pytest.mark.parametrize(("d", "p"), [(2, 3), (2, 4), (2, 5), (3, 4), (3, 5)])
def test_exact_and_true_root_chosen(solve, d, p):
    x, tx, rx, ls = scene(100 * d + p, 200, d, p)
    sol = solve(ls, tx, rx)
    assert_well_formed(sol, 200, d)
    assert sol.solvable.all()
    assert dist(sol.x, x).max() <= ATOL  # the chosen root is the true one
    assert sol.residual.max() <= ATOL
    # A reported alternative is a genuinely different point.
    assert (dist(sol.alternative, sol.x)[sol.has_alternative] > 1e-3).all()


@pytest.mark.parametrize("solve", SOLVERS)
def test_three_dimensional_with_three_receivers_exact(solve):
    # 3D, one transmitter and three receivers: square for the sum-range method (P = D);
    # only two differences for three unknowns in the difference-range method: refused.
    x, tx, rx, ls = scene(7, 100, 3, 3)
    if solve is difference_range_solve:
        with pytest.raises(ParameterError) as info:
            solve(ls, tx, rx)
        assert info.value.field == "l"
        return
    sol = solve(ls, tx, rx)
    assert_well_formed(sol, 100, 3)
    assert sol.solvable.all()
    best = np.minimum(
        dist(sol.x, x), np.where(sol.has_alternative, dist(sol.alternative, x), np.inf)
    )
    assert best.max() <= ATOL


# ---------------------------------------------------------------- square systems: two roots


@pytest.mark.parametrize(
    ("solve", "d"),
    [
        (sum_range_solve, 2),
        (sum_range_solve, 3),
        (difference_range_solve, 2),
        (difference_range_solve, 3),
    ],
)
def test_square_system_reports_both_roots(solve, d):
    p = d + MIN_P[solve]
    x, tx, rx, ls = scene(300 + d, 200, d, p)
    sol = solve(ls, tx, rx)
    assert_well_formed(sol, 200, d)
    assert sol.solvable.all()
    err_x, err_alt = dist(sol.x, x), dist(sol.alternative, x)
    found = (err_x <= ATOL) | (sol.has_alternative & (err_alt <= ATOL))
    assert found.all()  # the truth is always one of the two reported roots
    assert sol.has_alternative.mean() > 0.1  # two consistent roots are common
    alt = sol.alternative[sol.has_alternative]
    fit = range_sums(alt, tx[sol.has_alternative], rx[sol.has_alternative])
    if solve is sum_range_solve:
        # Both ellipse intersections fit every range sum exactly.
        np.testing.assert_allclose(fit, ls[sol.has_alternative], atol=ATOL)
        np.testing.assert_allclose(sol.alternative_residual[sol.has_alternative], 0.0, atol=ATOL)
    else:
        # The mirror root fits the differences exactly, and the transmitter (range sums)
        # picks the true one as x.
        diff = ls[:, 1:] - ls[:, :1]
        np.testing.assert_allclose(fit[:, 1:] - fit[:, :1], diff[sol.has_alternative], atol=ATOL)
        assert (err_x <= ATOL).all()


def test_two_ellipse_intersections_known_case():
    # tx at the origin, receivers on the axes; the target and its second intersection.
    tx = [0.0, 0.0]
    rx = [[10000.0, 0.0], [0.0, 10000.0]]
    x_true = np.array([7000.0, 7000.0])
    ls = range_sums(x_true, tx, rx)
    sol = sum_range_solve(ls, tx, rx)
    assert sol.solvable[0] and sol.has_alternative[0]
    # By symmetry about y = x the second intersection lies on that line too: it is the
    # other point with |s| + |s - b| = l on it.
    roots = sorted([sol.x[0].tolist(), sol.alternative[0].tolist()])
    for root in roots:
        assert root[0] == pytest.approx(root[1], abs=ATOL)
        np.testing.assert_allclose(range_sums(root, tx, rx), ls, atol=ATOL)
    assert any(np.allclose(r, x_true, atol=ATOL) for r in roots)
    assert dist(*roots) > 1000.0
    # A third receiver on the line y = x breaks the tie: only the true point survives
    # with zero residual, and it is chosen.
    rx3 = rx + [[12000.0, 12000.0]]
    sol = sum_range_solve(range_sums(x_true, tx, rx3), tx, rx3)
    np.testing.assert_allclose(sol.x[0], x_true, atol=ATOL)
    if sol.has_alternative[0]:
        assert sol.alternative_residual[0] > 1.0


# ---------------------------------------------------------------- near a baseline


@pytest.mark.parametrize("solve", SOLVERS)
@pytest.mark.parametrize("offset", [0.0, 1e-3, 0.5, 20.0])
@pytest.mark.parametrize("d", [2, 3])
def test_target_near_a_baseline(solve, offset, d):
    tx = np.zeros(d)
    rx = np.array(
        [
            [10000.0, 0.0, 0.0],
            [-3000.0, 9000.0, 500.0],
            [-4000.0, -8000.0, -800.0],
            [2000.0, 7000.0, 2500.0],
        ]
    )[:, :d]
    if d == 2:
        rx = rx[:3]
    # Target on / just off the tx - rx_1 segment: the ellipse of rx_1 degenerates there.
    x_true = np.array([4000.0, offset, 0.0][:d] if d == 2 else [4000.0, offset, offset])
    ls = range_sums(x_true, tx, rx)
    sol = solve(ls, tx, rx)
    assert_well_formed(sol, 1, d)
    assert sol.solvable[0]
    np.testing.assert_allclose(sol.x[0], x_true, atol=ATOL)


# ---------------------------------------------------------------- degenerate geometry


def test_coplanar_platforms_3d_give_mirror_images():
    # All platforms at one altitude: the target and its mirror image fit equally;
    # the one above the plane is chosen, the other reported.
    tx = [0.0, 0.0, 1000.0]
    rx = [
        [9000.0, 1000.0, 1000.0],
        [-2000.0, 9500.0, 1000.0],
        [-6000.0, -7000.0, 1000.0],
        [5000.0, -8000.0, 1000.0],
    ]
    x_true = np.array([3000.0, 4000.0, 3500.0])
    mirror = np.array([3000.0, 4000.0, -1500.0])
    for solve, p in ((sum_range_solve, 3), (sum_range_solve, 4), (difference_range_solve, 4)):
        ls = range_sums(x_true, tx, rx[:p])
        sol = solve(ls, tx, rx[:p])
        assert sol.solvable[0] and sol.has_alternative[0]
        np.testing.assert_allclose(sol.x[0], x_true, atol=ATOL)
        np.testing.assert_allclose(sol.alternative[0], mirror, atol=ATOL)
        sol = solve(range_sums(mirror, tx, rx[:p]), tx, rx[:p])
        np.testing.assert_allclose(sol.x[0], x_true, atol=ATOL)  # ambiguous: above wins


def test_collinear_platforms_2d_give_mirror_images():
    tx = [0.0, 0.0]
    rx = [[5000.0, 0.0], [12000.0, 0.0], [-7000.0, 0.0]]
    x_true = np.array([3000.0, 2500.0])
    sol = sum_range_solve(range_sums(x_true, tx, rx), tx, rx)
    assert sol.solvable[0] and sol.has_alternative[0]
    np.testing.assert_allclose(sol.x[0], x_true, atol=ATOL)
    np.testing.assert_allclose(sol.alternative[0], [3000.0, -2500.0], atol=ATOL)


def test_collinear_platforms_3d_are_unsolvable_not_nan():
    tx = [0.0, 0.0, 0.0]
    rx = [[5000.0, 0.0, 0.0], [12000.0, 0.0, 0.0], [-7000.0, 0.0, 0.0]]
    sol = sum_range_solve(range_sums([3000.0, 2500.0, 100.0], tx, rx), tx, rx)
    assert_well_formed(sol, 1, 3)
    assert not sol.solvable[0]


# ---------------------------------------------------------------- no real solution


def test_nested_ellipses_are_unsolvable_not_nan():
    # Two ellipses sharing the focus tx, one inside the other: no intersection.
    tx = [0.0, 0.0]
    rx = [[1000.0, 0.0], [500.0, 300.0]]
    ls = [1200.0, 20000.0]
    sol = sum_range_solve(ls, tx, rx)
    assert_well_formed(sol, 1, 2)
    assert not sol.solvable[0] and not sol.has_alternative[0]
    assert sol.residual[0] > 100.0


@pytest.mark.parametrize("d", [2, 3])
def test_inconsistent_rows_flagged_per_problem(d):
    p = d + 2
    x, tx, rx, ls = scene(11 + d, 6, d, p)
    bad = ls.copy()
    # Rows 1 and 4: the last receiver's ellipse shrunk onto its baseline and the first
    # one's blown up: no point fits, and no real consistent root exists.
    for n in (1, 4):
        bad[n, -1] = np.linalg.norm(rx[n, -1] - tx[n, -1])
        bad[n, 0] = 60000.0
    for solve in SOLVERS:
        sol = solve(bad, tx, rx)
        assert_well_formed(sol, 6, d)
        good = np.array([0, 2, 3, 5])
        assert sol.solvable[good].all()
        np.testing.assert_allclose(sol.x[good], x[good], atol=ATOL)
        assert not sol.solvable[[1, 4]].any()
        assert (sol.residual[[1, 4]] > 100.0).all()


def test_difference_beyond_receiver_separation_is_unsolvable():
    # |d| cannot exceed the distance between the two receivers: no hyperbola exists.
    tx = [0.0, 0.0]
    rx = [[9000.0, 0.0], [9100.0, 100.0], [0.0, 9000.0]]
    ls = [10000.0, 15000.0, 12000.0]
    sol = difference_range_solve(ls, tx, rx)
    assert_well_formed(sol, 1, 2)
    assert not sol.solvable[0]


# ---------------------------------------------------------------- shapes and batching


@pytest.mark.parametrize("solve", SOLVERS)
def test_batched_equals_one_by_one(solve):
    x, tx, rx, ls = scene(21, 8, 2, 4)
    rng = np.random.default_rng(5)
    noisy = ls + rng.normal(0.0, 0.5, ls.shape)
    sol = solve(noisy, tx, rx, baseline_tol=5.0)
    for n in range(8):
        one = solve(noisy[n], tx[n], rx[n], baseline_tol=5.0)
        assert one.x.shape == (1, 2)
        np.testing.assert_allclose(one.x[0], sol.x[n], rtol=0, atol=1e-9)
        assert one.solvable[0] == sol.solvable[n]


def test_single_transmitter_given_once_and_frozen_result():
    rx = [[6000.0, 0.0], [0.0, 8000.0], [7000.0, 9000.0]]
    ls = range_sums([2000.0, 3000.0], [0.0, 0.0], rx)
    sol = sum_range_solve(ls, [0.0, 0.0], rx)
    np.testing.assert_allclose(sol.x, [[2000.0, 3000.0]], atol=ATOL)
    with pytest.raises(dataclasses.FrozenInstanceError):
        sol.x = None


def test_noisy_data_stays_close_and_finite():
    x, tx, rx, ls = scene(42, 300, 2, 3)
    rng = np.random.default_rng(43)
    noisy = ls + rng.normal(0.0, 0.5, ls.shape)
    for solve in SOLVERS:
        sol = solve(noisy, tx, rx, baseline_tol=5.0)
        assert_well_formed(sol, 300, 2)
        err = dist(sol.x, x)[sol.solvable]
        assert sol.solvable.mean() > 0.9
        assert np.median(err) < 50.0


def test_noisy_measurement_below_baseline_accepted_with_tolerance():
    tx = [0.0, 0.0]
    rx = [[10000.0, 0.0], [0.0, 9000.0], [-8000.0, -5000.0]]
    ls = range_sums([4000.0, 0.0], tx, rx)
    ls[0] -= 0.7  # noise put the crossing measurement below its baseline
    with pytest.raises(GeometryError):
        sum_range_solve(ls, tx, rx)
    sol = sum_range_solve(ls, tx, rx, baseline_tol=2.5)
    assert_well_formed(sol, 1, 2)


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("solve", SOLVERS)
def test_several_transmitters_rejected(solve):
    x, tx, rx, ls = scene(31, 3, 2, 4)
    tx[2, 3] += [500.0, 0.0]
    ls = range_sums(x, tx, rx)
    with pytest.raises(ParameterError, match="one transmitter") as info:
        solve(ls, tx, rx)
    assert (info.value.field, info.value.index) == ("tx", 2)


def test_difference_needs_d_plus_one_measurements():
    x, tx, rx, ls = scene(32, 2, 2, 2)
    with pytest.raises(ParameterError, match="difference") as info:
        difference_range_solve(ls, tx, rx)
    assert info.value.field == "l"
    sum_range_solve(ls, tx, rx)  # two ellipses are enough for the sum-range method


def bad_inputs(what):
    x, tx, rx, ls = scene(33, 3, 2, 3)
    if what == "few":
        return ls[:, :1], tx[:, :1], rx[:, :1]
    if what == "coincident":
        rx[1, 1] = tx[1, 1]
    elif what == "same_rx":
        rx[2, 2] = rx[2, 0]
    elif what == "negative":
        ls[0, 2] = -5.0
    elif what == "nan":
        ls[1, 1] = np.nan
    elif what == "inf_rx":
        rx[2, 0, 1] = -np.inf
    elif what == "short":
        ls[1, 0] = np.linalg.norm(rx[1, 0] - tx[1, 0]) - 1.0
    elif what == "shape_l":
        return ls[:, :2], tx, rx
    elif what == "shape_rx":
        return ls, tx, rx[..., :1]
    return ls, tx, rx


@pytest.mark.parametrize("solve", SOLVERS)
@pytest.mark.parametrize(
    ("what", "error", "field", "index"),
    [
        ("few", ParameterError, "l", None),
        ("coincident", GeometryError, "rx", 1),
        ("same_rx", GeometryError, "rx", 2),
        ("negative", ParameterError, "l", 0),
        ("nan", NonFiniteError, "l", 1),
        ("inf_rx", NonFiniteError, "rx", 2),
        ("short", GeometryError, "l", 1),
        ("shape_l", ParameterError, "l", None),
        ("shape_rx", ParameterError, "rx", None),
    ],
)
def test_bad_input_raises_named_error(solve, what, error, field, index):
    with pytest.raises(error) as info:
        solve(*bad_inputs(what))
    assert info.value.field == field
    assert info.value.index == index


# ---------------------------------------------- the compiled sum-range roots vs numpy


def assert_roots_agree(ls, tx, rx, double_root=False):
    """sum_range_roots (compiled, Jacobi SVD) against sum_range_roots_reference (LAPACK).

    The same decisions (solvable, has_alternative) everywhere; the same points to 1e-9
    of the coordinate scale (two SVD algorithms round differently, and a poorly
    conditioned system amplifies that: the module notes' 1e-6 m at 10 km), and to
    1e-12 where the geometry is well conditioned (most problems). At a double root
    (``double_root``: a target on the platforms' line, the baseline crossing) the two
    roots are as far apart as the square root of rounding (1e-8 of the scale), so
    whether they count as one point and where they are is only that accurate.
    """
    ls, tx, rx, _ = validate_problem(ls, tx, rx)
    ref = sum_range_roots_reference(ls, tx, rx)
    new = sum_range_roots(ls, tx, rx)
    np.testing.assert_array_equal(new.solvable, ref.solvable)
    if not double_root:
        np.testing.assert_array_equal(new.has_alternative, ref.has_alternative)
    scale = 1.0 + np.abs(tx).max(axis=(1, 2)) + np.abs(rx).max(axis=(1, 2))
    rtol = 1e-7 if double_root else 1e-9
    for a, b in ((new.x, ref.x), (new.alternative, ref.alternative)):
        gap = np.abs(a - b).max(axis=1) / np.maximum(scale, np.abs(b).max(axis=1))
        assert (gap <= rtol).all()
        assert double_root or (gap <= 1e-12).mean() >= 0.5
    pairs = ((new.residual, ref.residual), (new.alternative_residual, ref.alternative_residual))
    for a, b in pairs:
        assert (np.abs(a - b) <= rtol * scale).all()


@pytest.mark.parametrize("d, p", [(2, 2), (2, 3), (2, 5), (3, 3), (3, 4)])
def test_compiled_roots_agree_with_numpy_on_random_problems(d, p):
    _, tx, rx, ls = scene(11 + d + p, 1000, d, p)
    assert_roots_agree(ls, tx, rx)
    rng = np.random.default_rng(d * p)
    assert_roots_agree(ls + rng.uniform(0.0, 2000.0, ls.shape), tx, rx)  # some unsolvable


def test_compiled_roots_on_degenerate_geometry_one_problem_and_an_empty_batch():
    rng = np.random.default_rng(12)
    n = 300
    # 2D: every platform on the x axis (rank D - 1: mirror images)
    tx = np.zeros((n, 3, 2))
    rx = np.zeros((n, 3, 2))
    rx[:, :, 0] = rng.uniform(1e3, 1e4, (n, 3)) * [1.0, -1.0, 1.0]
    x = rng.uniform(-2e4, 2e4, (n, 2))
    assert_roots_agree(range_sums(x, tx, rx), tx, rx)
    x[:, 1] = 0.0  # on the line: the baseline crossing, a double root
    assert_roots_agree(range_sums(x, tx, rx), tx, rx, double_root=True)
    # 3D: every platform at one altitude (coplanar); a target on a receiver
    tx3 = np.zeros((n, 4, 3))
    rx3 = np.zeros((n, 4, 3))
    rx3[:, :, :2] = rng.uniform(-1e4, 1e4, (n, 4, 2))
    x3 = rng.uniform(-2e4, 2e4, (n, 3))
    assert_roots_agree(range_sums(x3, tx3, rx3), tx3, rx3)
    x3[0] = rx3[0, 1]  # on a receiver: a range of 0, as sensitive as a double root
    assert_roots_agree(range_sums(x3[:1], tx3[:1], rx3[:1]), tx3[:1], rx3[:1], double_root=True)
    # 3D: every platform on one line (rank D - 2: unsolvable)
    line = np.zeros((n, 3, 3))
    line[:, :, 0] = rx[:, :, 0]
    assert_roots_agree(range_sums(x3, np.zeros((n, 3, 3)), line), np.zeros((n, 3, 3)), line)
    one = np.array([[3000.0, 4000.0]])
    assert_roots_agree(range_sums(one, tx[:1], rx[:1]), tx[:1], rx[:1])
    empty = sum_range_roots(np.zeros((0, 3)), np.zeros((0, 3, 2)), np.zeros((0, 3, 2)))
    assert empty.x.shape == (0, 2) and empty.solvable.shape == (0,)
