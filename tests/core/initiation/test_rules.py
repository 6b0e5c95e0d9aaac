"""select_rules: each choice of the settings picks its stage function once."""

from dataclasses import replace

import numpy as np
from initiation_helpers import CONFIG, POLAR, run, scan, target

from plotgate.core.initiation.capture import GateCapture, LikelyCapture, capture_pairs
from plotgate.core.initiation.pairs import ellipse_pairs, likelihood_pairs, window_pairs
from plotgate.core.initiation.rules import select_rules
from plotgate.core.initiation.search import PlotIndex
from plotgate.core.initiation.state import Initiators

SCORE = replace(CONFIG, confirmation="score", surveillance_area=1e8)


def test_only_cartesian_score_confirmation_widens_the_gates_to_the_likelihood_gate():
    picked = {
        name: select_rules(config)
        for name, config in {
            "k/m": CONFIG,
            "score": SCORE,
            "polar k/m": POLAR,
            "polar score": replace(POLAR, confirmation="score", surveillance_area=1e8),
        }.items()
    }
    assert picked["k/m"].track_pairs.func is ellipse_pairs
    assert picked["score"].track_pairs.func is likelihood_pairs
    assert picked["polar k/m"].track_pairs.func is window_pairs
    assert picked["polar score"].track_pairs.func is window_pairs
    assert isinstance(picked["score"].capture, LikelyCapture)
    for name in ("k/m", "polar k/m", "polar score"):
        assert isinstance(picked[name].capture, GateCapture)


def _initiators(config, *points):
    state, _ = run(config, scan(0.0, *points))
    ini: Initiators = state.initiators
    return ini


def test_likely_captures_add_to_the_gates_pairs_in_initiator_then_plot_order():
    rng = np.random.default_rng(29)
    ini = _initiators(SCORE, *[target(0.0 + 100.0 * i) for i in range(5)])
    z = np.column_stack([rng.uniform(900.0, 6000.0, 3000), rng.uniform(1900.0, 2100.0, 3000)])
    plots = scan(1.0, *z)
    index = PlotIndex(plots, None)
    allowed = rng.random(plots.size) < 0.9
    rules = select_rules(SCORE)
    gated = capture_pairs(ini, plots, index, allowed, 1, rules.capture.gate, rules.window)
    both = rules.capture(ini, plots, index, allowed, 1)
    key = both.row * plots.size + both.plot
    assert (np.diff(key) > 0).all() and allowed[both.plot].all()
    assert set(zip(gated.row, gated.plot, strict=True)) < set(
        zip(both.row, both.plot, strict=True)
    )
    np.testing.assert_allclose(
        both.statistic, np.linalg.norm(plots.z[both.plot] - ini.z[both.row], axis=1)
    )
