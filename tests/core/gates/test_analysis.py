"""Tests of core.gates.analysis (Konovalov): gate areas, resolution cells, false marks,
capture probability and gate design, each against an independent computation."""

import math

import numpy as np
import pytest
from scipy import integrate, optimize, special, stats

from plotgate.core import (
    CombinedGate,
    EllipseGate,
    ExpandedGate,
    FirstAssociationGate,
    NonFiniteError,
    ParameterError,
    PlotgateError,
    RectangularGate,
    RingGate,
    SectorGate,
    capture_probability,
    combined_area_approximation,
    design_gate,
    false_marks,
    gate_area,
    mark_geometry,
    resolution_cells,
    unconditional_probability,
)

TAU = 5.0

# N problems at once: ranges, azimuths and sigmas all differ (B correlated unless az = 0)
R = np.array([300.0, 5e3, 20e3, 50e3, 80e3])
AZ = np.array([0.4, -2.0, 0.0, 3.0, 1.2])
SR1 = np.array([100.0, 20.0, 150.0, 200.0, 300.0])
SAZ1 = np.radians([0.5, 0.05, 0.3, 0.5, 1.0])
SR2 = np.array([80.0, 30.0, 100.0, 200.0, 250.0])
SAZ2 = np.radians([0.4, 0.1, 0.3, 0.5, 0.8])


def batch_geometry():
    return mark_geometry(R, AZ, SR1, SAZ1, tau=TAU, sigma_r2=SR2, sigma_az2=SAZ2)


def cartesian_covariance(r, az, sr, saz):
    """the polar-to-Cartesian Jacobian J: P = J diag(sr^2, saz^2) J^T,
    J = [[sin az, r cos az], [cos az, -r sin az]]."""
    J = np.array([[math.sin(az), r * math.cos(az)], [math.cos(az), -r * math.sin(az)]])
    return J @ np.diag([sr**2, saz**2]) @ J.T


def B_of(i):
    return cartesian_covariance(R[i], AZ[i], SR1[i], SAZ1[i]) + cartesian_covariance(
        R[i], AZ[i], SR2[i], SAZ2[i]
    )


def gamma(P_G):
    return stats.chi2.ppf(P_G, 2)


def annular_sector(r_c, W_R, W_az):
    """Area of ranges r_c +- W_R (clipped at 0) over azimuths +-W_az (at most a full turn)."""
    W_az = np.minimum(W_az, np.pi)
    return W_az * ((r_c + W_R) ** 2 - np.maximum(r_c - W_R, 0.0) ** 2)


# ---------------------------------------------------------------- gate_area: closed forms


def test_ring_area():
    area = gate_area(RingGate(100.0, 500.0), batch_geometry())
    assert area.shape == (len(R),)
    np.testing.assert_allclose(area, np.pi * TAU**2 * (500.0**2 - 100.0**2), rtol=1e-12)
    np.testing.assert_allclose(
        gate_area(RingGate(0.0, 300.0), batch_geometry()), np.pi * (300.0 * TAU) ** 2, rtol=1e-12
    )


@pytest.mark.parametrize("P_G", [0.5, 0.9, 0.999])
def test_ellipse_area(P_G):
    g = batch_geometry()
    expected = [np.pi * gamma(P_G) * math.sqrt(np.linalg.det(B_of(i))) for i in range(len(R))]
    area = gate_area(EllipseGate(P_G, offset=(300.0, -200.0)), g)
    np.testing.assert_allclose(area, expected, rtol=1e-12)
    S = np.array([[4e4, 1.5e4], [1.5e4, 9e3]])
    np.testing.assert_allclose(
        gate_area(EllipseGate(P_G, S=S), g),
        np.pi * gamma(P_G) * math.sqrt(np.linalg.det(S)),
        rtol=1e-12,
    )


@pytest.mark.parametrize(
    ("r", "sigma_r", "sigma_az_deg"),
    [(30e3, 10.0, 0.5), (80e3, 5.0, 1.0), (50e3, 200.0, 0.5)],
    ids=["axes-26-to-1", "axes-279-to-1", "paper"],
)
def test_ellipse_area_typical_radar(r, sigma_r, sigma_az_deg):
    # accurate range, poor azimuth: B's axes sqrt(2) sigma_r and sqrt(2) r sigma_az
    g = mark_geometry(r, 0.3, sigma_r, math.radians(sigma_az_deg), tau=TAU)
    expected = np.pi * gamma(0.9) * 2.0 * sigma_r * r * math.radians(sigma_az_deg)
    assert gate_area(EllipseGate(0.9), g)[0] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("p", [0.9, 0.95])
def test_expanded_area(p):
    K_g = math.sqrt(-2.0 * math.log(1.0 - p))
    a = 500.0 * TAU + K_g * SR1
    b = 500.0 * TAU + K_g * R * SAZ1
    np.testing.assert_allclose(
        gate_area(ExpandedGate(500.0, p), batch_geometry()), np.pi * a * b, rtol=1e-12
    )


def test_rectangular_area():
    g = batch_geometry()
    hx = np.array([2.5 * math.sqrt(B_of(i)[0, 0]) for i in range(len(R))])
    hy = np.array([2.5 * math.sqrt(B_of(i)[1, 1]) for i in range(len(R))])
    np.testing.assert_allclose(
        gate_area(RectangularGate(2.5, offset=(100.0, 0.0)), g), 4.0 * hx * hy, rtol=1e-12
    )
    np.testing.assert_allclose(
        gate_area(RectangularGate(3.0, sigma_x=40.0, sigma_y=70.0), g),
        4.0 * 120.0 * 210.0,
        rtol=1e-12,
    )


def test_sector_area():
    g = batch_geometry()
    offset = np.array([250.0, -120.0])
    z_pred = np.stack([R * np.sin(AZ), R * np.cos(AZ)], axis=-1) + offset
    r_pred = np.hypot(z_pred[:, 0], z_pred[:, 1])
    # prediction sigmas default to the first mark's
    expected = annular_sector(r_pred, 3.0 * np.hypot(SR2, SR1), 2.0 * np.hypot(SAZ2, SAZ1))
    area = gate_area(SectorGate(3.0, 2.0, offset=tuple(offset)), g)
    np.testing.assert_allclose(area, expected, rtol=1e-12)
    expected = annular_sector(r_pred, 3.0 * np.hypot(SR2, 50.0), 2.0 * np.hypot(SAZ2, 0.002))
    area = gate_area(
        SectorGate(3.0, 2.0, offset=tuple(offset), sigma_r_pred=50.0, sigma_az_pred=0.002), g
    )
    np.testing.assert_allclose(area, expected, rtol=1e-12)


def test_sector_area_with_full_turn_window():
    # W_az = 3 hypot(1, 1) rad > pi: the window is the full turn, so the sector is the
    # annulus r +- W_R (W_R = 3 hypot(100, 100) = 424 m), or the disc r + W_R when the
    # range window reaches the radar (r = 300 m)
    W_R = 3.0 * math.hypot(100.0, 100.0)
    g = mark_geometry([2e3, 300.0], 0.3, 100.0, 1.0, tau=TAU)
    expected = [np.pi * ((2e3 + W_R) ** 2 - (2e3 - W_R) ** 2), np.pi * (300.0 + W_R) ** 2]
    np.testing.assert_allclose(gate_area(SectorGate(3.0, 3.0), g), expected, rtol=1e-12)


def test_first_association_area():
    g = batch_geometry()
    R_max = 300.0 * TAU  # 1500 m: the first problem (r = 300 m) is within it
    W_R = R_max + 3.0 * np.hypot(SR1, SR2)
    W_az = np.arcsin(np.minimum(1.0, R_max / R)) + 3.0 * np.hypot(SAZ1, SAZ2)
    expected = annular_sector(R, W_R, W_az)
    assert R[0] < W_R[0]  # the range window reaches the radar: an inner radius of 0
    np.testing.assert_allclose(
        gate_area(FirstAssociationGate(300.0, 3.0, 3.0), g), expected, rtol=1e-12
    )


def _combined_area_quad(B, R_min, R_max, P_G):
    """Half the integral over direction of hi^2 - lo^2, hi = R_max + h, lo = max(0, R_min - h),
    h = sqrt(gamma / u^T B^-1 u), by scipy quad."""
    Q = np.linalg.inv(B)
    g = gamma(P_G)

    def integrand(t):
        u = np.array([math.cos(t), math.sin(t)])
        h = math.sqrt(g / (u @ Q @ u))
        return 0.5 * ((R_max + h) ** 2 - max(0.0, R_min - h) ** 2)

    # split at the kinks, where h = R_min (found on a fine grid, refined by brentq)
    grid = np.linspace(0.0, 2.0 * math.pi, 4001)
    gap = [math.sqrt(g / (u @ Q @ u)) - R_min for u in np.stack([np.cos(grid), np.sin(grid)], 1)]
    kinks = [
        optimize.brentq(
            lambda t: (
                math.sqrt(
                    g
                    / (
                        np.array([math.cos(t), math.sin(t)])
                        @ Q
                        @ np.array([math.cos(t), math.sin(t)])
                    )
                )
                - R_min
            ),
            a,
            b,
            xtol=1e-15,
        )
        for a, b, ga, gb in zip(grid[:-1], grid[1:], gap[:-1], gap[1:], strict=True)
        if ga * gb < 0.0
    ]
    edges = [0.0, *kinks, 2.0 * math.pi]
    value = 0.0
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        part, err = integrate.quad(integrand, a, b, epsabs=1e-9, epsrel=1e-12, limit=500)
        assert err < 1e-11 * part
        value += part
    return value


COMBINED_CASES = {
    # the paper's set-up: h > R_min in every direction, no hole (30 km below)
    "paper-50km": ((50e3, 0.0, 200.0, math.radians(0.5)), (100.0, 500.0), 0.9),
    # small errors: a hole of radius R_min - h in every direction
    "hole": ((20e3, 0.7, 20.0, math.radians(0.1)), (100.0, 500.0), 0.9),
    # eccentric B with h crossing R_min: kinks in the inner boundary
    "kinks": ((50e3, -1.1, 20.0, math.radians(0.5)), (100.0, 500.0), 0.95),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(COMBINED_CASES))
def test_combined_area_against_quad_and_monte_carlo(case):
    geo, (v_min, v_max), P_G = COMBINED_CASES[case]
    g = mark_geometry(*geo, tau=TAU)
    B = g.P1[0] + g.P2[0]
    R_min, R_max = v_min * TAU, v_max * TAU
    exact = gate_area(CombinedGate(v_min, v_max, P_G), g)[0]
    assert exact == pytest.approx(_combined_area_quad(B, R_min, R_max, P_G), rel=1e-9)
    # seeded Monte Carlo: uniform points in a box holding the gate, tested by the gate
    rng = np.random.default_rng(4242 + list(COMBINED_CASES).index(case))
    half = R_max + math.sqrt(gamma(P_G) * np.linalg.eigvalsh(B)[-1]) + 1.0
    n = 2_000_000
    pts = g.z1[0] + rng.uniform(-half, half, (n, 2))
    inside = CombinedGate(v_min, v_max, P_G).test(g.z1[0], g.P1[0], pts, g.P2[0], TAU).inside
    p = inside.mean()
    box = (2.0 * half) ** 2
    assert abs(exact - box * p) <= 4.0 * box * math.sqrt(p * (1.0 - p) / n)


def test_combined_area_without_hole_has_elliptic_integral_closed_form():
    # where h >= R_min in every direction the gate is the disc R_max grown by h(u):
    # S = pi R_max^2 + R_max sqrt(gamma) int 1 / sqrt(u^T B^-1 u) + pi gamma sqrt|B|, and
    # int_0^2pi d theta / sqrt(cos^2/a^2 + sin^2/b^2) = 4 b K(1 - b^2 / a^2) (a >= b the
    # semi-axes sqrt(lambda) of B; K the complete elliptic integral of the first kind)
    g = mark_geometry(50e3, 0.6, 200.0, math.radians(0.5), tau=TAU)
    b, a = np.sqrt(np.linalg.eigvalsh(g.P1[0] + g.P2[0]))
    gam = gamma(0.9)
    R_min, R_max = 500.0, 2500.0
    assert math.sqrt(gam) * b > R_min
    expected = (
        np.pi * R_max**2
        + R_max * math.sqrt(gam) * 4.0 * b * special.ellipk(1.0 - b**2 / a**2)
        + np.pi * gam * a * b
    )
    assert gate_area(CombinedGate(100.0, 500.0, 0.9), g)[0] == pytest.approx(expected, rel=1e-12)


def test_combined_area_approximation_formula():
    g = batch_geometry()
    expected = [
        np.pi * (2500.0**2 - 500.0**2)
        + 0.5 * np.pi * math.sqrt(np.linalg.det(gamma(0.9) * B_of(i)))
        for i in range(len(R))
    ]
    np.testing.assert_allclose(
        combined_area_approximation(CombinedGate(100.0, 500.0, 0.9), g), expected, rtol=1e-12
    )


def test_gate_area_bad_gate_parameters_named():
    g = batch_geometry()
    for gate, field in [
        (CombinedGate(100.0, 500.0, 1.0), "P_G"),
        (EllipseGate(0.0), "P_G"),
        (ExpandedGate(500.0, 1.2), "p"),
        (RingGate(600.0, 500.0), "v_min"),
        (RectangularGate(-1.0), "k"),
        (SectorGate(3.0, 0.0), "K_az"),
        (FirstAssociationGate(-5.0, 3.0, 3.0), "v_max"),
    ]:
        with pytest.raises(ParameterError) as info:
            gate_area(gate, g)
        assert info.value.field == field, gate


# ---------------------------------------------------------------- the paper's comparison

PAPER_R, PAPER_DR, PAPER_DAZ, PAPER_F = 50e3, 500.0, math.radians(1.5), 1e-4


def paper_cells(area):
    return resolution_cells(area, PAPER_R, PAPER_DR, PAPER_DAZ)


def test_paper_expanded_against_combined_false_marks():
    # Konovalov: tau 5 s, v 100..500 m/s, sigma_r 200 m, sigma_az 0.5 deg, r 50 km,
    # dR 500 m, dAz 1.5 deg, F 1e-4: 49 cells against 31, P(>= 1 false) 0.0049 against 0.0031
    g = mark_geometry(PAPER_R, 0.0, 200.0, math.radians(0.5), tau=TAU)
    expanded = paper_cells(gate_area(ExpandedGate(500.0, 0.9), g)).item()
    combined = paper_cells(combined_area_approximation(CombinedGate(100.0, 500.0, 0.9), g)).item()
    assert abs(expanded - 49.0) <= 1.0  # 48.32
    assert abs(combined - 31.0) <= 1.0  # 30.73
    assert abs(false_marks(expanded, PAPER_F).at_least_one - 0.0049) <= 2e-4
    assert abs(false_marks(combined, PAPER_F).at_least_one - 0.0031) <= 2e-4
    # the paper's ratio "1.5 times"
    assert expanded / combined == pytest.approx(1.5, abs=0.1)


def test_paper_combined_gate_exact_area_is_larger_than_its_approximation():
    # The EXACT combined gate is the ring grown by h(u) = sqrt(gamma / u^T B^-1 u) in every
    # direction (outward and inward), not the ring plus half an ellipse: growing the outer
    # circle adds about R_max * int h d theta (the band along the whole circumference) on
    # top of the ellipse, and here h_min = sqrt(gamma lambda_min) = 607 m > R_min = 500 m
    # closes the hole. Found: 3.5725e7 m^2 = 54.58 cells (P(>= 1 false) 0.00544), larger
    # even than the expanded gate's 48.32 cells; the paper's 31 is the approximation.
    g = mark_geometry(PAPER_R, 0.0, 200.0, math.radians(0.5), tau=TAU)
    gate = CombinedGate(100.0, 500.0, 0.9)
    exact = gate_area(gate, g)[0]
    approx = combined_area_approximation(gate, g)[0]
    assert exact > approx
    assert exact == pytest.approx(3.5724927e7, rel=1e-6)
    cells = paper_cells(exact).item()
    assert cells == pytest.approx(54.584, abs=0.01)
    assert false_marks(cells, PAPER_F).at_least_one == pytest.approx(0.005444, abs=1e-6)
    assert cells > paper_cells(gate_area(ExpandedGate(500.0, 0.9), g)).item()


# ---------------------------------------------------------------- cells, false marks, capture


def test_resolution_cells_arithmetic():
    assert resolution_cells(1e6, 1e4, 100.0, 0.01) == pytest.approx(100.0, rel=1e-15)
    area = np.array([1e6, 2.5e7, 0.0])
    r = np.array([1e4, 5e4, 3e4])
    np.testing.assert_allclose(
        resolution_cells(area, r, 500.0, math.radians(1.5)),
        area / (500.0 * r * math.radians(1.5)),
        rtol=1e-15,
    )
    np.testing.assert_allclose(
        resolution_cells(area, 5e4, 250.0, 0.02), area / (250.0 * 5e4 * 0.02), rtol=1e-15
    )


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"dR": 0.0}, ParameterError, "dR"),
        ({"dAz": -0.01}, ParameterError, "dAz"),
        ({"r": 0.0}, ParameterError, "r"),
        ({"area": -1.0}, ParameterError, "area"),
        ({"dR": [1.0, 2.0]}, ParameterError, "dR"),
        ({"area": np.nan}, NonFiniteError, "area"),
        ({"dAz": np.inf}, NonFiniteError, "dAz"),
    ],
)
def test_resolution_cells_bad_inputs(kwargs, error, field):
    args = {"area": 1e6, "r": 1e4, "dR": 100.0, "dAz": 0.01}
    args.update(kwargs)
    with pytest.raises(error) as info:
        resolution_cells(**args)
    assert info.value.field == field


@pytest.mark.parametrize("F", [1e-10, 1e-4, 0.3])
def test_false_marks_against_scipy_poisson(F):
    cells = np.array([0.0, 1.0, 30.7, 48.3, 1e4])
    res = false_marks(cells, F, m_max=7)
    mean = F * cells
    np.testing.assert_allclose(res.mean, mean, rtol=1e-15)
    assert res.probabilities.shape == (5, 8)
    np.testing.assert_allclose(
        res.probabilities,
        stats.poisson.pmf(np.arange(8)[None, :], mean[:, None]),
        rtol=1e-12,
        atol=1e-300,
    )
    np.testing.assert_allclose(res.at_least_one, stats.poisson.sf(0, mean), rtol=1e-12)
    assert res.at_least_one[0] == 0.0


def test_false_marks_scalar_and_default_m_max():
    res = false_marks(49.0, 1e-4)
    assert res.probabilities.shape == (6,)
    assert float(res.at_least_one) == pytest.approx(-math.expm1(-49e-4), rel=1e-14)
    assert res.probabilities.sum() == pytest.approx(1.0 - stats.poisson.sf(5, 49e-4), rel=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "error", "field"),
    [
        ({"F": 0.0}, ParameterError, "F"),
        ({"F": 1.0}, ParameterError, "F"),
        ({"F": [1e-4, 1e-3]}, ParameterError, "F"),
        ({"cells": -1.0}, ParameterError, "cells"),
        ({"cells": [1.0, np.nan]}, NonFiniteError, "cells"),
        ({"m_max": -1}, ParameterError, "m_max"),
        ({"m_max": 2.5}, ParameterError, "m_max"),
        ({"m_max": True}, ParameterError, "m_max"),
    ],
)
def test_false_marks_bad_inputs(kwargs, error, field):
    args = {"cells": 10.0, "F": 1e-4, "m_max": 3}
    args.update(kwargs)
    with pytest.raises(error) as info:
        false_marks(**args)
    assert info.value.field == field


def test_capture_probability():
    assert capture_probability(0.9967, 0.9, 0.8) == pytest.approx(0.9967 * 0.72, rel=1e-15)
    np.testing.assert_allclose(
        capture_probability([0.82, 0.9967], 0.9, [0.8, 1.0]),
        [0.82 * 0.9 * 0.8, 0.9967 * 0.9],
        rtol=1e-15,
    )
    assert capture_probability(1.0, 1.0, 0.0) == 0.0


@pytest.mark.parametrize(
    ("args", "error", "field"),
    [
        ((1.2, 0.9, 0.9), ParameterError, "P_gate"),
        ((0.9, -0.1, 0.9), ParameterError, "P_D1"),
        ((0.9, 0.9, [0.5, 1.01]), ParameterError, "P_D2"),
        ((0.9, 0.9, np.nan), NonFiniteError, "P_D2"),
    ],
)
def test_capture_probability_bad_inputs(args, error, field):
    with pytest.raises(error) as info:
        capture_probability(*args)
    assert info.value.field == field


# ---------------------------------------------------------------- design_gate


def paper_geometry():
    return mark_geometry(PAPER_R, 0.0, 200.0, math.radians(0.5), tau=TAU)


def _check_design(design, geometry, capture, v_min, v_max, prior, P_D1=1.0, P_D2=1.0):
    # recompute the designed gate's probability independently of the design's own report
    res = unconditional_probability(design.gate, geometry, v_min, v_max, prior)
    assert abs(res.probability[0] * P_D1 * P_D2 - capture) <= 1e-5
    assert abs(design.capture - capture) <= 1e-5
    assert design.probability == pytest.approx(res.probability[0], abs=1e-12)
    assert design.error < 1e-6
    assert design.area == pytest.approx(gate_area(design.gate, geometry)[0], rel=1e-12)


@pytest.mark.slow
def test_design_combined_gate_reaches_capture_and_grows_with_it():
    g = paper_geometry()
    template = CombinedGate(100.0, 500.0, 0.5)
    low = design_gate(template, g, 0.99, 100.0, 500.0, "area")
    high = design_gate(template, g, 0.995, 100.0, 500.0, "area")
    for design, capture in ((low, 0.99), (high, 0.995)):
        assert isinstance(design.gate, CombinedGate)
        assert (design.gate.v_min, design.gate.v_max) == (100.0, 500.0)
        assert design.parameter == design.gate.P_G
        _check_design(design, g, capture, 100.0, 500.0, "area")
    assert high.parameter > low.parameter
    assert high.area > low.area


@pytest.mark.slow
def test_design_with_detection_probabilities():
    g = paper_geometry()
    design = design_gate(
        CombinedGate(100.0, 500.0, 0.9), g, 0.85, 100.0, 500.0, "speed", P_D1=0.9, P_D2=0.95
    )
    _check_design(design, g, 0.85, 100.0, 500.0, "speed", 0.9, 0.95)
    assert design.probability == pytest.approx(0.85 / 0.855, abs=1e-5)


@pytest.mark.slow
def test_design_expanded_gate_reaches_capture_and_grows_with_it():
    g = paper_geometry()
    template = ExpandedGate(500.0, 0.5)
    low = design_gate(template, g, 0.97, 100.0, 500.0, "speed")
    high = design_gate(template, g, 0.99, 100.0, 500.0, "speed")
    for design, capture in ((low, 0.97), (high, 0.99)):
        assert isinstance(design.gate, ExpandedGate) and design.gate.v_max == 500.0
        assert design.parameter == design.gate.p
        _check_design(design, g, capture, 100.0, 500.0, "speed")
    assert high.parameter > low.parameter
    assert high.area > low.area


@pytest.mark.parametrize(
    ("gate", "capture", "P_D"),
    [
        (CombinedGate(100.0, 500.0, 0.9), 0.9, 0.9),  # above P_D1 P_D2 = 0.81
        (CombinedGate(100.0, 500.0, 0.9), 0.81, 0.9),  # exactly P_D1 P_D2
        (CombinedGate(100.0, 500.0, 0.9), 0.5, 1.0),  # the ring alone gives 0.82
        (ExpandedGate(500.0, 0.9), 0.5, 1.0),  # the circle R_max alone gives 0.85
        (CombinedGate(100.0, 500.0, 0.9), 1.0, 1.0),
        (CombinedGate(100.0, 500.0, 0.9), 0.0, 1.0),
    ],
    ids=["above-detection", "at-detection", "ring-suffices", "circle-suffices", "one", "zero"],
)
def test_design_unreachable_capture(gate, capture, P_D):
    with pytest.raises(ParameterError) as info:
        design_gate(gate, paper_geometry(), capture, 100.0, 500.0, "area", P_D1=P_D, P_D2=P_D)
    assert info.value.field == "capture"
    assert isinstance(info.value, PlotgateError)


def test_design_needs_one_problem():
    g = mark_geometry([20e3, 50e3], 0.0, 200.0, 0.01, tau=TAU)
    with pytest.raises(ParameterError) as info:
        design_gate(CombinedGate(100.0, 500.0, 0.9), g, 0.99, 100.0, 500.0)
    assert info.value.field == "geometry"
