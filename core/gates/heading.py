"""The prior-averaged density at the gate's nodes (Konovalov, eq. 6): kernel and reference.

The unconditional probability integrates over the gate the density g of the second
mark d = x + w, with x = s e_phi on the prior's ring and w ~ N(0, B). At every gate
node d this module gives 2 pi |B|^1/2 (2 pi) g(d), the heading integral of the prior's
closed-form radial integral of N(s e_phi; d, B):

- :func:`prior_density_reference`, with numpy: graded Gauss-Legendre heading panels
  built as arrays, the ray moments at every heading (:func:`ray_moments_reference`);
- :func:`prior_density`, compiled, one node at a time and never more than one node's
  headings in memory. It picks the rule for the problem:

  * a nearly round B (axis ratio below :data:`ECCENTRIC`) and a ring wider than
    sigma_min: the mapped periodic trapezoid rule (:func:`_mapped_density`), which
    converges geometrically on the heading's single peak;
  * an eccentric B with the area prior: B's principal axes (:func:`_principal_density`),
    the long axis in closed form, the short one on a few panels;
  * otherwise the reference's own graded panels (:func:`_graded_density`), so the two
    agree to rounding.

Each kernel reads B as a :class:`Gaussian` record and the prior as a :class:`PriorRing`
record (plain tuples to numba; their types are stated once, :data:`GAUSSIAN` and
:data:`PRIOR_RING`).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from scipy.special import ndtr

from plotgate.core.compiled import kernel
from plotgate.core.gates.quadrature import angle_breaks, gauss_legendre, panel_rule
from plotgate.core.sym2 import Sym2, inverse

__all__ = [
    "BLOCK",
    "DensityTable",
    "ECCENTRIC",
    "GAUSSIAN",
    "PRIOR_RING",
    "TABLE_ORDER",
    "TABLE_PANEL",
    "TAIL",
    "Gaussian",
    "PriorRing",
    "cached_table",
    "clear_tables",
    "density_table",
    "gaussian",
    "interpolated_density",
    "prior_density",
    "prior_density_reference",
    "prior_ring",
    "principal_axes",
    "ray_moments",
    "ray_moments_reference",
    "ring_features",
    "table_shape",
    "table_size",
    "tabulates",
]

BLOCK = 4096
"""Nodes whose heading panels share one number of grading levels (the reference's array)."""
ECCENTRIC = 3.0
"""Axis ratio sqrt(lambda_max / lambda_min) of B from which the heading integrand has
more than one peak (the mapped rule's premise fails) and B's axes get their own panels."""
SMEARED = 8.0
"""Axis ratio from which the graded heading panels also grade about the directions where
the line d + t e_major crosses the ring's circles: a long Gaussian smears the ring along
its major axis, and those crossings are sharp features of the heading integrand."""
TAIL = 9.0
"""Standard deviations beyond which a Gaussian's density (< e^-40) is left out."""
HEADING_SPREAD = 4.0
"""epsilon / w of the conformal map of the mapped heading rule: the peak, w wide, is spread
over about a quarter of the mapped circle."""
HEADING_TOL = 1e-10
"""Wanted error of the mapped trapezoid sum of the heading integral, relative to a bound
on that integral (successive sums agree within its square root). The stop on delta^2 is
a heuristic: at the gate nodes of Konovalov's example the largest error measured was
3e-7 of the bound (at nodes where the integral is far below it); the second rule's
looser heading puts that into the error estimate (1.4e-8 there, against 4e-10 from the
numpy reference; 2.2e-8 with the density table's stated error added)."""
MAPPED_NODES = (16, 1 << 14)
"""First and most trapezoid nodes of the mapped heading rule."""
THIN_NODES = 8
"""Gauss-Legendre nodes across a prior ring no wider than sigma_min: the Gaussian varies
by at most one standard deviation across it, and 8 nodes hold the integral to ~1e-12."""
_MAX_LEVELS = 40
"""Most grading levels about one feature (:data:`plotgate.core.gates.quadrature.RATIO` ^ 40)."""
_RATIO = 3.0
_SQRT_2PI = math.sqrt(2.0 * math.pi)
_TWO_PI = 2.0 * math.pi
_SQRT_HALF = math.sqrt(0.5)

GAUSSIAN = "UniTuple(float64, 7)"
"""numba type of a :class:`Gaussian`."""
PRIOR_RING = "Tuple((float64, float64, float64, float64, float64[:], float64[:]))"
"""numba type of a :class:`PriorRing`."""
_RULE = "Tuple((float64[:], float64[:], float64))"
"""numba type of a Gauss-Legendre rule: nodes and weights on [-1, 1], grading scale."""
_MAPPING = "Tuple((float64, float64, int64, int64))"
"""numba type of the mapped heading rule's (spread, tol, n_start, n_max)."""
_POINTS = "float64[:], float64[:]"
"""numba types of the nodes d = (dx, dy), m, relative to the first mark."""


RingArgs = tuple[float, float, float, float, np.ndarray, np.ndarray]
"""A :class:`PriorRing` as a kernel receives it."""
RuleArgs = tuple[np.ndarray, np.ndarray, float]
"""Gauss-Legendre nodes and weights on [-1, 1] and the grading scale, as a kernel receives them."""


class Gaussian(NamedTuple):
    """B of one problem as the kernels read it."""

    qxx: float  # B^-1
    qxy: float
    qyy: float
    qdet: float  # |B^-1|
    lam_min: float  # B's eigenvalues
    lam_max: float
    major: float  # direction of B's major axis, rad counter-clockwise from east

    def args(self) -> tuple[float, ...]:
        """The record as a kernel receives it (numba takes a plain tuple)."""
        return tuple(self)


class PriorRing(NamedTuple):
    """The speed prior as the ring of true displacements x = v tau, as the kernels read it.

    The length s of x has the density c0 + c1 s on [R_min, R_max]. A ring no wider than
    sigma_min is integrated on the nodes s_j with weights (``nodes``, ``weights``; empty
    for a wider ring, whose radial integral is in closed form).
    """

    R_min: float
    R_max: float
    c0: float
    c1: float
    nodes: np.ndarray
    weights: np.ndarray

    @property
    def closed_form(self) -> bool:
        return self.nodes.size == 0

    def args(self) -> RingArgs:
        """The record as a kernel receives it (numba takes a plain tuple)."""
        return (self.R_min, self.R_max, self.c0, self.c1, self.nodes, self.weights)


def principal_axes(B: Sym2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """lambda_min, lambda_max and the major-axis direction of B."""
    half_diff = 0.5 * (B.xx - B.yy)
    root = np.hypot(half_diff, B.xy)
    mean = 0.5 * (B.xx + B.yy)
    lam_max = mean + root
    return B.det / lam_max, lam_max, 0.5 * np.arctan2(B.xy, half_diff)


def gaussian(B: Sym2) -> Gaussian:
    """The :class:`Gaussian` of a B of length 1."""
    Q = inverse(B)
    lam_min, lam_max, major = principal_axes(B)
    return Gaussian(*(float(x[0]) for x in (Q.xx, Q.xy, Q.yy, Q.det, lam_min, lam_max, major)))


def prior_ring(prior: str, R_min: float, R_max: float, lam_min: float) -> PriorRing:
    """The :class:`PriorRing` of ``prior`` ("area" or "speed") on [R_min, R_max].

    A ring no wider than sigma_min = sqrt(lam_min) gets Gauss-Legendre nodes in
    u = (s - R_min) / (R_max - R_min) on [0, 1], where the prior's density is 1
    (``"speed"``) or 2 s / (R_max + R_min) (``"area"``): finite and free of cancellation
    however thin or small the ring (tau or the speeds down to 5e-324), where the closed
    form's 1 / (R_max^2 - R_min^2) overflows and its moments cancel. A circle
    (R_min = R_max) is one node.
    """
    R_min, R_max = float(R_min), float(R_max)
    if R_max - R_min > math.sqrt(lam_min):
        if prior == "speed":
            return PriorRing(R_min, R_max, 1.0 / (R_max - R_min), 0.0, *_no_nodes())
        return PriorRing(R_min, R_max, 0.0, 2.0 / (R_max * R_max - R_min * R_min), *_no_nodes())
    if R_max == R_min:
        return PriorRing(R_min, R_max, 0.0, 0.0, np.array([R_max]), np.array([1.0]))
    u, w = panel_rule(np.array([0.0, 1.0]), THIN_NODES)
    s = R_min + u * (R_max - R_min)
    if prior == "area":
        w = w * (2.0 * s / (R_max + R_min))
    return PriorRing(R_min, R_max, 0.0, 0.0, s, w)


def _no_nodes() -> tuple[np.ndarray, np.ndarray]:
    return np.empty(0), np.empty(0)


def ray_moments_reference(
    ux: np.ndarray,
    uy: np.ndarray,
    mx: np.ndarray,
    my: np.ndarray,
    Q: Sym2,
    t1: np.ndarray | np.float64,
    t2: np.ndarray | np.float64,
) -> tuple[np.ndarray, np.ndarray]:
    """M_k = integral over t in [t1, t2] of t^k exp(-q(t)/2), k = 0, 1, with numpy.

    q(t) = (t u - m)^T Q (t u - m) with a unit direction u and Q = B^-1. Writing
    a = u^T Q u, b = u^T Q m and the minimum of q along the ray
    k = |Q| (u x m)^2 / a (Lagrange's identity, free of cancellation),

    M0 = sqrt(2 pi / a) exp(-k/2) [Phi(s2) - Phi(s1)],  s_i = (a t_i - b) / sqrt(a),
    M1 = [exp(-q(t1)/2) - exp(-q(t2)/2)] / a + (b / a) M0.

    Vectorized over rays (the conditional probability's integrand uses it as is); the
    reference of :func:`ray_moments`.
    """
    a = Q.xx * ux * ux
    a += 2.0 * Q.xy * ux * uy
    a += Q.yy * uy * uy
    b = Q.xx * ux * mx
    b += Q.xy * (ux * my + uy * mx)
    b += Q.yy * uy * my
    k = ux * my
    k -= uy * mx
    k *= k
    k *= Q.det
    k /= a
    root_a = np.sqrt(a)
    s1 = a * t1
    s1 -= b
    s1 /= root_a
    s2 = a * t2
    s2 -= b
    s2 /= root_a
    # Phi(s2) - Phi(s1) from the tail that does not cancel: flip both when s1 > 0
    flip = np.where(s1 > 0.0, -1.0, 1.0)
    M0 = ndtr(flip * s2)
    M0 -= ndtr(flip * s1)
    M0 *= flip
    M0 *= np.exp(-0.5 * k)
    M0 *= _SQRT_2PI
    M0 /= root_a
    s1 *= s1
    s1 += k
    s2 *= s2
    s2 += k
    M1 = np.exp(-0.5 * s1)
    M1 -= np.exp(-0.5 * s2)
    b *= M0
    M1 += b
    M1 /= a
    return M0, M1


@kernel(f"UniTuple(float64, 2)(float64, float64, float64, float64, {GAUSSIAN}, float64, float64)")
def ray_moments(
    ux: float,
    uy: float,
    mx: float,
    my: float,
    gauss: tuple[float, ...],
    t1: float,
    t2: float,
) -> tuple[float, float]:
    """:func:`ray_moments_reference` for one ray, compiled: (M0, M1)."""
    qxx, qxy, qyy, qdet = gauss[0], gauss[1], gauss[2], gauss[3]
    a = qxx * ux * ux + 2.0 * qxy * ux * uy + qyy * uy * uy
    b = qxx * ux * mx + qxy * (ux * my + uy * mx) + qyy * uy * my
    k = ux * my - uy * mx
    k = k * k * qdet / a
    root_a = math.sqrt(a)
    s1 = (a * t1 - b) / root_a
    s2 = (a * t2 - b) / root_a
    flip = -1.0 if s1 > 0.0 else 1.0
    phi = 0.5 * (math.erfc(-flip * s2 * _SQRT_HALF) - math.erfc(-flip * s1 * _SQRT_HALF))
    M0 = flip * phi * math.exp(-0.5 * k) * _SQRT_2PI / root_a
    M1 = (math.exp(-0.5 * (s1 * s1 + k)) - math.exp(-0.5 * (s2 * s2 + k)) + b * M0) / a
    return M0, M1


@kernel(f"float64(float64, float64, float64, float64, {GAUSSIAN}, {PRIOR_RING})")
def _heading_value(
    ux: float, uy: float, px: float, py: float, gauss: tuple[float, ...], ring: RingArgs
) -> float:
    """The heading integrand at direction u for the node p: the prior's radial integral."""
    R_min, R_max, c0, c1, nodes, weights = ring
    if nodes.size == 0:
        M0, M1 = ray_moments(ux, uy, px, py, gauss, R_min, R_max)
        radial: float = c0 * M0 + c1 * M1 if c1 != 0.0 else c0 * M0
        return radial
    qxx, qxy, qyy = gauss[0], gauss[1], gauss[2]
    value: float = 0.0
    for j in range(nodes.size):
        nx = nodes[j] * ux - px
        ny = nodes[j] * uy - py
        q = qxx * nx * nx + 2.0 * qxy * nx * ny + qyy * ny * ny
        value += weights[j] * math.exp(-0.5 * q)
    return value


def ring_features(
    ox: np.ndarray,
    oy: np.ndarray,
    ux: np.ndarray,
    uy: np.ndarray,
    radii: tuple[float, float],
    minor: np.ndarray | None,
) -> np.ndarray:
    """Distances along rays o + t u to the edges of the blurred prior ring (NaN: none).

    The ray's closest approach to z1, its crossings of the circles |x| = R, and, for an
    eccentric B (``minor``, the direction of its minor axis, given), its crossings of
    the lines x . e_minor = +-R: a long Gaussian smears the ring along its major axis,
    and the smeared ring's sharp edges are those lines.
    """
    along = ox * ux + oy * uy
    base = along * along - (ox * ox + oy * oy)
    out = [-along]
    for R in radii:
        with np.errstate(invalid="ignore"):
            root = np.sqrt(base + R * R)
        out += [-along - root, -along + root]
    if minor is not None:
        ex, ey = np.cos(minor), np.sin(minor)
        offset, rate = ox * ex + oy * ey, ux * ex + uy * ey
        with np.errstate(divide="ignore", invalid="ignore"):
            out += [(c - offset) / rate for R in radii for c in (R, -R)]
    return np.stack(out, axis=-1)


def prior_density_reference(
    dx: np.ndarray,
    dy: np.ndarray,
    B: Sym2,
    ring: PriorRing,
    rule: tuple[int, float],
) -> np.ndarray:
    """2 pi |B|^1/2 (2 pi) g(d) at (n, K) points d of n problems, with numpy.

    ``rule`` is (Gauss-Legendre order per panel, scale of the grading widths). Headings
    are integrated within reach of d and graded about the direction of d: N(d, B)
    subtends about sigma_min / |d|, or sigma_min / R_min where the inner circle cuts it.
    A long N(d, B) (axis ratio from :data:`SMEARED`) meets the prior ring along the line
    d + t e_major, and the directions of that line's crossings of the ring's circles are
    sharp features too. The points of each problem are taken :data:`BLOCK` // n at a
    time, and the panels of a block share their number of grading levels.
    """
    n, K = dx.shape
    block = max(1, BLOCK // n)
    density = np.empty((n, K))
    for first in range(0, K, block):
        cols = slice(first, first + block)
        density[:, cols] = _graded_block(dx[:, cols], dy[:, cols], B, ring, rule)
    return density


def _graded_block(
    dx: np.ndarray, dy: np.ndarray, B: Sym2, ring: PriorRing, rule: tuple[int, float]
) -> np.ndarray:
    m, scale = rule
    R_min, R_max = ring.R_min, ring.R_max
    lam_min, lam_max, major = principal_axes(B)
    sigma = np.sqrt(lam_min)[:, None]
    dist = np.hypot(dx, dy)
    # near the origin (or a vanishing ring) the ratios overflow to inf: every heading
    # is within reach, and an infinite width grades nothing
    with np.errstate(over="ignore"):
        half = np.arcsin(
            np.minimum(1.0, TAIL * np.sqrt(lam_max)[:, None] / np.maximum(dist, 1e-300))
        )
        half = np.where(half < 0.5 * np.pi, half, np.pi)
        centres = [np.arctan2(dy, dx)]
        widths = [scale * sigma / np.maximum(dist, max(R_min, 1e-300))]
        if (lam_max >= SMEARED**2 * lam_min).any():
            ex, ey = np.cos(major)[:, None], np.sin(major)[:, None]
            crossings = ring_features(dx, dy, ex, ey, (R_min, R_max), None)[..., 1:]
            for k, R in enumerate((R_min, R_min, R_max, R_max)):
                t = crossings[..., k]
                centres.append(np.arctan2(dy + t * ey, dx + t * ex))
                widths.append(np.broadcast_to(scale * sigma / max(R, 1e-300), t.shape))
    phi_edges = angle_breaks(centres[0] - half, 2.0 * half, centres, widths, None, uniform=2)
    phi, w_phi = panel_rule(phi_edges, m)
    Q = Sym2(*(np.reshape(x, (-1, 1, 1)) for x in inverse(B)))
    ex, ey = np.cos(phi), np.sin(phi)
    mx, my = dx[..., None], dy[..., None]
    if ring.closed_form:
        M0, M1 = ray_moments_reference(ex, ey, mx, my, Q, np.float64(R_min), np.float64(R_max))
        kernel_ = ring.c0 * M0 + ring.c1 * M1 if ring.c1 else ring.c0 * M0
    else:  # a ring thinner than the Gaussian (v_min = v_max: a circle) is a smooth factor
        kernel_ = np.zeros(np.broadcast_shapes(ex.shape, mx.shape))
        for s_j, w_j in zip(ring.nodes, ring.weights, strict=True):
            nx, ny = s_j * ex - mx, s_j * ey - my
            q = Q.xx * nx * nx + 2.0 * Q.xy * nx * ny + Q.yy * ny * ny
            kernel_ += w_j * np.exp(-0.5 * q)
    density: np.ndarray = np.einsum("nkf,nkf->nk", w_phi, kernel_)
    return density


def prior_density(
    dx: np.ndarray, dy: np.ndarray, B: Sym2, ring: PriorRing, rule: tuple[int, float]
) -> np.ndarray:
    """:func:`prior_density_reference` of one problem (B of length 1) at (K,) points, compiled.

    The rule follows the problem (module docstring). The mapped heading rule doubles its
    nodes until two sums agree within sqrt(:data:`HEADING_TOL`) (times the rule's scale:
    the lower rule of the unconditional probability gets a looser heading, so the two
    rules' difference also covers the heading's error) of
    2 pi (c0 + c1 R_max) sqrt(2 pi lambda_max), a bound on the integral.
    """
    g = gaussian(B)
    m, scale = rule
    points = (np.ascontiguousarray(dx, np.float64), np.ascontiguousarray(dy, np.float64))
    ratio2 = g.lam_max / g.lam_min
    x_gl, w_gl = gauss_legendre(m)
    if ring.closed_form and ratio2 < ECCENTRIC**2:
        bound = 2.0 * np.pi * (ring.c0 + ring.c1 * ring.R_max) * np.sqrt(2.0 * np.pi * g.lam_max)
        tol = float(np.sqrt(HEADING_TOL) * scale * bound)
        mapping = (HEADING_SPREAD, tol, *MAPPED_NODES)
        return _mapped_density(*points, g.args(), ring.args(), mapping)
    if ring.closed_form and ring.c0 == 0.0:
        return _principal_density(*points, g.args(), ring.args(), (x_gl, w_gl, float(scale)))
    return _graded_density(*points, g.args(), ring.args(), (x_gl, w_gl, float(scale)))


@kernel("float64(float64, float64, float64, float64, float64, float64, float64[:], float64[:])")
def _disk_probability(
    xi: float,
    eta: float,
    R: float,
    sig_min: float,
    sig_max: float,
    scale: float,
    x_gl: np.ndarray,
    w_gl: np.ndarray,
) -> float:
    """sqrt(2 pi) sigma_min P(|X| <= R) for X ~ N(d, B), d = (xi, eta) in B's principal axes.

    The lines of X at minor coordinate y = R sin psi cut the disk in the chord
    |x| <= R cos psi, whose probability along the major axis is a difference of normal
    distribution functions; in psi the chord's sqrt end points at the tangents y = +-R
    are smooth, and dy = R cos psi dpsi. The minor coordinate's Gaussian, about eta, is
    cut into panels at eta + sigma_min (0, +-1, +-2.5, +-4.5, +-7) ``scale`` (as far as
    :data:`TAIL`), each mapped to psi.
    """
    if R <= 0.0:
        return 0.0
    m = x_gl.size
    total = 0.0
    previous = -2.0 * math.pi
    for k in range(-5, 6):
        step = (0.0, 1.0, 2.5, 4.5, 7.0, TAIL)[abs(k)]
        offset = min(step * scale, TAIL) if abs(k) < 5 else TAIL
        y = eta + (offset if k >= 0 else -offset) * sig_min
        psi = math.asin(min(1.0, max(-1.0, y / R)))
        if k > -5 and psi > previous:
            half_width = 0.5 * (psi - previous)
            for g in range(m):
                at = previous + half_width * (1.0 + x_gl[g])
                chord = R * math.cos(at)
                u = (R * math.sin(at) - eta) / sig_min
                hi = (chord - xi) * _SQRT_HALF / sig_max
                lo = (-chord - xi) * _SQRT_HALF / sig_max
                # Phi(hi) - Phi(lo) from the tail that does not cancel
                if lo > 0.0:
                    along = 0.5 * (math.erfc(lo) - math.erfc(hi))
                else:
                    along = 0.5 * (math.erfc(-hi) - math.erfc(-lo))
                total += half_width * w_gl[g] * math.exp(-0.5 * u * u) * along * chord
        previous = psi
    return total


@kernel(f"float64[:]({_POINTS}, {GAUSSIAN}, {PRIOR_RING}, {_RULE})")
def _principal_density(
    dx: np.ndarray, dy: np.ndarray, gauss: tuple[float, ...], ring: RingArgs, rule: RuleArgs
) -> np.ndarray:
    """The area prior's density in B's principal axes, the long axis in closed form.

    With the area prior, 2 pi |B|^1/2 (2 pi) g(d) = c1 2 pi |B|^1/2 P(R_min <= |X| <= R_max)
    for X ~ N(d, B): the difference of two disk probabilities (:func:`_disk_probability`).
    An eccentric B's density is thin across its major axis and long along it, so a few
    panels across and a closed form along replace the graded heading panels, whose count
    grows with the axis ratio.
    """
    lam_min, lam_max, major = gauss[4], gauss[5], gauss[6]
    R_min, R_max, c1 = ring[0], ring[1], ring[3]
    x_gl, w_gl, scale = rule
    sig_min = math.sqrt(lam_min)
    sig_max = math.sqrt(lam_max)
    ex = math.cos(major)
    ey = math.sin(major)
    # c1 2 pi |B|^1/2 over the minor Gaussian's normalization sqrt(2 pi) sigma_min
    factor = c1 * _TWO_PI * sig_max / _SQRT_2PI
    out = np.empty(dx.size)
    for i in range(dx.size):
        xi = dx[i] * ex + dy[i] * ey
        eta = dy[i] * ex - dx[i] * ey
        outer = _disk_probability(xi, eta, R_max, sig_min, sig_max, scale, x_gl, w_gl)
        inner = _disk_probability(xi, eta, R_min, sig_min, sig_max, scale, x_gl, w_gl)
        out[i] = factor * (outer - inner)
    return out


class DensityTable(NamedTuple):
    """The density of one problem on a grid in B's principal axes, for interpolation.

    g(d) is even in both principal coordinates (the prior is isotropic, B's Gaussian even),
    so the grid covers the quarter 0 <= xi <= L_xi, 0 <= eta <= L_eta (beyond it, more
    than :data:`TAIL` standard deviations from the ring, g is below e^-40 of its bound).
    Each axis is cut into equal panels, each with the ``order`` Chebyshev-Lobatto points
    (shared at the panels' ends); ``values`` holds the density at the grid's points.
    """

    major: float
    lengths: tuple[float, float]  # L_xi, L_eta, m
    panels: tuple[int, int]
    order: int
    values: np.ndarray  # (panels_xi (order - 1) + 1, panels_eta (order - 1) + 1)

    @property
    def size(self) -> int:
        return int(self.values.size)

    def args(self) -> TableArgs:
        """The record as a kernel receives it (numba takes a plain tuple)."""
        return (self.major, *self.lengths, *self.panels, self.order, self.values)


TableArgs = tuple[float, float, float, int, int, int, np.ndarray]
_TABLE = "Tuple((float64, float64, float64, int64, int64, int64, float64[:, :]))"
"""numba type of a :class:`DensityTable`."""
TABLE_ORDER = 16
"""Chebyshev-Lobatto points a panel of the density table, along each axis."""
TABLE_PANEL = 3.0
"""Most width of a table panel, in standard deviations of B along its axis: with
:data:`TABLE_ORDER` points, the interpolation error measured below 1e-10 of the density's
bound (tests/core/gates/test_heading.py)."""


def _lobatto(order: int) -> np.ndarray:
    """Chebyshev-Lobatto points on [0, 1], increasing."""
    return 0.5 - 0.5 * np.cos(np.pi * np.arange(order) / (order - 1))


Reach = tuple[float, float] | None
"""How far the points a table serves reach along B's major and minor axes (m), or None:
everywhere the density is not negligible."""


def table_shape(
    B: Sym2, ring: PriorRing, reach: Reach = None
) -> tuple[tuple[float, float], tuple[int, int]]:
    """The lengths and panel counts of the density table of one problem (B of length 1),
    cut to ``reach`` if given (the same panel widths: the same interpolation error)."""
    g = gaussian(B)
    sigmas = (math.sqrt(g.lam_max), math.sqrt(g.lam_min))
    lengths = (ring.R_max + TAIL * sigmas[0], ring.R_max + TAIL * sigmas[1])
    if reach is not None:
        lengths = (min(lengths[0], reach[0]), min(lengths[1], reach[1]))
    panels = (
        max(1, math.ceil(lengths[0] / (TABLE_PANEL * sigmas[0]))),
        max(1, math.ceil(lengths[1] / (TABLE_PANEL * sigmas[1]))),
    )
    return lengths, panels


def tabulates(B: Sym2, ring: PriorRing) -> bool:
    """Whether the density of one problem is accurate enough everywhere to tabulate.

    A table spreads the error of each of its points over a panel, so it takes the rules
    that hold everywhere: B's principal axes (the area prior, 1e-9 of the bound) and the
    mapped heading rule (a nearly round B, about 1e-8). The graded heading panels are
    centred on the direction of d, and where the heading's peak lies elsewhere (near
    z1, an eccentric B) they err by up to 1e-4 of the density at single points, which a
    gate node of small weight bears alone but a table would not.
    """
    g = gaussian(B)
    return ring.closed_form and (ring.c0 == 0.0 or g.lam_max < ECCENTRIC**2 * g.lam_min)


def table_size(B: Sym2, ring: PriorRing, reach: Reach = None) -> int:
    """Grid points of the density table of one problem: the densities it costs."""
    _, panels = table_shape(B, ring, reach)
    return (panels[0] * (TABLE_ORDER - 1) + 1) * (panels[1] * (TABLE_ORDER - 1) + 1)


def density_table(
    B: Sym2, ring: PriorRing, rule: tuple[int, float], reach: Reach = None
) -> DensityTable:
    """Tabulate :func:`prior_density` (with ``rule``) for one problem (B of length 1), on
    the points within ``reach`` (:func:`table_shape`).

    The area prior is tabulated in B's principal axes whatever B's axis ratio: there it
    holds 1e-9 of the density's bound, where the mapped heading rule holds about 1e-8
    (up to 3e-7 at single points), and the table's error is common to both rules of the
    unconditional probability, so its error estimate cannot see it.
    """
    g = gaussian(B)
    lengths, panels = table_shape(B, ring, reach)
    unit = _lobatto(TABLE_ORDER)[:-1]
    axes = [
        np.append((np.arange(p)[:, None] + unit).ravel() * (L / p), L)
        for L, p in zip(lengths, panels, strict=True)
    ]
    xi, eta = np.meshgrid(*axes, indexing="ij")
    ex, ey = math.cos(g.major), math.sin(g.major)
    dx, dy = (xi * ex - eta * ey).ravel(), (xi * ey + eta * ex).ravel()
    if ring.closed_form and ring.c0 == 0.0:  # the area prior: B's principal axes, 1e-9
        x_gl, w_gl = gauss_legendre(rule[0])
        values = _principal_density(dx, dy, g.args(), ring.args(), (x_gl, w_gl, float(rule[1])))
    else:
        values = prior_density(dx, dy, B, ring, rule)
    return DensityTable(g.major, lengths, panels, TABLE_ORDER, values.reshape(xi.shape))


def cached_table(B: Sym2, ring: PriorRing, rule: tuple[int, float]) -> DensityTable:
    """:func:`density_table`, kept for the last few problems: gates.design evaluates about
    twenty probabilities of one problem (one B, one prior), each gate sharing its table."""
    key = (
        tuple(float(x[0]) for x in B),
        ring.R_min,
        ring.R_max,
        ring.c0,
        ring.c1,
        tuple(ring.nodes),
        tuple(ring.weights),
        rule,
    )
    return _table_of(key)


def clear_tables() -> None:
    """Forget the kept tables (a bench timing a cold call)."""
    _table_of.cache_clear()


@functools.lru_cache(maxsize=4)
def _table_of(key: tuple) -> DensityTable:  # type: ignore[type-arg]
    (xx, xy, yy, det), R_min, R_max, c0, c1, nodes, weights, rule = key
    B = Sym2(*(np.array([x]) for x in (xx, xy, yy, det)))
    ring = PriorRing(R_min, R_max, c0, c1, np.array(nodes), np.array(weights))
    return density_table(B, ring, rule)


@kernel("void(float64, float64[:], float64[:], float64[:])")
def _lagrange(t: float, nodes: np.ndarray, weights: np.ndarray, basis: np.ndarray) -> None:
    """The Lagrange basis at t in [0, 1] on ``nodes``, barycentric (second form)."""
    total = 0.0
    for j in range(nodes.size):
        diff = t - nodes[j]
        if diff == 0.0:
            basis[:] = 0.0
            basis[j] = 1.0
            return
        basis[j] = weights[j] / diff
        total += basis[j]
    for j in range(nodes.size):
        basis[j] /= total


@kernel(f"float64[:]({_POINTS}, {_TABLE})")
def interpolated_density(dx: np.ndarray, dy: np.ndarray, table: TableArgs) -> np.ndarray:
    """The density at (K,) points from a :class:`DensityTable`, by barycentric Lagrange
    interpolation on the panel of each point, along each principal axis."""
    major, L_xi, L_eta, p_xi, p_eta, order, values = table
    ex = math.cos(major)
    ey = math.sin(major)
    h_xi = L_xi / p_xi
    h_eta = L_eta / p_eta
    nodes = np.empty(order)
    weights = np.empty(order)
    for j in range(order):
        nodes[j] = 0.5 - 0.5 * math.cos(math.pi * j / (order - 1))
        weights[j] = (-1.0) ** j * (0.5 if j == 0 or j == order - 1 else 1.0)
    basis_xi = np.empty(order)
    basis_eta = np.empty(order)
    out = np.empty(dx.size)
    for i in range(dx.size):
        xi = abs(dx[i] * ex + dy[i] * ey)
        eta = abs(dy[i] * ex - dx[i] * ey)
        if xi > L_xi or eta > L_eta:
            out[i] = 0.0
            continue
        a = min(int(xi / h_xi), p_xi - 1)
        b = min(int(eta / h_eta), p_eta - 1)
        _lagrange(xi / h_xi - a, nodes, weights, basis_xi)
        _lagrange(eta / h_eta - b, nodes, weights, basis_eta)
        total = 0.0
        first_xi = a * (order - 1)
        first_eta = b * (order - 1)
        for j in range(order):
            row = 0.0
            for k in range(order):
                row += basis_eta[k] * values[first_xi + j, first_eta + k]
            total += basis_xi[j] * row
        out[i] = total
    return out


@kernel(f"float64[:]({_POINTS}, {GAUSSIAN}, {PRIOR_RING}, {_RULE})")
def _graded_density(
    dx: np.ndarray, dy: np.ndarray, gauss: tuple[float, ...], ring: RingArgs, rule: RuleArgs
) -> np.ndarray:
    """:func:`prior_density_reference`'s graded heading panels, node by node.

    Builds the same heading panels point by point (:data:`BLOCK` points share their
    grading levels, as one array of the reference does) and sums the same closed-form
    radial integrals.
    """
    lam_min, lam_max, major = gauss[4], gauss[5], gauss[6]
    R_min, R_max = ring[0], ring[1]
    x_gl, w_gl, scale = rule
    n = dx.size
    out = np.empty(n)
    m = x_gl.size
    sigma = math.sqrt(lam_min)
    sig_max = math.sqrt(lam_max)
    ex = math.cos(major)
    ey = math.sin(major)
    n_centres = 5 if lam_max >= SMEARED * SMEARED * lam_min else 1
    centres = np.empty(n_centres)
    widths = np.empty(n_centres)
    pts = np.empty(3 + n_centres * (1 + 2 * _MAX_LEVELS))
    edges = np.empty(pts.size)
    radii = (R_min, R_min, R_max, R_max)
    inner = max(R_min, 1e-300)
    for first in range(0, n, BLOCK):
        last = min(n, first + BLOCK)
        # pass 1: the block's grading levels (quadrature.breakpoints' _levels)
        ratio = -1.0
        for i in range(first, last):
            dist = math.hypot(dx[i], dy[i])
            half = math.asin(min(1.0, TAIL * sig_max / max(dist, 1e-300)))
            half = half if half < 0.5 * math.pi else math.pi
            lo = math.atan2(dy[i], dx[i]) - half
            span = (lo + 2.0 * half) - lo
            w0 = scale * sigma / max(dist, inner)
            if math.isfinite(w0) and w0 > 0.0:
                ratio = max(ratio, span / w0)
            if n_centres > 1:
                for k in range(4):
                    wk = scale * sigma / max(radii[k], 1e-300)
                    if math.isfinite(wk) and wk > 0.0:
                        ratio = max(ratio, span / wk)
        if ratio < 0.0:
            levels = 0
        elif ratio <= 1.0:
            levels = 1
        else:
            levels = int(min(_MAX_LEVELS, math.ceil(math.log(ratio) / math.log(_RATIO)) + 1))
        # pass 2: each node's panels and headings
        for i in range(first, last):
            px = dx[i]
            py = dy[i]
            dist = math.hypot(px, py)
            half = math.asin(min(1.0, TAIL * sig_max / max(dist, 1e-300)))
            half = half if half < 0.5 * math.pi else math.pi
            centres[0] = math.atan2(py, px)
            widths[0] = scale * sigma / max(dist, inner)
            if n_centres > 1:
                along = px * ex + py * ey
                base = along * along - (px * px + py * py)
                for k in range(4):
                    disc = base + radii[k] * radii[k]
                    root = math.sqrt(disc) if disc >= 0.0 else math.nan
                    t = -along - root if k % 2 == 0 else -along + root
                    centres[1 + k] = math.atan2(py + t * ey, px + t * ex)
                    widths[1 + k] = scale * sigma / max(radii[k], 1e-300)
            lo = centres[0] - half
            hi = lo + 2.0 * half
            span = hi - lo
            count = 0
            for c in range(n_centres):
                pts[count] = centres[c]
                count += 1
            for c in range(n_centres):
                for sign in (1.0, -1.0):
                    for level in range(levels):
                        offset = widths[c] * _RATIO**level
                        offset = offset if math.isfinite(offset) and offset > 0.0 else 0.0
                        pts[count] = centres[c] + sign * min(offset, math.pi)
                        count += 1
            pts[count] = lo + span * 0.5
            count += 1
            for j in range(count):
                p = pts[j]
                if math.isnan(p):
                    p = lo
                p = lo + (p - lo) % _TWO_PI
                pts[j] = min(max(p, lo), hi)
            edges[0] = lo
            edges[1 : count + 1] = np.sort(pts[:count])
            edges[count + 1] = hi
            tol = 1e-12 * (hi - lo)
            total = 0.0
            a = lo
            for j in range(1, count + 2):
                b = edges[j]
                if b - edges[j - 1] <= tol:
                    continue
                half_width = 0.5 * (b - a)
                for g in range(m):
                    phi = a + half_width * (1.0 + x_gl[g])
                    value = _heading_value(math.cos(phi), math.sin(phi), px, py, gauss, ring)
                    total += half_width * w_gl[g] * value
                a = b
            out[i] = total
    return out


@kernel(f"float64[:]({_POINTS}, {GAUSSIAN}, {PRIOR_RING}, {_MAPPING})")
def _mapped_density(
    dx: np.ndarray,
    dy: np.ndarray,
    gauss: tuple[float, ...],
    ring: RingArgs,
    mapping: tuple[float, float, int, int],
) -> np.ndarray:
    """The heading integral by the periodic trapezoid rule after a conformal map.

    ``mapping`` is (spread, tol, n_start, n_max). The heading integrand, the prior's
    closed-form radial integral along e_phi of N(s e_phi; d, B), is periodic and
    analytic in phi with one peak, about the direction c of d and
    sigma_min / max(|d|, R_min) = w wide. The Moebius map of the circle

    .. math:: \\phi = c + 2 \\arctan(\\varepsilon \\tan(\\psi / 2)), \\quad
              \\phi'(\\psi) = \\varepsilon / (\\cos^2(\\psi/2) + \\varepsilon^2 \\sin^2(\\psi/2)),

    with epsilon = min(1, spread w) spreads the peak over psi of order one and keeps the
    integrand periodic and analytic, so the trapezoid rule in psi converges
    geometrically. The rule starts with ``n_start`` nodes and doubles (nested: the new
    nodes interleave the old) until two successive sums agree within ``tol``, at most
    ``n_max`` nodes: with geometric convergence the difference delta of the last two
    sums is the error of the coarser one, and the finer one's is about delta^2 / I for
    an integral of size I, so a ``tol`` of sqrt(epsilon) I aims at an error near
    epsilon I (a heuristic: where the integral is far below I the error can be larger).
    For a B that is not eccentric: an eccentric B's long density adds peaks away from c.
    """
    spread, tol, n_start, n_max = mapping
    n = dx.size
    out = np.empty(n)
    sigma = math.sqrt(gauss[4])
    inner = max(ring[0], 1e-300)
    for i in range(n):
        px = dx[i]
        py = dy[i]
        dist = math.hypot(px, py)
        if dist > 0.0:
            cx, cy = px / dist, py / dist
        else:
            cx, cy = 1.0, 0.0
        eps = min(1.0, spread * sigma / max(dist, inner))
        eps2 = eps * eps
        count = n_start
        total = 0.0
        previous = math.nan
        step = 2.0 * math.pi / count
        first = 0.0  # psi of the first node to add: 0, then the midpoints
        stride = step
        while True:
            j_count = count if first == 0.0 else count // 2
            for j in range(j_count):
                psi = first + j * stride
                ch = math.cos(0.5 * psi)
                sh = math.sin(0.5 * psi)
                rho2 = ch * ch + eps2 * sh * sh
                cos2 = (ch * ch - eps2 * sh * sh) / rho2
                sin2 = 2.0 * eps * sh * ch / rho2
                ux = cx * cos2 - cy * sin2
                uy = cy * cos2 + cx * sin2
                total += _heading_value(ux, uy, px, py, gauss, ring) * eps / rho2
            estimate = total * (2.0 * math.pi / count)
            if abs(estimate - previous) <= tol or count >= n_max:
                break
            previous = estimate
            stride = 2.0 * math.pi / count
            first = 0.5 * stride
            count *= 2
        out[i] = estimate
    return out
