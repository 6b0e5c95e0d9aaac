"""The fused kernel of a track's start against its numpy reference (Fadeev et al., eq. 2).

:func:`sample_fixes` solves every sample (closed form, a few Gauss-Newton steps, the
chi-square test, the information of each candidate) and fits each track's line in one
compiled pass; :func:`sample_fixes_reference` does each stage as a batched numpy pass.
Seeded draws on the accuracy study's kind of geometry, with three receivers (one line a
track) and with two (mirrored roots, the chains).
"""

import numpy as np
import pytest

from plotgate.core.multistatic.model import platform_positions, range_sums
from plotgate.core.multistatic.track_start import sample_fixes, sample_fixes_reference
from plotgate.core.multistatic.trajectory import trajectory_solve


def tracks(n, receivers, rng):
    """n noisy tracks of 60 samples: (l (N, T, P), t (T,), tx, rx (N, T, P, D), truth (2D,))."""
    t = 0.2 * np.arange(60)
    rx = platform_positions([[150.0, 500.0], [600.0, 1000.0], [150.0, 1500.0]], [8.7, 5.0], t)
    tx = np.repeat(platform_positions([9900.0, 1000.0], [-5.0, 8.7], t)[:, None], 3, axis=1)
    rx, tx = rx[:, :receivers], tx[:, :receivers]
    truth = np.array([5000.0, 201.0, 0.0, 80.0])
    clean = range_sums(truth[:2] + t[:, None] * truth[2:], tx, rx)
    ls = clean + 0.5 * rng.standard_normal((n, *clean.shape))
    return (
        ls,
        t,
        np.broadcast_to(tx, (n, *tx.shape)).copy(),
        np.broadcast_to(rx, (n, *rx.shape)).copy(),
        truth,
    )


@pytest.mark.parametrize("receivers", [3, 2])
def test_the_fixes_and_lines_agree_with_the_reference(receivers):
    ls, t, tx, rx, _ = tracks(5, receivers, np.random.default_rng(21))
    sigma = np.full(ls.shape, 0.5)
    new = sample_fixes(ls, t, tx, rx, sigma, 0.01)
    ref = sample_fixes_reference(ls, t, tx, rx, sigma, 0.01)
    np.testing.assert_array_equal(new.consistent, ref.consistent)
    np.testing.assert_array_equal(new.mirrored, ref.mirrored)
    scale = 1.0 + np.abs(ref.candidates).max()
    np.testing.assert_allclose(new.candidates, ref.candidates, rtol=0, atol=1e-6 * scale)
    # the information moves with its candidate (which differs by the closed form's
    # rounding, large near a baseline): 1e-6 of each matrix's largest entry
    big = np.abs(ref.information).max(axis=(-2, -1))[..., None, None]
    gap = np.abs(new.information - ref.information) / big
    assert gap.max() <= 1e-6, gap.max()
    plain = ~new.mirrored.reshape(ls.shape[:2]).any(axis=1)  # the kernel's lines
    assert plain.any() == (receivers == 3)
    np.testing.assert_allclose(new.lines[plain], ref.lines[plain], rtol=1e-6, atol=1e-6)


def test_a_track_from_its_own_start_equals_the_track_from_the_reference_line():
    ls, t, tx, rx, truth = tracks(3, 3, np.random.default_rng(22))
    sigma = np.full(ls.shape, 0.5)
    line = sample_fixes_reference(ls, t, tx, rx, sigma, 0.01).lines
    own = trajectory_solve(ls, t, tx, rx, 0.5)
    given = trajectory_solve(ls, t, tx, rx, 0.5, x0=line)
    np.testing.assert_allclose(own.state, given.state, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(own.state, np.broadcast_to(truth, own.state.shape), atol=50.0)
