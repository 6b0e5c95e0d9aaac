"""Existence confirmation (IPDA) on hand-made scans, against an IPDA step computed by hand.

The reference is written from Mušicki, Evans and Stanković (1994) and Bar-Shalom and Tse
(1975) with textbook matrices (F, Q, H, the plain Kalman gain, scipy's Gaussian density),
independently of :mod:`plotgate.core.initiation.existence` and the filter module:

    P(k|k-1) = p11 P(k-1) + p21 (1 - P(k-1))
    delta    = P_D P_G - P_D sum_i N(z_i; z_hat, S) / lambda     (plots inside the gate)
    P(k|k)   = (1 - delta) P(k|k-1) / (1 - delta P(k|k-1))
    x        = x^- + K sum_i beta_i nu_i
    P        = beta_0 P^- + (1 - beta_0) (I - K H) P^- + K (sum beta_i nu_i nu_i^T - nu nu^T) K^T

(the PDA update, one R for all plots). Tolerance: 1e-9 relative on the existence and the
state, 1e-7 on the covariance (sums in another order; the values are of order 1e2-1e4).
"""

import math

import numpy as np
import pytest
from initiation_helpers import scan
from scipy import stats

from plotgate.core.errors import ParameterError
from plotgate.core.initiation import PLOT_STRIDE, InitiationConfig, initiate, state_from_json
from plotgate.core.initiation.existence import (
    existence,
    existence_update,
    markov,
    mixture,
    mixture_reference,
)
from plotgate.core.initiation.simulate import mu_scenario, simulate

R = np.diag([25.0, 25.0])  # one plot covariance for every plot, m^2
P_D, LAMBDA, BETA_NT, P11, P21, P_G = 0.8, 1e-6, 1e-7, 0.95, 0.01, 0.99


def config(**changes):
    base = {
        "v_max": 30.0,
        "q": 1.0,
        "confirmation": "existence",
        "P_D": P_D,
        "clutter_density": LAMBDA,
        "new_target_density": BETA_NT,
        "survival": P11,
        "existence_birth": P21,
        "gate_P_G": P_G,
        "existence_confirm": 1.0 - 1e-12,  # confirm nothing unless a test lowers it
        "existence_delete": 1e-12,
        "capture_gate": "combined",
    }
    return InitiationConfig(**{**base, **changes})


def textbook_predict(x, P, dt, q):
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    Q1 = np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    Q = np.zeros((4, 4))
    Q[np.ix_([0, 2], [0, 2])] = Q1
    Q[np.ix_([1, 3], [1, 3])] = Q1
    return F @ x, F @ P @ F.T + q * Q


def hand_ipda(x, P, p, plots, dt=1.0, q=1.0):
    """One IPDA step by hand: the existence P(k|k) and the PDA state."""
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    xp, Pp = textbook_predict(x, P, dt, q)
    S = H @ Pp @ H.T + R
    K = Pp @ H.T @ np.linalg.inv(S)
    gamma = stats.chi2.ppf(P_G, 2)
    nus = [z - H @ xp for z in plots]
    nus = [nu for nu in nus if nu @ np.linalg.solve(S, nu) <= gamma]
    L = [stats.multivariate_normal(mean=np.zeros(2), cov=S).pdf(nu) / LAMBDA for nu in nus]
    p_pred = P11 * p + P21 * (1 - p)
    delta = P_D * P_G - P_D * sum(L)
    p_post = (1 - delta) * p_pred / (1 - delta * p_pred)
    beta = [P_D * li / (1 - delta) for li in L]
    beta_0 = (1 - P_D * P_G) / (1 - delta)
    nu = sum((b * n for b, n in zip(beta, nus, strict=True)), np.zeros(2))
    spread = sum((b * np.outer(n, n) for b, n in zip(beta, nus, strict=True)), np.zeros((2, 2)))
    x_new = xp + K @ nu
    P_c = (np.eye(4) - K @ H) @ Pp
    P_new = beta_0 * Pp + (1 - beta_0) * P_c + K @ (spread - np.outer(nu, nu)) @ K.T
    return p_post, x_new, P_new, len(nus)


def two_scans(cfg):
    """A tentative track from two plots 1 s apart (10 m/s east)."""
    state, _ = initiate(
        None, [scan(0.0, (1000.0, 2000.0), R=R), scan(1.0, (1010.0, 2000.0), R=R)], cfg
    )
    (row,) = np.flatnonzero(state.tracks.id == 0)
    return state, row


def test_existence_step_matches_the_closed_form_on_a_hand_made_scan():
    cfg = config()
    state, row = two_scans(cfg)
    x, P, p = state.tracks.x[row], state.tracks.P[row], float(existence(state.tracks.score[row]))
    plots = [(1022.0, 2003.0), (1015.0, 1996.0), (1026.0, 2009.0), (1060.0, 2000.0)]
    expected, x_new, P_new, inside = hand_ipda(x, P, p, [np.array(z) for z in plots])
    assert inside == 3  # the far plot is outside the 99% gate, the others weigh in
    after, _ = initiate(state, [scan(2.0, *plots, R=R)], cfg)
    (new_row,) = np.flatnonzero(after.tracks.id == 0)
    got = float(existence(after.tracks.score[new_row]))
    assert got == pytest.approx(expected, rel=1e-9)
    assert after.tracks.x[new_row] == pytest.approx(x_new, rel=1e-9)
    np.testing.assert_allclose(after.tracks.P[new_row], P_new, rtol=1e-7)
    assert after.tracks.n[new_row] == 3  # its history holds the nearest plot
    assert after.tracks.plots[new_row, -1] // PLOT_STRIDE == 2  # the nearest of scan 2


def test_a_scan_without_a_plot_in_the_gate_lowers_existence_by_the_miss_term():
    cfg = config()
    state, row = two_scans(cfg)
    p = float(existence(state.tracks.score[row]))
    after, _ = initiate(state, [scan(2.0, (5000.0, 5000.0), R=R)], cfg)
    (new_row,) = np.flatnonzero(after.tracks.id == 0)
    p_pred = P11 * p + P21 * (1 - p)
    expected = (1 - P_D * P_G) * p_pred / (1 - P_D * P_G * p_pred)
    assert float(existence(after.tracks.score[new_row])) == pytest.approx(expected, rel=1e-9)


def test_the_capture_starts_from_the_single_plots_odds():
    """The second plot's branch: odds P_D beta_NT / lambda times P_D N(z2 - z1) / lambda,
    N with the velocity prior's spread (the score rule's start)."""
    cfg = config()
    state, row = two_scans(cfg)
    S = 2 * R + (30.0**2 / 4 + 1.0 / 3) * np.eye(2)  # R1 + R2 + v_max^2 / 4 tau^2 + q Q_xy
    density = stats.multivariate_normal(mean=np.zeros(2), cov=S).pdf([10.0, 0.0])
    odds = P_D * BETA_NT / LAMBDA * P_D * density / LAMBDA
    assert float(state.tracks.score[row]) == pytest.approx(math.log(odds), rel=1e-9)


def test_confirms_at_the_threshold_and_drops_at_the_other():
    base = config()
    state, row = two_scans(base)
    p = float(existence(state.tracks.score[row]))
    plot = [(1020.0, 2000.0)]
    expected, *_ = hand_ipda(state.tracks.x[row], state.tracks.P[row], p, [np.array(plot[0])])
    confirm = config(existence_confirm=expected * 0.999)
    _, reports = initiate(two_scans(confirm)[0], [scan(2.0, *plot, R=R)], confirm)
    assert 0 in reports[0].confirmed.tolist()
    drop = config(existence_delete=0.999, existence_confirm=0.9999)
    state, _ = initiate(None, [scan(0.0, (1000.0, 2000.0), R=R)], drop)
    _, reports = initiate(state, [scan(1.0, (1010.0, 2000.0), R=R)], drop)
    assert "existence" in reports[0].reasons.tolist()


def test_markov_and_update_in_log_odds_match_the_probabilities():
    rng = np.random.default_rng(7)
    p = rng.uniform(0.01, 0.99, 50)
    got = existence(markov(log_odds_array(p), P11, P21))
    np.testing.assert_allclose(got, P11 * p + P21 * (1 - p), rtol=1e-12)
    row = np.repeat(np.arange(50), 3)
    log_ratio = rng.normal(0.0, 3.0, 150)
    post, beta_0, beta = existence_update(log_odds_array(p), np.full(50, P_G), P_D, row, log_ratio)
    delta = P_D * P_G - P_D * np.bincount(row, np.exp(log_ratio), minlength=50)
    np.testing.assert_allclose(existence(post), (1 - delta) * p / (1 - delta * p), rtol=1e-10)
    np.testing.assert_allclose(beta_0 + np.bincount(row, beta, minlength=50), 1.0, rtol=1e-12)


def log_odds_array(p):
    return np.log(p) - np.log1p(-p)


def test_mixture_matches_its_reference():
    rng = np.random.default_rng(11)
    m, e = 6, 20
    row = np.sort(rng.integers(0, m - 1, e))  # the last track has no pair
    w = rng.uniform(0.1, 1.0, e)
    w0 = rng.uniform(0.1, 1.0, m)
    total = w0 + np.bincount(row, w, minlength=m)
    beta_0, beta = w0 / total, w / total[row]
    A = rng.normal(size=(m, 4, 4))
    B = rng.normal(size=(e, 4, 4))
    x0, xi = rng.normal(size=(m, 4)) * 100, rng.normal(size=(e, 4)) * 100
    P0, Pi = A @ A.transpose(0, 2, 1), B @ B.transpose(0, 2, 1)
    x, P = mixture(x0, P0, beta_0, row, xi, Pi, beta)
    x_ref, P_ref = mixture_reference(x0, P0, beta_0, row, xi, Pi, beta)
    np.testing.assert_allclose(x, x_ref, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(P, P_ref, rtol=1e-12, atol=1e-7)
    assert (x[-1] == x0[-1]).all() and (P[-1] == P0[-1]).all()


def test_two_calls_answer_as_one_and_the_state_survives_json():
    cfg = config(existence_confirm=0.9, clutter_density=None, surveillance_area=2.25e8)
    scans = simulate(mu_scenario(250.0, scans=6), 3).scans
    whole, reports = initiate(None, scans, cfg)
    state = None
    parts = []
    for s in scans:
        state, (report,) = initiate(state, [s], cfg)
        state = state_from_json(state.to_json(), cfg)  # through JSON each time
        parts.append(report)
    assert state.to_json() == whole.to_json()
    for a, b in zip(parts, reports, strict=True):
        assert a.confirmed.tolist() == b.confirmed.tolist()
        assert a.dropped.tolist() == b.dropped.tolist()


def test_a_tampered_existence_is_refused():
    cfg = config(existence_confirm=0.9, existence_delete=0.02)
    state, row = two_scans(cfg)
    data = state.to_json()
    data["tracks"]["score"][row] = math.log(0.01 / 0.99)  # below existence_delete
    with pytest.raises(ParameterError) as caught:
        state_from_json(data, cfg)
    assert caught.value.field == "state.tracks.score"


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"existence_delete": 0.5, "existence_confirm": 0.4}, "existence_delete"),
        ({"survival": 1.5}, "survival"),
        ({"mode": "polar"}, "mode"),
        ({"clutter_density": None}, "clutter_density"),
    ],
)
def test_settings_are_checked(changes, field):
    with pytest.raises(ParameterError) as caught:
        config(**changes)
    assert caught.value.field == field


def test_other_modes_keep_their_digest():
    """The existence settings count in the digest only under existence confirmation."""
    assert InitiationConfig(survival=0.5).digest() == InitiationConfig().digest()
    assert config(survival=0.5).digest() != config().digest()
