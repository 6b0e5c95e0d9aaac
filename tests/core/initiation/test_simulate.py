"""The seeded scenario simulator: detections and clutter at their rates, reproducibly."""

import numpy as np

from plotgate.core.initiation.simulate import Scenario, simulate


def test_simulator_draws_detections_and_clutter_at_their_rates():
    # 2000 scans: detections ~ Binomial(5 x 2000, 0.8), clutter ~ Poisson(2000 x 30);
    # both means within 4 standard errors
    s = Scenario(
        x0=np.array([[5000.0, 5000.0]] * 5),
        v=np.zeros((5, 2)),
        scans=2000,
        interval=1.0,
        P_D=0.8,
        clutter=30.0,
        region=np.array([0.0, 10000.0, 0.0, 10000.0]),
        sensor=np.zeros(2),
        sigma_r=5.0,
        sigma_az=np.radians(0.2),
    )
    sim = simulate(s, 11)
    labels = np.concatenate(sim.labels)
    assert abs((labels >= 0).sum() - 8000) < 4 * np.sqrt(10000 * 0.8 * 0.2)
    assert abs((labels < 0).sum() - 60000) < 4 * np.sqrt(60000)
    z = np.concatenate([sc.z for sc in sim.scans])[labels < 0]
    assert z.min() >= 0.0 and z.max() <= 10000.0
    again = simulate(s, 11)
    np.testing.assert_array_equal(
        np.concatenate([sc.r for sc in again.scans]), np.concatenate([sc.r for sc in sim.scans])
    )
