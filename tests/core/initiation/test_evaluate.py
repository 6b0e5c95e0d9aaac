"""The Monte Carlo evaluation: targets initiated, false tracks, and sweeps of a setting."""

import pytest

from plotgate.core.errors import ParameterError
from plotgate.core.initiation import InitiationConfig
from plotgate.core.initiation.evaluate import evaluate, sweep, swept
from plotgate.core.initiation.simulate import Scenario, mu_scenario


def test_evaluation_without_clutter_initiates_every_target():
    s = mu_scenario(0.0)
    s = Scenario(**{**s.__dict__, "P_D": 1.0})
    ev = evaluate(
        s, InitiationConfig(mode="polar", v_max=30.0, a_max=10.0, K_A=3.0), runs=5, seed=1
    )
    assert ev.mean_true == 5.0 and ev.mean_false == 0.0 and ev.ceiling == 5.0
    # by distance (100 m) one track in 25 confirmed is too far: at 11 km the azimuth
    # error alone is 38 m and a three-plot velocity extrapolates it
    assert ev.mean_true_by_distance >= 4.6 and ev.mean_time_to_confirmation == 2.0


def test_each_point_of_a_sweep_is_the_evaluation_of_its_config_on_the_same_scans():
    scenario = mu_scenario(100.0)
    base = InitiationConfig(
        mode="polar",
        v_max=30.0,
        confirmation="score",
        P_D=0.8,
        surveillance_area=15000.0**2,
        new_target_density=1e-7,
        false_confirmation=1e-9,
        true_deletion=1e-9,
        capture_gate="combined",
    )
    values = [0.01, 0.3]
    first, *curve = sweep(scenario, base, "false_confirmation", values, 6, 11, baseline=True)
    for value, point in zip(values, curve, strict=True):
        alone = evaluate(scenario, swept(base, "false_confirmation", value), 6, 11)
        assert point.true.tolist() == alone.true.tolist()
        assert point.false.tolist() == alone.false.tolist()
        assert (point.mean_true, point.se_true) == (alone.mean_true, alone.se_true)
    assert first.true.tolist() == evaluate(scenario, base, 6, 11).true.tolist()
    # a looser threshold confirms at least as many tracks on the same scans
    assert (curve[1].true + curve[1].false >= curve[0].true + curve[0].false).all()
    k_of_m = sweep(scenario, InitiationConfig(v_max=30.0), "confirm", ["2/4", "4/4"], 4, 1)
    assert k_of_m[0].mean_true >= k_of_m[1].mean_true


@pytest.mark.parametrize(
    ("parameter", "values", "field", "index"),
    [
        ("confirm", ["3/4", "three"], "values", 1),
        ("confirm", ["5/4"], "values", 0),
        ("gate_P_G", [0.9, 1.0], "values", 1),
        ("confirm", ["\u00b2/4"], "values", 0),
        ("confirm", ["3/4/5"], "values", 0),
        ("nonsense", [1.0], "parameter", None),
        ("gate_P_G", [], "values", None),
    ],
)
def test_sweep_values_are_checked_and_named(parameter, values, field, index):
    with pytest.raises(ParameterError) as err:
        sweep(mu_scenario(20.0), InitiationConfig(), parameter, values, 2, 0)
    assert (err.value.field, err.value.index) == (field, index)
