"""The prior-averaged density's heading integral, compiled (Konovalov, eq. 6).

:func:`plotgate.core.gates.probability.prior_density_reference` computes, at every node d
of the gate's quadrature, the heading integral of the prior's closed-form radial
integral of N(s e_phi; d, B) with numpy: it builds the graded heading panels of every
node as arrays, then the ray moments at every heading. :func:`prior_density` does the
same node by node in one compiled loop, with the same panels (the grading levels are
taken per block of :data:`BLOCK` nodes, as the reference takes them per array), so the
two agree to rounding; it never holds more than one node's headings in memory.
"""

from __future__ import annotations

import math

import numpy as np

from plotgate.core.compiled import kernel

__all__ = ["BLOCK", "MAX_LEVELS", "mapped_density", "prior_density", "radial_moment"]

BLOCK = 4096
"""Nodes whose heading panels share one number of grading levels (the reference's array)."""
MAX_LEVELS = 40
"""Most grading levels about one feature (:data:`plotgate.core.gates.quadrature.RATIO` ^ 40)."""
_RATIO = 3.0
_TAIL = 9.0
_SQRT_2PI = math.sqrt(2.0 * math.pi)
_TWO_PI = 2.0 * math.pi
_SQRT_HALF = math.sqrt(0.5)


@kernel(
    "float64(float64, float64, float64, float64, float64, float64, float64, float64, "
    "float64, float64, float64, float64)"
)
def radial_moment(
    ux: float,
    uy: float,
    mx: float,
    my: float,
    qxx: float,
    qxy: float,
    qyy: float,
    qdet: float,
    t1: float,
    t2: float,
    c0: float,
    c1: float,
) -> float:
    """c0 M0 + c1 M1 along the ray t u, t in [t1, t2], of exp(-q(t)/2) about m.

    The scalar form of the ray moments M0, M1 of :mod:`plotgate.core.gates.probability`
    (there vectorized over rays): Phi(s2) - Phi(s1) from the tail that does not cancel.
    """
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
    if c1 == 0.0:
        return c0 * M0
    M1 = (math.exp(-0.5 * (s1 * s1 + k)) - math.exp(-0.5 * (s2 * s2 + k)) + b * M0) / a
    return c0 * M0 + c1 * M1


@kernel(
    "float64[:](float64[:], float64[:], float64, float64, float64, float64, float64, "
    "float64, float64, float64, float64, float64, float64, float64[:], float64[:], "
    "boolean, boolean, float64[:], float64[:], float64, int64)"
)
def prior_density(
    dx: np.ndarray,
    dy: np.ndarray,
    qxx: float,
    qxy: float,
    qyy: float,
    qdet: float,
    lam_min: float,
    lam_max: float,
    major: float,
    R_min: float,
    R_max: float,
    c0: float,
    c1: float,
    thin_s: np.ndarray,
    thin_w: np.ndarray,
    closed_form: bool,
    eccentric: bool,
    x_gl: np.ndarray,
    w_gl: np.ndarray,
    scale: float,
    block: int,
) -> np.ndarray:
    """2 pi |B|^1/2 (2 pi) g(d) at the points (dx, dy), heading panels graded as the reference.

    Parameters
    ----------
    dx, dy : (K,) float64
        Points d relative to the first mark, m.
    qxx, qxy, qyy, qdet : float
        B^-1 and its determinant.
    lam_min, lam_max, major : float
        B's eigenvalues and the direction of its major axis.
    R_min, R_max : float
        The prior ring's radii, m.
    c0, c1 : float
        The prior's density c0 + c1 s of the length s (used when ``closed_form``).
    thin_s, thin_w : (J,) float64
        Nodes and weights over a ring thinner than sigma_min (used otherwise).
    closed_form, eccentric : bool
        Radial integral in closed form; grade also about the crossings of the line
        d + t e_major with the ring's circles.
    x_gl, w_gl : (m,) float64
        Gauss-Legendre nodes and weights on [-1, 1].
    scale : float
        Scale of the grading widths.
    block : int
        Nodes that share one number of grading levels.
    """
    n = dx.size
    out = np.empty(n)
    m = x_gl.size
    sigma = math.sqrt(lam_min)
    sig_max = math.sqrt(lam_max)
    ex = math.cos(major)
    ey = math.sin(major)
    n_centres = 5 if eccentric else 1
    centres = np.empty(n_centres)
    widths = np.empty(n_centres)
    pts = np.empty(3 + n_centres * (1 + 2 * MAX_LEVELS))
    edges = np.empty(pts.size)
    radii = (R_min, R_min, R_max, R_max)
    inner = max(R_min, 1e-300)
    for first in range(0, n, block):
        last = min(n, first + block)
        # pass 1: the block's grading levels (quadrature.breakpoints' _levels)
        ratio = -1.0
        for i in range(first, last):
            dist = math.hypot(dx[i], dy[i])
            half = math.asin(min(1.0, _TAIL * sig_max / max(dist, 1e-300)))
            half = half if half < 0.5 * math.pi else math.pi
            lo = math.atan2(dy[i], dx[i]) - half
            span = (lo + 2.0 * half) - lo
            w0 = scale * sigma / max(dist, inner)
            if math.isfinite(w0) and w0 > 0.0:
                ratio = max(ratio, span / w0)
            if eccentric:
                for k in range(4):
                    wk = scale * sigma / max(radii[k], 1e-300)
                    if math.isfinite(wk) and wk > 0.0:
                        ratio = max(ratio, span / wk)
        if ratio < 0.0:
            levels = 0
        elif ratio <= 1.0:
            levels = 1
        else:
            levels = int(min(MAX_LEVELS, math.ceil(math.log(ratio) / math.log(_RATIO)) + 1))
        # pass 2: each node's panels and headings
        for i in range(first, last):
            px = dx[i]
            py = dy[i]
            dist = math.hypot(px, py)
            half = math.asin(min(1.0, _TAIL * sig_max / max(dist, 1e-300)))
            half = half if half < 0.5 * math.pi else math.pi
            centres[0] = math.atan2(py, px)
            widths[0] = scale * sigma / max(dist, inner)
            if eccentric:
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
                    ux = math.cos(phi)
                    uy = math.sin(phi)
                    if closed_form:
                        value = radial_moment(
                            ux, uy, px, py, qxx, qxy, qyy, qdet, R_min, R_max, c0, c1
                        )
                    else:
                        value = 0.0
                        for j_s in range(thin_s.size):
                            nx = thin_s[j_s] * ux - px
                            ny = thin_s[j_s] * uy - py
                            value += thin_w[j_s] * math.exp(
                                -0.5 * (qxx * nx * nx + 2.0 * qxy * nx * ny + qyy * ny * ny)
                            )
                    total += half_width * w_gl[g] * value
                a = b
            out[i] = total
    return out


@kernel(
    "float64[:](float64[:], float64[:], float64, float64, float64, float64, float64, "
    "float64, float64, float64, float64, float64, float64, int64, int64)"
)
def mapped_density(
    dx: np.ndarray,
    dy: np.ndarray,
    qxx: float,
    qxy: float,
    qyy: float,
    qdet: float,
    lam_min: float,
    R_min: float,
    R_max: float,
    c0: float,
    c1: float,
    spread: float,
    tol: float,
    n_start: int,
    n_max: int,
) -> np.ndarray:
    """2 pi |B|^1/2 (2 pi) g(d) by the periodic trapezoid rule after a conformal map.

    The heading integrand, the prior's closed-form radial integral along e_phi of
    N(s e_phi; d, B), is periodic and analytic in phi with one peak, about the direction
    c of d and sigma_min / max(|d|, R_min) = w wide. The Moebius map of the circle

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
    For a B that is not eccentric: an eccentric B's long density adds peaks away from c
    (:func:`prior_density` grades about them).
    """
    n = dx.size
    out = np.empty(n)
    sigma = math.sqrt(lam_min)
    inner = max(R_min, 1e-300)
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
                value = radial_moment(ux, uy, px, py, qxx, qxy, qyy, qdet, R_min, R_max, c0, c1)
                total += value * eps / rho2
            estimate = total * (2.0 * math.pi / count)
            if abs(estimate - previous) <= tol or count >= n_max:
                break
            previous = estimate
            stride = 2.0 * math.pi / count
            first = 0.5 * stride
            count *= 2
        out[i] = estimate
    return out
