"""The gates on the candidates: every plot inside a track's gate, and no other."""

from dataclasses import replace

import numpy as np
from initiation_helpers import CONFIG, POLAR, R4, SAZ, SR, pscan, run, scan, target
from scipy import stats

from plotgate.core.initiation import InitiationConfig, cartesian_scan, polar_scan
from plotgate.core.initiation.filter import predict
from plotgate.core.initiation.pairs import (
    Prediction,
    ellipse_pairs,
    likelihood_gate_bound,
    likelihood_pairs,
    window_coefficients,
    window_pairs,
)
from plotgate.core.initiation.score import log_clutter_density, ml_gate
from plotgate.core.initiation.search import PlotIndex


def test_candidate_search_finds_exactly_the_brute_force_gate_members():
    rng = np.random.default_rng(5)
    state, _ = run(CONFIG, *[scan(t, target(t)) for t in range(3)])
    z = np.column_stack([rng.uniform(900.0, 1200.0, 4000), rng.uniform(1900.0, 2100.0, 4000)])
    s = cartesian_scan(3.0, z, np.broadcast_to(R4, (4000, 2, 2)))
    tr = state.tracks
    dt = s.t - tr.t
    xp, Pp = predict(tr.x, tr.P, dt, CONFIG.q)
    _, cols, stat = ellipse_pairs(tr, Prediction(dt, xp, Pp), s, PlotIndex(s, None), CONFIG)
    nu = s.z - xp[0, :2]
    rho = np.einsum("ni,ij,nj->n", nu, np.linalg.inv(Pp[0, :2, :2] + R4), nu)
    brute = np.flatnonzero(rho <= stats.chi2.ppf(CONFIG.gate_P_G, 2))
    assert brute.size > 5
    np.testing.assert_array_equal(np.sort(cols), brute)
    np.testing.assert_allclose(stat[np.argsort(cols)], rho[brute], rtol=1e-10)


def test_polar_candidate_search_finds_exactly_the_window_members_across_north():
    # a polar track heading across north (azimuth +-180 deg is due south: use a track
    # at azimuth 179.9 deg) and 20000 plots around it, on both sides of the wrap
    rng = np.random.default_rng(6)
    first = [pscan(0, (10000.0, 179.9)), pscan(1, (10010.0, 179.95))]
    state, _ = run(POLAR, *first)
    r = rng.uniform(9900.0, 10150.0, 20000)
    az = np.radians(rng.uniform(178.0, 182.0, 20000))
    az = np.where(az > np.pi, az - 2 * np.pi, az)
    s = polar_scan(2.0, r, az, np.full(r.size, SR), np.full(r.size, SAZ))
    tr = state.tracks
    dt = s.t - tr.t
    xp, Pp = predict(tr.x, tr.P, dt, POLAR.q)
    index = PlotIndex(s, window_coefficients(POLAR))
    _, cols, _ = window_pairs(tr, Prediction(dt, xp, Pp), s, index, POLAR)
    k = np.sqrt(stats.chi2.ppf(POLAR.gate_P_G, 2))
    r_pred = 10020.0
    W_R = k * np.sqrt(SR**2 + 4 * SR**2 + SR**2)
    W_az = np.arcsin(30.0 / 10010.0) + k * np.sqrt(2) * SAZ
    d_az = np.abs((az - tr.az[0] + np.pi) % (2 * np.pi) - np.pi)
    brute = np.flatnonzero((np.abs(r - r_pred) <= W_R) & (d_az <= W_az))
    assert brute.size > 20 and (az[brute] < 0).any() and (az[brute] > 0).any()
    np.testing.assert_array_equal(np.sort(cols), brute)


def test_the_likelihood_gate_bound_is_at_least_every_pairs_gate():
    """Minkowski's |P + R| >= |P| + |R|: the bound that sizes the candidate search."""
    rng = np.random.default_rng(28)
    A = rng.normal(size=(50, 2, 2)) * 30.0
    P = A @ A.transpose(0, 2, 1)
    B = rng.normal(size=(40, 2, 2)) * 10.0
    R = B @ B.transpose(0, 2, 1) + np.eye(2)
    z = rng.uniform(0.0, 1e4, size=(40, 2))
    cfg = InitiationConfig(confirmation="score", surveillance_area=1e8)
    plots = cartesian_scan(1.0, z, R)
    bound = likelihood_gate_bound(P, plots, cfg)
    density = log_clutter_density(cfg, plots.size)
    every = ml_gate(np.linalg.det(P[:, None] + R[None]), cfg, density)
    assert (bound[:, None] >= every - 1e-9).all()
    empty = cartesian_scan(1.0, np.empty((0, 2)), np.empty((0, 2, 2)))
    assert np.isfinite(bound).all() and (likelihood_gate_bound(P, empty, cfg) == -np.inf).all()


def test_the_likelihood_gate_finds_exactly_the_brute_force_members_of_either_gate():
    """Score confirmation, Cartesian: a plot is in a track's gate when its rho is within
    the chi-square threshold or Blackman's maximum-likelihood gate of its own S, and the
    search bounded by likelihood_gate_bound misses none (sparse clutter: the
    maximum-likelihood gate is the wider)."""
    cfg = replace(CONFIG, confirmation="score", surveillance_area=1e10)
    rng = np.random.default_rng(28)
    state, _ = run(CONFIG, *[scan(t, target(t)) for t in range(3)])
    z = np.column_stack([rng.uniform(900.0, 1200.0, 4000), rng.uniform(1900.0, 2100.0, 4000)])
    R = R4 * rng.uniform(0.5, 4.0, (4000, 1, 1))
    s = cartesian_scan(3.0, z, R)
    tr = state.tracks
    dt = s.t - tr.t
    xp, Pp = predict(tr.x, tr.P, dt, cfg.q)
    prediction = Prediction(dt, xp, Pp)
    _, cols, stat = likelihood_pairs(tr, prediction, s, PlotIndex(s, None), cfg)
    S = Pp[0, :2, :2] + R
    nu = s.z - xp[0, :2]
    rho = np.einsum("ni,nij,nj->n", nu, np.linalg.inv(S), nu)
    gate = ml_gate(np.linalg.det(S), cfg, log_clutter_density(cfg, s.size))
    chi2 = stats.chi2.ppf(cfg.gate_P_G, 2)
    brute = np.flatnonzero(rho <= np.fmax(chi2, gate))
    narrow = ellipse_pairs(tr, prediction, s, PlotIndex(s, None), cfg).plot
    assert brute.size > np.flatnonzero(rho <= chi2).size == narrow.size > 5
    np.testing.assert_array_equal(np.sort(cols), brute)
    np.testing.assert_allclose(stat[np.argsort(cols)], rho[brute], rtol=1e-9)
