"""The gates' radii as a RadialForm: the compiled radii against their numpy reference."""

import math

import numpy as np
import pytest

from plotgate.core import (
    CombinedGate,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    RectangularGate,
    RingGate,
    SectorGate,
    mark_geometry,
)
from plotgate.core.gates.regions import radial_radii, radial_radii_reference

FORM_GATES = [
    RingGate(100.0, 500.0),
    CombinedGate(100.0, 500.0, 0.9),
    CombinedGate(20.0, 500.0, 0.999),  # h > R_min in some directions: lo clipped at 0
    ExpandedGate(500.0, 0.9),
    EllipseGate(0.9, offset=(0.0, 1500.0)),
    EllipseGate(0.99, S=[[4e5, 1e5], [1e5, 9e4]]),
    FirstAssociationGate(500.0, 3.0, 3.0),
    SectorGate(3.0, 3.0),
]


def geometry():
    return mark_geometry(
        [20e3, 50e3, 80e3],
        [0.3, 2.0, -1.0],
        [200.0, 50.0, 20.0],
        np.radians([0.5, 0.2, 1.0]),
        tau=5.0,
    )


@pytest.mark.parametrize("gate", FORM_GATES, ids=lambda g: type(g).__name__)
def test_compiled_radii_match_reference(gate):
    g = geometry()
    region = gate.region(g)
    theta = np.random.default_rng(31).uniform(-7.0, 7.0, (g.n, 40))
    lo, hi = radial_radii_reference(region.form, theta)
    for i in range(g.n):
        for j in range(theta.shape[1]):
            got = radial_radii(tuple(region.form), i, theta[i, j])
            np.testing.assert_allclose(got, (lo[i, j], hi[i, j]), rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("gate", FORM_GATES[:4], ids=lambda g: type(g).__name__)
def test_form_is_the_gates_test(gate):
    """Points just inside and just outside the radii, by the gate's own test."""
    g = geometry()
    region = gate.region(g)
    theta = np.random.default_rng(32).uniform(0.0, 2.0 * math.pi, (g.n, 30))
    lo, hi = region.radii(theta)
    u = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    for i in range(g.n):
        o = g.z1[i] + region.origin[i]
        inside = o + u[i] * (0.5 * (lo[i] + hi[i]))[:, None]
        outside = o + u[i] * (hi[i] * (1.0 + 1e-6))[:, None]
        assert gate.contains(g, i, inside).all()
        assert not gate.contains(g, i, outside).any()


def test_rectangle_has_no_form():
    assert RectangularGate(3.0).region(geometry()).form is None


@pytest.mark.parametrize("second", [False, True], ids=["same-sigmas", "own-sigmas"])
def test_one_mark_of_floats_is_the_array_geometry_to_the_bit(second):
    """A mark of Python floats (a request's) takes the scalar path; it builds the geometry
    the array path does, bit for bit, field by field."""
    rng = np.random.default_rng(33)
    for _ in range(200):
        r, az = float(rng.uniform(100.0, 2e5)), float(rng.uniform(-7.0, 7.0))
        sigma_r, sigma_az = float(rng.uniform(0.1, 500.0)), float(rng.uniform(1e-5, 0.05))
        extra = (float(rng.uniform(0.1, 500.0)), float(rng.uniform(1e-5, 0.05)))
        tau = float(rng.uniform(0.1, 10.0))
        extra = extra if second else (None, None)
        fast = mark_geometry(r, az, sigma_r, sigma_az, tau, *extra)
        slow = mark_geometry(np.array(r), az, sigma_r, sigma_az, tau, *extra)
        for name in (
            "r",
            "az",
            "sigma_r1",
            "sigma_az1",
            "sigma_r2",
            "sigma_az2",
            "z1",
            "P1",
            "P2",
        ):
            a, b = getattr(fast, name), getattr(slow, name)
            assert a.shape == b.shape and a.dtype == b.dtype
            np.testing.assert_array_equal(a, b, strict=True)
        for a, b in zip(fast.B, slow.B, strict=True):
            np.testing.assert_array_equal(a, b, strict=True)
        assert fast.tau == slow.tau
