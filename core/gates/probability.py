"""Probability that the second mark falls in a gate (Konovalov, eq. 1-6).

The second mark is d = z2 - z1 ~ N(v tau, B) about the first (Konovalov, eq. 1), so

- the conditional probability for a known velocity v is the integral of that
  density over the gate (eq. 2);
- the unconditional one averages it over a uniform heading and a speed prior on
  [v_min, v_max] (eq. 3-6): ``prior="area"`` puts the true displacement x = v tau
  uniformly over the ring (the paper's eq. 4, speed density proportional to v),
  ``prior="speed"`` makes the speed uniform.

Both are computed by deterministic quadrature in the gate's polar coordinates
(:class:`plotgate.core.gates.regions.StarRegion`). Along a ray o + t u the Gaussian has a
closed-form integral,

.. math:: \\int_{t_1}^{t_2} t^k e^{-q(t)/2} dt, \\quad
          q(t) = (t\\mathbf{u} - \\mathbf{m})^T \\mathbf{B}^{-1} (t\\mathbf{u} - \\mathbf{m}),
          \\; k = 0, 1,

with erf and exp only (:func:`plotgate.core.gates.heading.ray_moments_reference`). The
conditional probability is then a 1-D integral over direction; the unconditional one
integrates the gate's directions and radii and the prior's heading
(:mod:`plotgate.core.gates.heading`), with the prior's speed in closed form. Every
integral uses composite Gauss-Legendre panels graded towards its thin features
(:mod:`plotgate.core.gates.quadrature`): the Gaussian's angular peak, the kinks of the
gate's boundary, and the edges of the prior's ring. The conditional probability bisects
its panels until a 10-point and a 5-point rule agree to 1e-10 and reports the sum of
their differences (the error of the lower order: a bound in practice). The unconditional
one reports its difference from a second, lower-order rule on interleaved panels: an
estimate, not a bound; where both rules read one density table cut to the gate's nodes,
the table's stated error (:data:`TABLE_ERROR`) is added, which their difference cannot
see. Checked against 14-point rules it was within a factor 5 of the true error wherever
that exceeded 1e-9, and the true error stayed below 1e-7 on every tested case (the
target is 1e-6).

:func:`monte_carlo_probability` samples the same set-up and applies the gate tests
themselves; it is for checking the quadrature, not for production use.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import kernel
from plotgate.core.errors import ParameterError
from plotgate.core.gates.heading import (
    ECCENTRIC,
    SMEARED,
    TAIL,
    PriorRing,
    cached_table,
    density_table,
    interpolated_density,
    principal_axes,
    prior_density,
    prior_density_reference,
    prior_ring,
    ray_moments,
    ray_moments_reference,
    ring_features,
    table_size,
    tabulates,
)
from plotgate.core.gates.kinds import Gate
from plotgate.core.gates.parameters import ring_radii
from plotgate.core.gates.quadrature import (
    RATIO,
    adaptive_panels,
    angle_breaks,
    breakpoints,
    gauss_legendre,
    panel_rule,
)
from plotgate.core.gates.regions import (
    RADIAL_FORM,
    MarkGeometry,
    StarRegion,
    radial_radii,
    radial_radii_along,
)
from plotgate.core.sym2 import Sym2, inverse
from plotgate.core.validation import as_points, pair_count

__all__ = [
    "GateProbability",
    "Prior",
    "conditional_integral",
    "conditional_integral_reference",
    "conditional_probability",
    "conditional_probability_reference",
    "monte_carlo_probability",
    "unconditional_probability",
    "unconditional_quadrature",
]

Prior = Literal["area", "speed"]
PRIORS: tuple[str, ...] = ("area", "speed")

RULES = ((8, 1.0), (7, np.sqrt(3.0)))
"""(Gauss-Legendre order per panel, scale of the grading widths) of the two rules of the
unconditional probability: the result, and the reference whose difference from it is the
error estimate. The reference's panels interleave with the result's, so the estimate
catches a feature the panels miss as well as too low an order."""
Rules = tuple[tuple[int, float], ...]
TABLE_GAIN = 2
"""The unconditional probability tabulates the density when the gate's nodes (both rules)
number at least this many times the table's points: a table point costs a density (as a
node does) and interpolating 0.1-0.2 us a node, so below it the table would not pay."""
SEARCH_CALLS = 20
"""Calls on one problem a ``table=True`` quadrature expects: gates.design's search makes
about twenty, and its table pays over all of them."""
TABLE_ERROR = 1e-9
"""Error of a density table cut to the gate's nodes, relative to the density's bound
2 pi (c0 + c1 R_max) sqrt(2 pi lambda_max): B's principal axes hold 1e-9 of it and the
interpolation 1e-10 (:func:`plotgate.core.gates.heading.density_table`,
tests/core/gates/test_heading.py). Both rules read the one table, so their difference
cannot see its error: the unconditional probability adds it to its estimate, times the
gate's area over the Gaussian's normalization."""
TABLE_MOST = 1 << 21
"""Most points of a density table (16 MiB): an extremely eccentric B (sigma_min of
millimetres) would need millions; its nodes are evaluated directly instead."""
M_CONDITIONAL = (10, 5)
"""Gauss-Legendre orders of the adaptive conditional probability's two rules."""
_CONDITIONAL_TOL = 1e-10
"""Absolute error the conditional probability's panels are refined to."""


@dataclass(frozen=True)
class GateProbability:
    """Gating probabilities of N problems.

    Attributes
    ----------
    probability : (N,) ndarray
        Probability that the second mark falls in the gate.
    error : (N,) ndarray
        Estimated absolute quadrature error.
    """

    probability: np.ndarray
    error: np.ndarray


class ConditionalProblems(NamedTuple):
    """N conditional problems as the compiled bisection reads them ((N,) each): the mean
    of d relative to the region's origin, and B^-1 with its determinant."""

    mx: np.ndarray
    my: np.ndarray
    qxx: np.ndarray
    qxy: np.ndarray
    qyy: np.ndarray
    qdet: np.ndarray


CONDITIONAL_PROBLEMS = "UniTuple(float64[:], 6)"
"""numba type of :class:`ConditionalProblems`."""
_PANEL_RULES = "UniTuple(float64[:], 4)"
"""numba type of the two Gauss-Legendre rules (nodes, weights, nodes, weights)."""
MAX_ROUNDS = 40
"""Bisections of a starting panel at most (a panel this deep is accepted as it is)."""
MAX_PANELS = 100_000
"""Panels the bisection evaluates at most (per batch in the reference, per problem in the
kernel); past it the open panels are accepted as they are, their differences counted."""


def _conditional_integrand(
    region: StarRegion, Q: Sym2, rel: np.ndarray
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Closed-form radial integral M1 over the gate along rays theta, for given problems."""

    def integrand(rows: np.ndarray, theta: np.ndarray) -> np.ndarray:
        lo, hi = region.radii(theta, rows)
        Qr = Sym2(*(x[rows][:, None] for x in Q))
        _, M1 = ray_moments_reference(
            np.cos(theta), np.sin(theta), rel[rows, :1], rel[rows, 1:], Qr, lo, hi
        )
        return M1

    return integrand


@kernel(f"float64({CONDITIONAL_PROBLEMS}, {RADIAL_FORM}, int64, float64)")
def _ray_integral(
    problems: tuple[np.ndarray, ...], form: tuple[np.ndarray, ...], i: int, theta: float
) -> float:
    """M1 of problem i along direction theta, over the gate's radii."""
    ux, uy = math.cos(theta), math.sin(theta)
    lo, hi = radial_radii_along(form, i, ux, uy)
    gauss = (problems[2][i], problems[3][i], problems[4][i], problems[5][i], 0.0, 0.0, 0.0)
    return ray_moments(ux, uy, problems[0][i], problems[1][i], gauss, lo, hi)[1]


@kernel(
    f"UniTuple(float64, 2)({CONDITIONAL_PROBLEMS}, {RADIAL_FORM}, int64, float64, float64, "
    f"{_PANEL_RULES})"
)
def _panel_sums(
    problems: tuple[np.ndarray, ...],
    form: tuple[np.ndarray, ...],
    i: int,
    a: float,
    b: float,
    rules: tuple[np.ndarray, ...],
) -> tuple[float, float]:
    """The higher- and lower-order rules' integrals over the panel [a, b]."""
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    high, low = 0.0, 0.0
    for j in range(rules[0].size):
        high += rules[1][j] * _ray_integral(problems, form, i, mid + half * rules[0][j])
    for j in range(rules[2].size):
        low += rules[3][j] * _ray_integral(problems, form, i, mid + half * rules[2][j])
    return half * high, half * low


@kernel(
    f"UniTuple(float64[:], 2)({CONDITIONAL_PROBLEMS}, {RADIAL_FORM}, float64[:, :], float64[:], "
    f"{_PANEL_RULES})"
)
def conditional_integral(
    problems: tuple[np.ndarray, ...],
    form: tuple[np.ndarray, ...],
    edges: np.ndarray,
    tol: np.ndarray,
    rules: tuple[np.ndarray, ...],
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`conditional_integral_reference` compiled, problem by problem: each starting
    panel is bisected depth first (a stack of open panels, at most :data:`MAX_ROUNDS`
    deep) rather than all panels round by round; the same panels are accepted unless
    :data:`MAX_PANELS` is reached, so the sums agree to rounding."""
    n, n_edges = edges.shape
    integral, error = np.zeros(n), np.zeros(n)
    stack_a = np.empty(n_edges + MAX_ROUNDS + 1)
    stack_b = np.empty(n_edges + MAX_ROUNDS + 1)
    depth = np.empty(n_edges + MAX_ROUNDS + 1, dtype=np.int64)
    for i in range(n):
        share = tol[i] / (edges[i, -1] - edges[i, 0])
        top = 0
        for e in range(n_edges - 2, -1, -1):  # pushed last to first: popped in order
            if edges[i, e + 1] > edges[i, e]:
                stack_a[top], stack_b[top], depth[top] = edges[i, e], edges[i, e + 1], 0
                top += 1
        evaluated = 0
        while top > 0:
            top -= 1
            a, b, level = stack_a[top], stack_b[top], depth[top]
            high, low = _panel_sums(problems, form, i, a, b, rules)
            evaluated += 1
            diff = abs(high - low)
            if diff <= share * (b - a) or level == MAX_ROUNDS - 1 or evaluated >= MAX_PANELS:
                integral[i] += high
                error[i] += diff
                continue
            mid = 0.5 * (a + b)
            stack_a[top], stack_b[top], depth[top] = mid, b, level + 1
            stack_a[top + 1], stack_b[top + 1], depth[top + 1] = a, mid, level + 1
            top += 2
    return integral, error


def conditional_integral_reference(
    region: StarRegion, Q: Sym2, rel: np.ndarray, edges: np.ndarray, tol: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The integral over the gate of the unnormalized Gaussian of mean ``rel`` (relative
    to the region's origin) and inverse covariance Q, and its error, with numpy: the
    starting panels ``edges`` bisected round by round
    (:func:`plotgate.core.gates.quadrature.adaptive_panels`) until the rules of
    :data:`M_CONDITIONAL` agree within ``tol``."""
    return adaptive_panels(
        _conditional_integrand(region, Q, rel),
        edges,
        tol,
        orders=M_CONDITIONAL,
        max_rounds=MAX_ROUNDS,
        max_panels=MAX_PANELS,
    )


_READ_1D = "Array(float64, 1, 'A', readonly=True)"
_READ_2D = "Array(float64, 2, 'A', readonly=True)"
MEAN_AND_B = f"UniTuple({_READ_1D}, 5)"
"""numba type of N conditional problems as :func:`conditional_quadrature` reads them
((N,) each): the mean of d relative to the region's origin (x, y), and B (xx, xy, yy)."""
_UNIFORM = 4
_TWO_PI = 2.0 * math.pi
"""Equal starting panels of the conditional probability's full turn."""


def conditional_edges_reference(region: StarRegion, B: Sym2, rel: np.ndarray) -> np.ndarray:
    """Starting panels of the conditional probability, (N, E), with numpy.

    The Gaussian subtends about sigma / |m| seen from the origin, or sigma / lo where the
    inner edge lo of the gate cuts it (then about B's major axis): panels graded about
    the mean's direction and B's major axis by that width
    (:func:`plotgate.core.gates.quadrature.angle_breaks`), plus the region's kinks.
    """
    lam_min, _, major = principal_axes(B)
    centres = [np.arctan2(rel[:, 1], rel[:, 0]), major, major + np.pi]
    inner = region.radii(np.stack(centres, axis=-1))[0].min(axis=-1)
    reach = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), np.maximum(inner, 1e-300))
    with np.errstate(over="ignore"):  # a Gaussian about the origin: infinitely wide, no grading
        width = np.sqrt(lam_min) / reach
    return angle_breaks(
        region.start, region.span, centres, [width] * 3, region.kinks, uniform=_UNIFORM
    )


@kernel(f"float64[:, :]({MEAN_AND_B}, {RADIAL_FORM}, {_READ_1D}, {_READ_1D}, {_READ_2D})")
def conditional_edges(
    problems: tuple[np.ndarray, ...],
    form: tuple[np.ndarray, ...],
    start: np.ndarray,
    span: np.ndarray,
    kinks: np.ndarray,
) -> np.ndarray:
    """:func:`conditional_edges_reference` compiled: the same centres, widths, grading
    levels (over the whole batch, as :func:`plotgate.core.gates.quadrature.breakpoints`
    counts them), wrapping, clipping and merging of edges within 1e-12 of the span, so
    the same panels; each row padded with its last edge to the widest row."""
    mx, my, bxx, bxy, byy = problems
    n = mx.size
    centres = np.empty((n, 3))
    width = np.empty(n)
    ratio = 0.0
    graded = False
    for i in range(n):
        half_diff = 0.5 * (bxx[i] - byy[i])
        lam_max = 0.5 * (bxx[i] + byy[i]) + math.hypot(half_diff, bxy[i])
        lam_min = (bxx[i] * byy[i] - bxy[i] * bxy[i]) / lam_max
        major = 0.5 * math.atan2(bxy[i], half_diff)
        centres[i, 0] = math.atan2(my[i], mx[i])
        centres[i, 1] = major
        centres[i, 2] = major + math.pi
        inner = math.inf
        for c in range(3):
            inner = min(inner, radial_radii(form, i, centres[i, c])[0])
        reach = max(math.hypot(mx[i], my[i]), max(inner, 1e-300))
        width[i] = math.sqrt(lam_min) / reach
        if math.isfinite(width[i]) and width[i] > 0.0:
            graded = True
            ratio = max(ratio, ((start[i] + span[i]) - start[i]) / width[i])
    levels = 0
    if graded:
        levels = (
            1 if ratio <= 1.0 else min(40, int(math.ceil(math.log(ratio) / math.log(RATIO))) + 1)
        )
    count = 2 + 3 * (1 + 2 * levels) + kinks.shape[1] + _UNIFORM - 1
    pts = np.empty((n, count))
    most = 1
    for i in range(n):
        lo, hi = start[i], start[i] + span[i]
        full = hi - lo
        row = pts[i]
        row[0], row[1] = lo, hi
        k = 2
        for c in range(3):
            row[k] = centres[i, c]
            k += 1
        for c in range(3):
            for sign in (1.0, -1.0):
                for j in range(levels):
                    offset = width[i] * RATIO**j
                    if not (math.isfinite(offset) and offset > 0.0):
                        offset = 0.0
                    row[k] = centres[i, c] + sign * min(offset, math.pi)
                    k += 1
        for j in range(kinks.shape[1]):
            row[k] = kinks[i, j]
            k += 1
        for j in range(1, _UNIFORM):
            row[k] = lo + full * (j / _UNIFORM)
            k += 1
        for j in range(2, count):
            x = lo if math.isnan(row[j]) else row[j]
            row[j] = min(max(lo + (x - lo) % _TWO_PI, lo), hi)
        row.sort()
        tol = 1e-12 * (row[-1] - row[0])
        kept = 1
        for j in range(1, count):
            if row[j] - row[j - 1] > tol:
                row[kept] = row[j]
                kept += 1
        row[kept:] = row[kept - 1]
        most = max(most, kept)
    return pts[:, :most].copy()


@kernel(
    f"UniTuple(float64[:], 2)({MEAN_AND_B}, {RADIAL_FORM}, {_READ_1D}, {_READ_1D}, "
    f"{_READ_2D}, {_PANEL_RULES}, float64)"
)
def conditional_quadrature(
    problems: tuple[np.ndarray, ...],
    form: tuple[np.ndarray, ...],
    start: np.ndarray,
    span: np.ndarray,
    kinks: np.ndarray,
    rules: tuple[np.ndarray, ...],
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`conditional_quadrature_reference` compiled: the starting panels
    (:func:`conditional_edges`), B^-1, the bisection (:func:`conditional_integral`) of
    ``rules`` to ``tol`` of the probability, and the Gaussian's normalization in one
    call: the probabilities and their errors."""
    mx, my, bxx, bxy, byy = problems
    edges = conditional_edges(problems, form, start, span, kinks)
    det = bxx * byy - bxy * bxy
    norm = 2.0 * np.pi * np.sqrt(det)
    Q = (byy / det, -bxy / det, bxx / det, 1.0 / det)
    gauss = (mx.copy(), my.copy(), *Q)
    integral, error = conditional_integral(gauss, form, edges, tol * norm, rules)
    return integral / norm, error / norm


def conditional_quadrature_reference(
    region: StarRegion, B: Sym2, rel: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The probability that the second mark, N(rel, B) about the region's origin, falls in
    the region, and its error, with numpy: :func:`conditional_edges_reference`'s panels
    bisected by :func:`conditional_integral_reference` to 1e-10, over the Gaussian's
    normalization 2 pi sqrt(|B|) (Konovalov, eq. 2)."""
    edges = conditional_edges_reference(region, B, rel)
    norm = 2.0 * np.pi * np.sqrt(B.det)
    integral, error = conditional_integral_reference(
        region, inverse(B), rel, edges, _CONDITIONAL_TOL * norm
    )
    return integral / norm, error / norm


def _conditional(
    gate: Gate, geometry: MarkGeometry, velocity: ArrayLike, reference: bool
) -> GateProbability:
    """:func:`conditional_probability`, compiled or (``reference``, or a region without a
    :class:`plotgate.core.gates.regions.RadialForm`: the rectangle) with numpy."""
    v = as_points("velocity", velocity)
    n = pair_count(geometry=(geometry.n,) if geometry.n > 1 else (), velocity=v.shape[:-1])
    if geometry.n != n:  # one geometry, many velocities (a curve against speed)
        geometry = geometry.take(np.zeros(n, dtype=int))
    region = gate.region(geometry)
    rel = v * geometry.tau - region.origin  # (N, 2): the region has N origins
    if reference or region.form is None:
        return GateProbability(*conditional_quadrature_reference(region, geometry.B, rel))
    B = geometry.B
    problems = (rel[:, 0], rel[:, 1], B.xx, B.xy, B.yy)
    return GateProbability(
        *conditional_quadrature(
            problems,
            tuple(region.form),
            region.start,
            region.span,
            region.kinks,
            tuple(x for m in M_CONDITIONAL for x in gauss_legendre(m)),
            _CONDITIONAL_TOL,
        )
    )


def conditional_probability(
    gate: Gate, geometry: MarkGeometry, velocity: ArrayLike
) -> GateProbability:
    """Probability that the second mark falls in the gate for a known velocity (eq. 2).

    .. math:: P = \\iint_{gate} \\mathcal N(\\mathbf d;\\, \\mathbf v\\tau, \\mathbf B)
              \\, d\\mathbf d

    Parameters
    ----------
    gate : Gate
        A gate of :mod:`plotgate.core.gates.kinds`.
    geometry : MarkGeometry
        N problems (first mark, sigmas, tau).
    velocity : (2,) or (N, 2) array_like
        Target velocity (v_x east, v_y north), m/s; N velocities may share one geometry.

    Returns
    -------
    GateProbability
        (N,) probabilities and error estimates.

    References
    ----------
    .. [1] A. A. Konovalov, eq. (1)-(2) (ring gate), and the combined
       gate's P_Sigma "by the same formulas" over the union of ring and ellipse.

    Examples
    --------
    The chi-square ellipse centred on the mean holds exactly P_G:

    >>> from plotgate.core.gates import EllipseGate, mark_geometry
    >>> g = mark_geometry(20e3, 0.3, 150.0, 0.004, tau=4.0)
    >>> res = conditional_probability(EllipseGate(0.9, offset=(800.0, 0.0)), g, [200.0, 0.0])
    >>> round(float(res.probability[0]), 10), bool(res.error[0] < 1e-6)
    (0.9, True)

    The integral over direction is bisected by a compiled kernel
    (:func:`conditional_integral`, with the gate's radii compiled from its
    :class:`plotgate.core.gates.regions.RadialForm`); :func:`conditional_probability_reference`
    computes the same with numpy.
    """
    return _conditional(gate, geometry, velocity, reference=False)


def conditional_probability_reference(
    gate: Gate, geometry: MarkGeometry, velocity: ArrayLike
) -> GateProbability:
    """:func:`conditional_probability` with numpy (the same starting panels, bisected
    round by round): the reference the compiled bisection is tested against."""
    return _conditional(gate, geometry, velocity, reference=True)


class GateNodes(NamedTuple):
    """A rule's nodes d over the gate of one problem, relative to z1, and their weights
    (area element rho d rho d theta included)."""

    dx: np.ndarray
    dy: np.ndarray
    weights: np.ndarray


def _gate_nodes(
    region: StarRegion,
    B: Sym2,
    R_min: float,
    R_max: float,
    rule: tuple[int, float],
) -> GateNodes:
    """The gate's nodes of one problem (B of length 1) by ``rule``."""
    m, scale = rule
    lam_min, lam_max, major = principal_axes(B)
    sigma = np.sqrt(lam_min)[:, None, None]
    reach = R_max + TAIL * np.sqrt(lam_max)[:, None]  # beyond it the density is < 1e-17
    # gate directions theta: (n, T)
    theta, w_theta = panel_rule(_theta_edges(region, B, R_min, R_max, scale), m)
    ux, uy = np.cos(theta), np.sin(theta)
    lo, hi = region.radii(theta)
    ox, oy = region.origin[:, :1], region.origin[:, 1:]
    # gate radii rho on the part of each ray within reach of z1, graded towards the
    # prior ring's edges and the ray's closest approach to z1: (n, T, R);
    # towards the smeared ring's edges from SMEARED: below it they are blurred enough that
    # the error estimate stays under 1e-6 without them (measured up to 6e-7 at an axis
    # ratio of 8.7), above it the estimate would reach 1e-5 by a ratio of 14, and with
    # them it stays near 1e-8 at 6-8 times the cost
    eccentric = bool((lam_max >= SMEARED**2 * lam_min).any())
    minor = (major + 0.5 * np.pi)[:, None] if eccentric else None
    features = ring_features(ox, oy, ux, uy, (R_min, R_max), minor)
    closest = features[..., 0]
    with np.errstate(invalid="ignore"):
        chord = np.sqrt(np.maximum(reach**2 - (ox * ox + oy * oy - closest**2), 0.0))
    lo = np.maximum(lo, closest - chord)
    hi = np.maximum(np.minimum(hi, closest + chord), lo)
    rho_edges = breakpoints(lo, hi, features, np.broadcast_to(scale * sigma, features.shape))
    rho, w_rho = panel_rule(rho_edges, m)
    dx = ox[..., None] + rho * ux[..., None]
    dy = oy[..., None] + rho * uy[..., None]
    weights = w_theta[..., None] * w_rho * rho
    return GateNodes(dx.ravel(), dy.ravel(), weights.ravel())


def _densities(
    nodes: list[GateNodes], B: Sym2, ring: PriorRing, rules: Rules, source: str, calls: int
) -> tuple[list[np.ndarray], float]:
    """The prior-averaged density at each rule's gate nodes, from ``source``:

    - ``"reference"``: :func:`plotgate.core.gates.heading.prior_density_reference`;
    - ``"direct"``: :func:`plotgate.core.gates.heading.prior_density` at every node, with
      the rule's own heading;
    - ``"table"``: the same, but interpolated from one table of the problem (built with
      the first rule's heading, shared by every rule and node, and kept for the next call
      on the problem) where it pays: the gate's nodes, times the ``calls`` expected on the
      problem, number at least :data:`TABLE_GAIN` times the table's points, the table
      holds at most :data:`TABLE_MOST`, and its density holds everywhere
      (:func:`plotgate.core.gates.heading.tabulates`); directly otherwise. With one call
      expected the table is not kept, and covers only the nodes' reach (:func:`_reach`):
      Konovalov's example needs 1,426 points where the whole density takes 6,916.

    Also returns the error of the density a table cut to the nodes adds at each node
    (:data:`TABLE_ERROR` of its bound), 0 when there is none.
    """
    if source == "reference":
        return [
            prior_density_reference(x.dx[None], x.dy[None], B, ring, rule)[0]
            for x, rule in zip(nodes, rules, strict=True)
        ], 0.0
    reach = _reach(nodes, B) if calls == 1 else None
    size = table_size(B, ring, reach)
    pays = TABLE_GAIN * size <= calls * sum(x.dx.size for x in nodes)
    if source == "table" and pays and size <= TABLE_MOST and tabulates(B, ring):
        error = 0.0
        if reach is None:
            table = cached_table(B, ring, rules[0]).args()
        else:
            table = density_table(B, ring, rules[0], reach).args()
            lam_max = float(principal_axes(B)[1][0])
            bound = 2.0 * np.pi * (ring.c0 + ring.c1 * ring.R_max) * np.sqrt(2.0 * np.pi * lam_max)
            error = TABLE_ERROR * float(bound)
        return [interpolated_density(x.dx, x.dy, table) for x in nodes], error
    return [
        prior_density(x.dx, x.dy, B, ring, rule) for x, rule in zip(nodes, rules, strict=True)
    ], 0.0


def _reach(nodes: list[GateNodes], B: Sym2) -> tuple[float, float]:
    """How far the gate's nodes reach along B's major and minor axes (m), with a margin
    of 1e-9 of it, so that rounding cannot put a node outside a table cut to it."""
    major = float(principal_axes(B)[2][0])
    ex, ey = math.cos(major), math.sin(major)
    xi = max(float(np.abs(x.dx * ex + x.dy * ey).max(initial=0.0)) for x in nodes)
    eta = max(float(np.abs(x.dy * ex - x.dx * ey).max(initial=0.0)) for x in nodes)
    return xi * (1.0 + 1e-9), eta * (1.0 + 1e-9)


def _theta_edges(
    region: StarRegion, B: Sym2, R_min: float, R_max: float, scale: float = 1.0
) -> np.ndarray:
    """Gate-direction panels: kinks, plus the tangents to the prior ring from an outer origin."""
    lam_min, _, major = principal_axes(B)
    ox, oy = region.origin[:, 0], region.origin[:, 1]
    dist = np.hypot(ox, oy)
    towards = np.arctan2(-oy, -ox)
    centres, widths = [], []
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for R in (R_min, R_max):
            half = np.arcsin(R / dist)
            centres += [towards + half, towards - half]
            widths += [np.sqrt(lam_min) / dist] * 2
    # an eccentric B blurs the ring's edges by sigma_min along its minor axis and by
    # about sigma_max |alpha| at an angle alpha from it: features 1 / kappa wide
    lam_max = B.xx + B.yy - lam_min
    if (lam_max >= ECCENTRIC**2 * lam_min).any():
        width = np.where(lam_max >= ECCENTRIC**2 * lam_min, np.sqrt(lam_min / lam_max), np.inf)
        centres += [major + k * 0.5 * np.pi for k in range(4)]
        widths += [width] * 4
    # 8 equal panels a turn to start with, at least 2; the centres and kinks of a half turn
    # (_half_turn) are symmetric under theta + pi, so wrapping keeps their images in it
    uniform = max(2, round(4.0 * float(region.span.min()) / np.pi))
    widths = [scale * w for w in widths]
    return angle_breaks(region.start, region.span, centres, widths, region.kinks, uniform=uniform)


def _half_turn(region: StarRegion) -> tuple[StarRegion, float]:
    """The region and the number of times its integral counts: half of it, twice, when the
    gate is symmetric about z1 itself (ring, combined, expanded, an ellipse or rectangle
    without offset), for then so is the integrand: the prior is isotropic and B's
    Gaussian even, so g(-d) = g(d). That halves the gate's nodes."""
    if not region.symmetric or region.origin.any():
        return region, 1.0
    return region._replace(span=np.full(region.span.shape, np.pi)), 2.0


def _validate_prior(prior: str) -> None:
    if prior not in PRIORS:
        raise ParameterError("prior", f"must be one of {', '.join(PRIORS)}, got {prior!r}")


def unconditional_probability(
    gate: Gate,
    geometry: MarkGeometry,
    v_min: float,
    v_max: float,
    prior: Prior = "area",
) -> GateProbability:
    """Probability that the second mark falls in the gate, over all headings and speeds.

    The true displacement x = v tau has a uniform heading and a length s on
    [v_min tau, v_max tau] with density 2 s / (R_max^2 - R_min^2) (``"area"``: x
    uniform over the ring, Konovalov, eq. 4-5) or 1 / (R_max - R_min) (``"speed"``);
    the second mark is d = x + w, w ~ N(0, B) (eq. 3), and

    .. math:: P = \\iint_{gate} g(\\mathbf d)\\, d\\mathbf d, \\quad
              g = f_1 * f_2 \\text{ (eq. 6)}.

    The prior's s is integrated in closed form along each heading; gate direction,
    gate radius and heading by graded Gauss-Legendre panels. With v_min = v_max the
    speed is fixed and both priors coincide.

    Parameters
    ----------
    gate : Gate
        A gate of :mod:`plotgate.core.gates.kinds`.
    geometry : MarkGeometry
        N problems.
    v_min, v_max : float
        Bounds of the speed prior, m/s, 0 <= v_min <= v_max (often the gate's own).
    prior : {"area", "speed"}
        The speed prior.

    Returns
    -------
    GateProbability
        (N,) probabilities and error estimates.

    References
    ----------
    .. [1] A. A. Konovalov, eq. (3)-(6); worked values 0.82 (50 km) and
       0.90 (20 km) for the ring gate, P'_Sigma = 0.9967 for the combined gate.
    """
    _validate_prior(prior)
    R_min, R_max = ring_radii(geometry.tau, v_min, v_max)
    (high, low), table = _quadratures(gate, geometry, R_min, R_max, prior, RULES, "table", 1)
    return GateProbability(high, np.abs(high - low) + table)


def unconditional_quadrature(
    gate: Gate,
    geometry: MarkGeometry,
    R_min: float,
    R_max: float,
    prior: str,
    rule: tuple[int, float],
    *,
    reference: bool = False,
    table: bool = False,
) -> np.ndarray:
    """The unconditional probability with one rule, problem by problem.

    ``rule`` is (Gauss-Legendre order per panel, scale of the grading widths), as in
    :data:`RULES`; R_min and R_max are the prior ring's radii (m) and ``prior`` is
    ``"area"`` or ``"speed"``, all validated by the caller
    (:func:`unconditional_probability`). :func:`plotgate.core.gates.analysis.design_gate`
    searches with a cheaper rule, and the tests check the error estimate against
    higher-order rules.

    The prior-averaged density at the gate's nodes is computed by the compiled
    :func:`plotgate.core.gates.heading.prior_density`, or with ``reference=True`` by its
    numpy reference :func:`plotgate.core.gates.heading.prior_density_reference` (the same
    gate nodes; the same result within the error estimates), or with ``table=True``
    interpolated from the problem's density table where it pays over
    :data:`SEARCH_CALLS` calls (:func:`_densities`); the table is kept for the next call
    on the same problem.

    Each problem is one 3-D quadrature of 10^5-10^6 nodes. Problems are not
    stacked into one array: their features lie in different places, and a common array
    would pad every problem to the panels of the most demanding one.
    """
    source = "reference" if reference else "table" if table else "direct"
    out: np.ndarray = _quadratures(
        gate, geometry, R_min, R_max, prior, (rule,), source, SEARCH_CALLS
    )[0][0]
    return out


def _quadratures(
    gate: Gate,
    geometry: MarkGeometry,
    R_min: float,
    R_max: float,
    prior: str,
    rules: Rules,
    source: str,
    calls: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The unconditional probability by each of ``rules``, (len(rules), N), problem by
    problem, and the error a density table adds to the first rule's, (N,); ``source`` of
    the density and ``calls`` as :func:`_densities`."""
    out = np.empty((len(rules), geometry.n))
    table_error = np.zeros(geometry.n)
    for i in range(geometry.n):
        part = geometry.take(slice(i, i + 1))
        region, turns = _half_turn(gate.region(part))
        lam_min = float(principal_axes(part.B)[0][0])
        ring = prior_ring(prior, R_min, R_max, lam_min)
        nodes = [_gate_nodes(region, part.B, R_min, R_max, rule) for rule in rules]
        densities, error = _densities(nodes, part.B, ring, rules, source, calls)
        norm = 4.0 * np.pi * np.pi * float(np.sqrt(part.B.det[0]))
        for k, (x, density) in enumerate(zip(nodes, densities, strict=True)):
            out[k, i] = turns * float(x.weights @ density) / norm
        table_error[i] = turns * error * float(nodes[0].weights.sum()) / norm
    return out, table_error


def monte_carlo_probability(
    gate: Gate,
    geometry: MarkGeometry,
    *,
    velocity: ArrayLike | None = None,
    v_min: float | None = None,
    v_max: float | None = None,
    prior: Prior = "area",
    samples: int = 1_000_000,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Monte Carlo estimate of the gating probability, for checking the quadrature.

    Samples the second mark (with ``velocity`` given: d = v tau + w; otherwise a
    uniform heading and a length from ``prior`` on [v_min tau, v_max tau], plus w),
    w ~ N(0, B), and applies the gate test itself (``gate.contains``).

    Returns
    -------
    p, standard_error : (N,) ndarray
        The fraction inside and its binomial standard error sqrt(p (1 - p) / samples).
    """
    rng = np.random.default_rng(seed)
    n = geometry.n
    v = None if velocity is None else np.broadcast_to(as_points("velocity", velocity), (n, 2))
    if v is None:
        _validate_prior(prior)
        # unchecked here: ring_radii refuses a missing bound, naming it
        R_min, R_max = ring_radii(geometry.tau, cast(float, v_min), cast(float, v_max))
    p = np.empty(n)
    for i in range(n):
        if v is not None:
            x = np.broadcast_to(v[i] * geometry.tau, (samples, 2))
        else:
            u = rng.random(samples)
            s = (
                np.sqrt(R_min**2 + u * (R_max**2 - R_min**2))
                if prior == "area"
                else R_min + u * (R_max - R_min)
            )
            heading = rng.uniform(0.0, 2.0 * np.pi, samples)
            x = np.stack([s * np.cos(heading), s * np.sin(heading)], axis=-1)
        B = np.array([[geometry.B.xx[i], geometry.B.xy[i]], [geometry.B.xy[i], geometry.B.yy[i]]])
        w = rng.standard_normal((samples, 2)) @ np.linalg.cholesky(B).T
        p[i] = gate.contains(geometry, i, geometry.z1[i] + x + w).mean()
    return p, np.sqrt(p * (1.0 - p) / samples)
