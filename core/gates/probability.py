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

with erf and exp only (:func:`_ray_moments`). The conditional probability is then
a 1-D integral over direction; the unconditional one integrates the gate's
directions and radii and the prior's heading, with the prior's speed in closed form.
Every integral uses composite Gauss-Legendre panels graded towards its thin features
(:mod:`plotgate.core.gates.quadrature`): the Gaussian's angular peak, the kinks of the gate's
boundary, and the edges of the prior's ring. The conditional probability bisects its
panels until a 10-point and a 5-point rule agree to 1e-10 and reports the sum of their
differences (the error of the lower order: a bound in practice). The unconditional
one reports its difference from a second, lower-order rule on interleaved panels: an
estimate, not a bound. Checked against 14-point rules it was within a factor 5 of the
true error wherever that exceeded 1e-9, and the true error stayed below 1e-7 on every
tested case (the target is 1e-6).

:func:`monte_carlo_probability` samples the same set-up and applies the gate tests
themselves; it is for checking the quadrature, not for production use.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, cast

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import ndtr

from plotgate.core.errors import ParameterError
from plotgate.core.gates.heading import BLOCK, mapped_density, prior_density
from plotgate.core.gates.kinds import Gate
from plotgate.core.gates.parameters import ring_radii
from plotgate.core.gates.quadrature import (
    adaptive_panels,
    breakpoints,
    gauss_legendre,
    panel_rule,
)
from plotgate.core.gates.regions import MarkGeometry, StarRegion
from plotgate.core.sym2 import Sym2, inverse
from plotgate.core.validation import as_points, pair_count

__all__ = [
    "GateProbability",
    "Prior",
    "compiled_density",
    "conditional_probability",
    "mapped_prior_density",
    "monte_carlo_probability",
    "prior_density_reference",
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
HEADING_SPREAD = 4.0
"""epsilon / w of the conformal map of the heading integral: the peak, w wide, is spread
over about a quarter of the mapped circle."""
HEADING_TOL = 1e-10
"""Wanted error of the mapped trapezoid sum of the heading integral, relative to a bound
on that integral (successive sums agree within its square root). The stop on delta^2 is
a heuristic: at the gate nodes of Konovalov's example the largest error measured was
3e-7 of the bound (at nodes where the integral is far below it); the second rule's
looser heading puts that into the error estimate (1.4e-8 there, against 4e-10 from the
numpy reference)."""
M_CONDITIONAL = (10, 5)
"""Gauss-Legendre orders of the adaptive conditional probability's two rules."""
_CONDITIONAL_TOL = 1e-10
"""Absolute error the conditional probability's panels are refined to."""
_SQRT_2PI = np.sqrt(2.0 * np.pi)
_ECCENTRIC = 3.0
"""Axis ratio sqrt(lambda_max / lambda_min) of B from which its axes get their own panels."""
_SMEARED = 8.0
"""Axis ratio from which the unconditional quadrature also grades towards the smeared
ring's edges: below it they are blurred enough that the error estimate stays under
1e-6 without them (measured up to 6e-7 at an axis ratio of 8.7), above it the estimate
would reach 1e-5 by a ratio of 14, and with them it stays near 1e-8 at 6-8 times
the cost."""
_TAIL = 9.0
"""Standard deviations beyond which a Gaussian's density (< e^-40) is left out."""
_THIN_NODES = 8
"""Gauss-Legendre nodes across a prior ring no wider than sigma_min: the Gaussian varies
by at most one standard deviation across it, and 8 nodes hold the integral to ~1e-12."""


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


def _column(S: Sym2, ndim: int) -> Sym2:
    return Sym2(*(np.reshape(x, (-1,) + (1,) * (ndim - 1)) for x in S))


def _axes(B: Sym2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """lambda_min, lambda_max and the major-axis direction of B."""
    half_diff = 0.5 * (B.xx - B.yy)
    root = np.hypot(half_diff, B.xy)
    mean = 0.5 * (B.xx + B.yy)
    lam_max = mean + root
    return B.det / lam_max, lam_max, 0.5 * np.arctan2(B.xy, half_diff)


def _ray_moments(
    ux: np.ndarray,
    uy: np.ndarray,
    mx: np.ndarray,
    my: np.ndarray,
    Q: Sym2,
    t1: np.ndarray | np.float64,
    t2: np.ndarray | np.float64,
) -> tuple[np.ndarray, np.ndarray]:
    """M_k = integral over t in [t1, t2] of t^k exp(-q(t)/2), k = 0, 1.

    q(t) = (t u - m)^T Q (t u - m) with a unit direction u and Q = B^-1. Writing
    a = u^T Q u, b = u^T Q m and the minimum of q along the ray
    k = |Q| (u x m)^2 / a (Lagrange's identity, free of cancellation),

    M0 = sqrt(2 pi / a) exp(-k/2) [Phi(s2) - Phi(s1)],  s_i = (a t_i - b) / sqrt(a),
    M1 = [exp(-q(t1)/2) - exp(-q(t2)/2)] / a + (b / a) M0.
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


def _angle_breaks(
    start: np.ndarray,
    span: np.ndarray,
    centres: list[np.ndarray],
    widths: list[np.ndarray],
    kinks: np.ndarray | None,
    uniform: int,
) -> np.ndarray:
    return breakpoints(
        start,
        start + span,
        np.stack(centres, axis=-1),
        np.stack(widths, axis=-1),
        kinks,
        periodic=True,
        uniform=uniform,
    )


def _conditional_integrand(
    region: StarRegion, Q: Sym2, rel: np.ndarray
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Closed-form radial integral M1 over the gate along rays theta, for given problems."""

    def integrand(rows: np.ndarray, theta: np.ndarray) -> np.ndarray:
        lo, hi = region.radii(theta, rows)
        Qr = Sym2(*(x[rows][:, None] for x in Q))
        _, M1 = _ray_moments(
            np.cos(theta), np.sin(theta), rel[rows, :1], rel[rows, 1:], Qr, lo, hi
        )
        return M1

    return integrand


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
    """
    v = as_points("velocity", velocity)
    n = pair_count(geometry=(geometry.n,) if geometry.n > 1 else (), velocity=v.shape[:-1])
    if geometry.n != n:  # one geometry, many velocities (a curve against speed)
        geometry = geometry.take(np.zeros(n, dtype=int))
    region = gate.region(geometry)
    mean = np.broadcast_to(v * geometry.tau, (n, 2))
    rel = mean - region.origin
    lam_min, _, major = _axes(geometry.B)
    centres = [np.arctan2(rel[:, 1], rel[:, 0]), major, major + np.pi]
    # starting panels: the Gaussian subtends about sigma / |m| seen from the origin, or
    # sigma / lo where the inner edge lo of the gate cuts it (then about B's major axis);
    # panels are then bisected until two rules agree
    inner = region.radii(np.stack(centres, axis=-1))[0].min(axis=-1)
    reach = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), np.maximum(inner, 1e-300))
    with np.errstate(over="ignore"):  # a Gaussian about the origin: infinitely wide, no grading
        width = np.sqrt(lam_min) / reach
    edges = _angle_breaks(region.start, region.span, centres, [width] * 3, region.kinks, uniform=4)
    norm = 2.0 * np.pi * np.sqrt(geometry.B.det)
    integral, error = adaptive_panels(
        _conditional_integrand(region, inverse(geometry.B), rel),
        edges,
        _CONDITIONAL_TOL * norm,
        orders=M_CONDITIONAL,
    )
    return GateProbability(integral / norm, error / norm)


def _ring_features(
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


def _prior_weights(prior: str, R_min: float, R_max: float) -> tuple[float, float]:
    """(c0, c1): the prior density of the length s is c0 + c1 s on [R_min, R_max]."""
    if prior == "speed":
        return 1.0 / (R_max - R_min), 0.0
    return 0.0, 2.0 / (R_max * R_max - R_min * R_min)


def _thin_ring_rule(prior: str, R_min: float, R_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes s_j and weights of the prior's integral over a ring thinner than sigma_min.

    Gauss-Legendre in u = (s - R_min) / (R_max - R_min) on [0, 1], where the prior's
    density is 1 (``"speed"``) or 2 s / (R_max + R_min) (``"area"``): finite and free of
    cancellation however thin or small the ring (tau or the speeds down to 5e-324),
    where the closed form's 1 / (R_max^2 - R_min^2) overflows and its moments cancel.
    """
    u, w = panel_rule(np.array([0.0, 1.0]), _THIN_NODES)
    s = R_min + u * (R_max - R_min)
    if prior == "area":
        w = w * (2.0 * s / (R_max + R_min))
    return s, w


def _unconditional_chunk(
    region: StarRegion,
    B: Sym2,
    R_min: float,
    R_max: float,
    prior: str,
    rule: tuple[int, float],
    theta_edges: np.ndarray,
    reference: bool,
) -> np.ndarray:
    """Integral over the gate of the prior-averaged density, for a chunk of problems."""
    m, scale = rule
    lam_min, lam_max, major = _axes(B)
    sigma = np.sqrt(lam_min)[:, None, None]
    reach = R_max + _TAIL * np.sqrt(lam_max)[:, None]  # beyond it the density is < 1e-17
    # gate directions theta: (n, T)
    theta, w_theta = panel_rule(theta_edges, m)
    ux, uy = np.cos(theta), np.sin(theta)
    lo, hi = region.radii(theta)
    ox, oy = region.origin[:, :1], region.origin[:, 1:]
    # gate radii rho on the part of each ray within reach of z1, graded towards the
    # prior ring's edges and the ray's closest approach to z1: (n, T, R)
    eccentric = bool((lam_max >= _SMEARED**2 * lam_min).any())
    minor = (major + 0.5 * np.pi)[:, None] if eccentric else None
    features = _ring_features(ox, oy, ux, uy, (R_min, R_max), minor)
    closest = features[..., 0]
    with np.errstate(invalid="ignore"):
        chord = np.sqrt(np.maximum(reach**2 - (ox * ox + oy * oy - closest**2), 0.0))
    lo = np.maximum(lo, closest - chord)
    hi = np.maximum(np.minimum(hi, closest + chord), lo)
    rho_edges = breakpoints(lo, hi, features, np.broadcast_to(scale * sigma, features.shape))
    rho, w_rho = panel_rule(rho_edges, m)
    n, T, R = rho.shape
    dx = (ox[..., None] + rho * ux[..., None]).reshape(n, T * R)
    dy = (oy[..., None] + rho * uy[..., None]).reshape(n, T * R)
    density = np.empty((n, T * R))
    if reference:
        block = max(1, BLOCK // n)
        for first in range(0, T * R, block):
            cols = slice(first, first + block)
            density[:, cols] = prior_density_reference(
                dx[:, cols], dy[:, cols], B, R_min, R_max, prior, m, scale, eccentric
            )
    else:
        for i in range(n):
            Bi = Sym2(*(x[i : i + 1] for x in B))
            if lam_max[i] >= _ECCENTRIC**2 * lam_min[i] or R_max - R_min <= np.sqrt(lam_min[i]):
                density[i] = compiled_density(
                    dx[i], dy[i], Bi, R_min, R_max, prior, m, scale, eccentric, max(1, BLOCK // n)
                )
            else:
                density[i] = mapped_prior_density(dx[i], dy[i], Bi, R_min, R_max, prior, scale)
    radial = np.einsum("ntr,ntr->nt", w_rho * rho, density.reshape(n, T, R))
    total = np.einsum("nt,nt->n", w_theta, radial)
    probability: np.ndarray = total / (4.0 * np.pi * np.pi * np.sqrt(B.det))
    return probability


def compiled_density(
    dx: np.ndarray,
    dy: np.ndarray,
    B: Sym2,
    R_min: float,
    R_max: float,
    prior: str,
    m: int,
    scale: float,
    eccentric: bool,
    block: int,
) -> np.ndarray:
    """:func:`prior_density_reference` for one problem (B of length 1) at (K,) points, compiled.

    The kernel :func:`plotgate.core.gates.heading.prior_density` builds the same heading
    panels point by point (``block`` points share their grading levels, as one array of
    the reference does) and sums the same closed-form radial integrals.
    """
    lam_min, lam_max, major = (float(x[0]) for x in _axes(B))
    Q = inverse(B)
    closed_form = R_max - R_min > np.sqrt(lam_min)
    c0, c1, s, w = 0.0, 0.0, np.empty(0), np.empty(0)
    if closed_form:
        c0, c1 = _prior_weights(prior, R_min, R_max)
    elif R_max > R_min:
        s, w = _thin_ring_rule(prior, R_min, R_max)
    else:
        s, w = np.array([R_max]), np.array([1.0])
    x_gl, w_gl = gauss_legendre(m)
    density: np.ndarray = prior_density(
        np.ascontiguousarray(dx, dtype=np.float64),
        np.ascontiguousarray(dy, dtype=np.float64),
        float(Q.xx[0]),
        float(Q.xy[0]),
        float(Q.yy[0]),
        float(Q.det[0]),
        lam_min,
        lam_max,
        major,
        float(R_min),
        float(R_max),
        float(c0),
        float(c1),
        s,
        w,
        bool(closed_form),
        eccentric,
        x_gl,
        w_gl,
        float(scale),
        block,
    )
    return density


def mapped_prior_density(
    dx: np.ndarray,
    dy: np.ndarray,
    B: Sym2,
    R_min: float,
    R_max: float,
    prior: str,
    scale: float = 1.0,
) -> np.ndarray:
    """:func:`prior_density_reference` by the mapped periodic trapezoid rule, compiled.

    For one problem (B of length 1) at (K,) points, a ring wider than sigma_min and a
    nearly round B (axis ratio below :data:`_ECCENTRIC`, as in Konovalov's example): the
    heading integrand has one peak, about as wide in every direction, and
    :func:`plotgate.core.gates.heading.mapped_density` integrates it with a
    geometrically converging rule, doubling its nodes until two sums agree within
    sqrt(:data:`HEADING_TOL`) (times ``scale``: the lower rule of :data:`RULES` gets a
    looser heading, so their difference also covers the heading's error) of
    2 pi (c0 + c1 R_max) sqrt(2 pi lambda_max), a bound on the integral; the finer sum's
    error is then about :data:`HEADING_TOL` of it.
    """
    lam_min, lam_max, _ = (float(x[0]) for x in _axes(B))
    Q = inverse(B)
    c0, c1 = _prior_weights(prior, R_min, R_max)
    bound = 2.0 * np.pi * (c0 + c1 * R_max) * np.sqrt(2.0 * np.pi * lam_max)
    density: np.ndarray = mapped_density(
        np.ascontiguousarray(dx, dtype=np.float64),
        np.ascontiguousarray(dy, dtype=np.float64),
        float(Q.xx[0]),
        float(Q.xy[0]),
        float(Q.yy[0]),
        float(Q.det[0]),
        lam_min,
        float(R_min),
        float(R_max),
        float(c0),
        float(c1),
        HEADING_SPREAD,
        float(np.sqrt(HEADING_TOL) * scale * bound),
        16,
        1 << 14,
    )
    return density


def prior_density_reference(
    dx: np.ndarray,
    dy: np.ndarray,
    B: Sym2,
    R_min: float,
    R_max: float,
    prior: str,
    m: int,
    scale: float,
    eccentric: bool,
) -> np.ndarray:
    """2 pi |B|^1/2 (2 pi) g(d) at (n, K) points d: the heading integral of the prior's
    closed-form radial integral of N(s e_phi; d, B), with numpy (the tested oracle of
    :func:`compiled_density`).

    Headings are integrated within reach of d and graded about the direction of d:
    N(d, B) subtends about sigma_min / |d|, or sigma_min / R_min where the inner circle
    cuts it. A long N(d, B) meets the prior ring along the line d + t e_major, and the
    directions of that line's crossings of the ring's circles are sharp features too.
    """
    lam_min, lam_max, major = _axes(B)
    sigma = np.sqrt(lam_min)[:, None]
    dist = np.hypot(dx, dy)
    # near the origin (or a vanishing ring) the ratios overflow to inf: every heading
    # is within reach, and an infinite width grades nothing
    with np.errstate(over="ignore"):
        half = np.arcsin(
            np.minimum(1.0, _TAIL * np.sqrt(lam_max)[:, None] / np.maximum(dist, 1e-300))
        )
        half = np.where(half < 0.5 * np.pi, half, np.pi)
        centres = [np.arctan2(dy, dx)]
        widths = [scale * sigma / np.maximum(dist, max(R_min, 1e-300))]
        if eccentric:
            ex, ey = np.cos(major)[:, None], np.sin(major)[:, None]
            crossings = _ring_features(dx, dy, ex, ey, (R_min, R_max), None)[..., 1:]
            for k, R in enumerate((R_min, R_min, R_max, R_max)):
                t = crossings[..., k]
                centres.append(np.arctan2(dy + t * ey, dx + t * ex))
                widths.append(np.broadcast_to(scale * sigma / max(R, 1e-300), t.shape))
    phi_edges = _angle_breaks(centres[0] - half, 2.0 * half, centres, widths, None, uniform=2)
    phi, w_phi = panel_rule(phi_edges, m)
    Q = _column(inverse(B), 3)
    ex, ey = np.cos(phi), np.sin(phi)
    mx, my = dx[..., None], dy[..., None]
    if R_max - R_min > float(sigma.min()):
        c0, c1 = _prior_weights(prior, R_min, R_max)
        M0, M1 = _ray_moments(ex, ey, mx, my, Q, np.float64(R_min), np.float64(R_max))
        kernel = c0 * M0 + c1 * M1 if c1 else c0 * M0
    else:  # a ring thinner than the Gaussian (v_min = v_max: a circle) is a smooth factor
        s, w = _thin_ring_rule(prior, R_min, R_max) if R_max > R_min else ([R_max], [1.0])
        kernel = np.zeros(np.broadcast_shapes(ex.shape, mx.shape))
        for s_j, w_j in zip(s, w, strict=True):
            nx, ny = s_j * ex - mx, s_j * ey - my
            kernel += w_j * np.exp(-0.5 * (Q.xx * nx * nx + 2.0 * Q.xy * nx * ny + Q.yy * ny * ny))
    density: np.ndarray = np.einsum("nkf,nkf->nk", w_phi, kernel)
    return density


def _theta_edges(
    region: StarRegion, B: Sym2, R_min: float, R_max: float, scale: float = 1.0
) -> np.ndarray:
    """Gate-direction panels: kinks, plus the tangents to the prior ring from an outer origin."""
    lam_min, _, major = _axes(B)
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
    if (lam_max >= _ECCENTRIC**2 * lam_min).any():
        width = np.where(lam_max >= _ECCENTRIC**2 * lam_min, np.sqrt(lam_min / lam_max), np.inf)
        centres += [major + k * 0.5 * np.pi for k in range(4)]
        widths += [width] * 4
    full = bool((region.span >= 2.0 * np.pi).all())
    widths = [scale * w for w in widths]
    return _angle_breaks(
        region.start, region.span, centres, widths, region.kinks, uniform=8 if full else 2
    )


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
    high, low = (
        unconditional_quadrature(gate, geometry, R_min, R_max, prior, rule) for rule in RULES
    )
    return GateProbability(high, np.abs(high - low))


def unconditional_quadrature(
    gate: Gate,
    geometry: MarkGeometry,
    R_min: float,
    R_max: float,
    prior: str,
    rule: tuple[int, float],
    *,
    reference: bool = False,
) -> np.ndarray:
    """The unconditional probability with one rule, problem by problem.

    ``rule`` is (Gauss-Legendre order per panel, scale of the grading widths), as in
    :data:`RULES`; R_min and R_max are the prior ring's radii (m) and ``prior`` is
    ``"area"`` or ``"speed"``, all validated by the caller
    (:func:`unconditional_probability`). :func:`plotgate.core.gates.analysis.design_gate`
    searches with a cheaper rule, and the tests check the error estimate against
    higher-order rules.

    The prior-averaged density at the gate's nodes is computed by the compiled
    :func:`compiled_density`, or with ``reference=True`` by its numpy oracle
    :func:`prior_density_reference` (same nodes, same result to rounding).

    Each problem is one 3-D quadrature of 10^5-10^6 nodes. Problems are not
    stacked into one array: their features lie in different places, and a common array
    would pad every problem to the panels of the most demanding one.
    """
    out = np.empty(geometry.n)
    for i in range(geometry.n):
        part = geometry.take(slice(i, i + 1))
        region = gate.region(part)
        theta_edges = _theta_edges(region, part.B, R_min, R_max, rule[1])
        out[i] = _unconditional_chunk(
            region, part.B, R_min, R_max, prior, rule, theta_edges, reference
        )[0]
    return out


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
