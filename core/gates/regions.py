"""Gates as plane regions, for gating probabilities and areas (seed 000, 002, 003).

A gating-probability problem (seed 000) places the first mark z1 at range r and
azimuth az from the radar, gives both marks' range and azimuth errors, and asks how
likely the second mark, taken tau seconds later, falls in a gate built about z1.
:class:`MarkGeometry` holds that set-up for N problems at once (a curve against
range is N geometries). Each gate kind is a small frozen dataclass with

- ``region(geometry)``: the gate as a :class:`StarRegion`, the form the quadrature of
  :mod:`plotgate.core.gates.probability` integrates over, and
- ``contains(geometry, z2)``: the gate test itself, delegating to the gate functions
  of :mod:`plotgate.core.gates.capture`, :mod:`plotgate.core.gates.tracking` and
  :mod:`plotgate.core.gates.polar`,
  which is what the Monte Carlo check samples.

Every gate is, seen from some origin o, a radial interval per direction: rays from o
in direction u(theta) = (cos theta, sin theta) (theta counter-clockwise from east)
meet the gate in [lo(theta), hi(theta)]. Ring, combined and expanded gates are
star-shaped about z1 (DESIGN section 3); ellipse and rectangular gates about their
centre; a polar sector is an interval of range over an interval of azimuth about
the radar. Positions in a region are relative to z1.

Decision (the paper is silent): B = P1 + P2 with both covariances evaluated at the
first mark's position. The marks are at most v_max tau apart, small against the
range, so this is the paper's "B from both measurements"; it keeps the second mark's
distribution exactly Gaussian, which the probabilities of seed 000 eq. (1)-(2) assume.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import GeometryError
from plotgate.core.frames import (
    cartesian_to_polar,
    polar_covariance_to_cartesian,
    polar_to_cartesian,
)
from plotgate.core.gates.capture import combined_gate, expanded_gate, ring_gate
from plotgate.core.gates.parameters import positive_coefficient, ring_radii, standard_deviation
from plotgate.core.gates.polar import first_association_gate, sector_gate
from plotgate.core.gates.thresholds import expansion_coefficient, gate_threshold
from plotgate.core.gates.tracking import ellipse_gate, rectangular_gate
from plotgate.core.sym2 import Sym2, sym2
from plotgate.core.validation import (
    as_array,
    as_covariance,
    as_points,
    as_scalar,
    first_index,
    pair_count,
    require_positive,
    require_scalar,
    to_pairs,
)

__all__ = [
    "CombinedGate",
    "EllipseGate",
    "ExpandedGate",
    "FirstAssociationGate",
    "Gate",
    "MarkGeometry",
    "RectangularGate",
    "RingGate",
    "SectorGate",
    "StarRegion",
    "mark_geometry",
]

TWO_PI = 2.0 * np.pi
Rows = slice | np.ndarray
"""Problems a radii call is for: all (``slice(None)``) or an index array, one per row."""
_ALL = slice(None)


@dataclass(frozen=True)
class MarkGeometry:
    """N gating problems: the first mark seen from a radar at the origin.

    Attributes
    ----------
    r, az : (N,) ndarray
        Range (m) and azimuth (rad, clockwise from north) of the first mark.
    sigma_r1, sigma_az1, sigma_r2, sigma_az2 : (N,) ndarray
        Range (m) and azimuth (rad) standard deviations of the first and second mark.
    tau : float
        Time between the marks, s.
    z1 : (N, 2) ndarray
        First mark, x east / y north, m.
    P1, P2 : (N, 2, 2) ndarray
        The marks' Cartesian covariances, both at z1 (module docstring), m^2.
    B : Sym2
        P1 + P2, the covariance of the second mark about its mean (seed 000, eq. 1).
    """

    r: np.ndarray
    az: np.ndarray
    sigma_r1: np.ndarray
    sigma_az1: np.ndarray
    sigma_r2: np.ndarray
    sigma_az2: np.ndarray
    tau: float
    z1: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    B: Sym2

    @property
    def n(self) -> int:
        return len(self.r)

    def take(self, rows: slice | np.ndarray) -> MarkGeometry:
        """The problems in ``rows``."""
        return MarkGeometry(
            self.r[rows],
            self.az[rows],
            self.sigma_r1[rows],
            self.sigma_az1[rows],
            self.sigma_r2[rows],
            self.sigma_az2[rows],
            self.tau,
            self.z1[rows],
            self.P1[rows],
            self.P2[rows],
            Sym2(*(x[rows] for x in self.B)),
        )


def mark_geometry(
    r: ArrayLike,
    az: ArrayLike,
    sigma_r: ArrayLike,
    sigma_az: ArrayLike,
    tau: float,
    sigma_r2: ArrayLike | None = None,
    sigma_az2: ArrayLike | None = None,
) -> MarkGeometry:
    """Validate and build :class:`MarkGeometry` for N problems.

    Parameters
    ----------
    r : float or (N,) array_like
        Range of the first mark, m, > 0.
    az : float or (N,) array_like
        Its azimuth, rad, clockwise from north.
    sigma_r, sigma_az : float or (N,) array_like
        Range (m) and azimuth (rad) standard deviations of the first mark, > 0.
    tau : float
        Time between the marks, s, > 0.
    sigma_r2, sigma_az2 : float or (N,) array_like, optional
        The second mark's; default equal to the first's (seed 000's example).

    Examples
    --------
    The paper's example at 50 km: B has 2 sigma_r^2 = 8e4 m^2 along the line of
    sight and 2 (r sigma_az)^2 = 3.8e5 m^2 across it.

    >>> g = mark_geometry(50e3, 0.0, 200.0, np.radians(0.5), tau=5.0)
    >>> g.n, np.round(g.B.xx), np.round(g.B.yy)
    (1, array([380772.]), array([80000.]))
    """
    r = as_array("r", r)
    az = as_array("az", az)
    s_r1 = standard_deviation("sigma_r", sigma_r)
    s_az1 = standard_deviation("sigma_az", sigma_az)
    s_r2 = s_r1 if sigma_r2 is None else standard_deviation("sigma_r2", sigma_r2)
    s_az2 = s_az1 if sigma_az2 is None else standard_deviation("sigma_az2", sigma_az2)
    tau = as_scalar("tau", tau)
    require_positive("tau", tau)
    n = pair_count(
        r=r.shape,
        az=az.shape,
        sigma_r=s_r1.shape,
        sigma_az=s_az1.shape,
        sigma_r2=s_r2.shape,
        sigma_az2=s_az2.shape,
    )
    r, az = to_pairs(r, n), to_pairs(az, n)
    if not (r > 0).all():
        bad = first_index(~(r > 0))
        raise GeometryError(
            "r", f"must be positive (the mark cannot sit on the radar), got {r[bad]}", bad
        )
    s_r1, s_az1, s_r2, s_az2 = (to_pairs(s, n) for s in (s_r1, s_az1, s_r2, s_az2))
    P1 = polar_covariance_to_cartesian(r, az, s_r1, s_az1)
    P2 = polar_covariance_to_cartesian(r, az, s_r2, s_az2)
    B = P1 + P2
    return MarkGeometry(
        r,
        az,
        s_r1,
        s_az1,
        s_r2,
        s_az2,
        tau,
        polar_to_cartesian(r, az),
        P1,
        P2,
        sym2(as_covariance("B", B)),
    )


class StarRegion(NamedTuple):
    """A gate as radial intervals about an origin, for N problems.

    Attributes
    ----------
    origin : (N, 2) ndarray
        Ray origin relative to z1, m.
    start, span : (N,) ndarray
        Directions covered, theta in [start, start + span] (rad, counter-clockwise
        from east); span = 2 pi for a full turn.
    kinks : (N, K) ndarray
        Directions where lo or hi is not smooth (NaN: none).
    radii : callable
        ``radii(theta, rows)`` returns (lo, hi), each shaped like theta, metres: theta
        is (N, T) for all problems, or (P, T) with ``rows`` (P,) naming the problem
        of each row.
    """

    origin: np.ndarray
    start: np.ndarray
    span: np.ndarray
    kinks: np.ndarray
    radii: Callable[..., tuple[np.ndarray, np.ndarray]]


def _full_turn(n: int, origin: np.ndarray, kinks: np.ndarray, radii: Callable) -> StarRegion:
    return StarRegion(
        np.broadcast_to(origin, (n, 2)), np.zeros(n), np.full(n, TWO_PI), kinks, radii
    )


def _no_kinks(n: int) -> np.ndarray:
    return np.full((n, 1), np.nan)


def _inverse_form(S: Sym2, theta: np.ndarray) -> np.ndarray:
    """u^T S^-1 u for u = (cos theta, sin theta); S components are (N, 1) or scalars."""
    c, s = np.cos(theta), np.sin(theta)
    return (S.yy * c * c - 2.0 * S.xy * c * s + S.xx * s * s) / S.det


def _column_sym2(S: Sym2) -> Sym2:
    return Sym2(*(np.asarray(x)[:, None] for x in S))


def _rows_of(S: Sym2, rows: Rows) -> Sym2:
    return Sym2(*(x[rows] for x in S))


@dataclass(frozen=True)
class RingGate:
    """Ring gate R_min <= |d| <= R_max (seed 000, Fig. 1); speeds in m/s."""

    v_min: float
    v_max: float

    def region(self, g: MarkGeometry) -> StarRegion:
        R_min, R_max = ring_radii(g.tau, self.v_min, self.v_max)
        n = g.n

        def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
            return np.full(theta.shape, R_min), np.full(theta.shape, R_max)

        return _full_turn(n, np.zeros(2), _no_kinks(n), radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        return ring_gate(g.z1[i], z2, g.tau, self.v_min, self.v_max).inside


@dataclass(frozen=True)
class CombinedGate:
    """Two-stage combined gate (seed 000, Fig. 4): the ring, else the P_G ellipse of B."""

    v_min: float
    v_max: float
    P_G: float

    def region(self, g: MarkGeometry) -> StarRegion:
        """Direction u: [max(0, R_min - h), R_max + h], h = sqrt(gamma / u^T B^-1 u)."""
        R_min, R_max = ring_radii(g.tau, self.v_min, self.v_max)
        require_scalar("P_G", self.P_G)
        gamma = float(gate_threshold(self.P_G))
        n = g.n
        B = _column_sym2(g.B)

        def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
            h = np.sqrt(gamma / _inverse_form(_rows_of(B, rows), theta))
            return np.maximum(R_min - h, 0.0), R_max + h

        # kinks where h = R_min: u^T B^-1 u = A0 + A1 cos(2 theta - 2 theta0) = gamma / R_min^2
        Bxx, Bxy, Byy, det = g.B
        A0 = 0.5 * (Bxx + Byy) / det
        A1 = np.hypot(0.5 * (Byy - Bxx), Bxy) / det
        theta0 = 0.5 * np.arctan2(-Bxy, 0.5 * (Byy - Bxx))
        # numpy division: a subnormal R_min gives gamma / R_min^2 = inf, so no kinks
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ratio = np.divide(gamma, R_min * R_min) if R_min > 0 else np.nan
            half = 0.5 * np.arccos((ratio - A0) / A1)
        kinks = theta0[:, None] + np.stack([half, -half, np.pi + half, np.pi - half], axis=-1)
        return _full_turn(n, np.zeros(2), kinks, radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        return combined_gate(
            g.z1[i], g.P1[i], z2, g.P2[i], g.tau, self.v_min, self.v_max, self.P_G
        ).inside


@dataclass(frozen=True)
class ExpandedGate:
    """Expanded ellipse gate (seed 000 ref. [4], Fig. 3): semi-axes R_max + K_g sigma."""

    v_max: float
    p: float

    def semi_axes(self, g: MarkGeometry) -> tuple[np.ndarray, np.ndarray]:
        """a (along the line of sight) and b (across it), m, from the first mark's sigmas."""
        _, R_max = ring_radii(g.tau, 0.0, self.v_max)
        require_scalar("p", self.p)
        K_g = float(expansion_coefficient(self.p))
        return R_max + K_g * g.sigma_r1, R_max + K_g * g.r * g.sigma_az1

    def region(self, g: MarkGeometry) -> StarRegion:
        a, b = (x[:, None] for x in self.semi_axes(g))
        los = (0.5 * np.pi - g.az)[:, None]  # math angle of the line of sight

        def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
            off = theta - los[rows]
            along, across = np.cos(off) / a[rows], np.sin(off) / b[rows]
            return np.zeros(theta.shape), 1.0 / np.sqrt(along * along + across * across)

        return _full_turn(g.n, np.zeros(2), _no_kinks(g.n), radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        return expanded_gate(
            g.z1[i], z2, g.tau, self.v_max, g.sigma_r1[i], g.sigma_az1[i], self.p
        ).inside


@dataclass(frozen=True)
class EllipseGate:
    """Chi-square ellipse gate nu^T S^-1 nu <= gamma(P_G) about z1 + offset.

    ``offset`` is the predicted displacement z_pred - z1 (m); ``S`` defaults to B.
    """

    P_G: float
    offset: tuple[float, float] = (0.0, 0.0)
    S: np.ndarray | None = None

    def _S(self, g: MarkGeometry) -> np.ndarray:
        if self.S is None:
            return g.P1 + g.P2
        return np.broadcast_to(as_covariance("S", self.S), (g.n, 2, 2))

    def region(self, g: MarkGeometry) -> StarRegion:
        require_scalar("P_G", self.P_G)
        gamma = float(gate_threshold(self.P_G))
        S = _column_sym2(sym2(self._S(g)))

        def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
            return np.zeros(theta.shape), np.sqrt(gamma / _inverse_form(_rows_of(S, rows), theta))

        return _full_turn(g.n, as_points("offset", self.offset), _no_kinks(g.n), radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        z_pred = g.z1[i] + as_points("offset", self.offset)
        return ellipse_gate(z2, z_pred, self._S(g)[i], self.P_G).inside


@dataclass(frozen=True)
class RectangularGate:
    """Rectangular gate |dx| <= k sigma_x, |dy| <= k sigma_y about z1 + offset (seed 003).

    sigma_x, sigma_y (m) default to sqrt(B_xx), sqrt(B_yy).
    """

    k: float
    offset: tuple[float, float] = (0.0, 0.0)
    sigma_x: float | None = None
    sigma_y: float | None = None

    def half_sizes(self, g: MarkGeometry) -> tuple[np.ndarray, np.ndarray]:
        k = positive_coefficient("k", self.k)
        s_x = (
            np.sqrt(g.B.xx)
            if self.sigma_x is None
            else standard_deviation("sigma_x", self.sigma_x)
        )
        s_y = (
            np.sqrt(g.B.yy)
            if self.sigma_y is None
            else standard_deviation("sigma_y", self.sigma_y)
        )
        return to_pairs(k * s_x, g.n), to_pairs(k * s_y, g.n)

    def region(self, g: MarkGeometry) -> StarRegion:
        hx, hy = self.half_sizes(g)
        corner = np.arctan2(hy, hx)[:, None]
        hx, hy = hx[:, None], hy[:, None]

        def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
            c, s = np.abs(np.cos(theta)), np.abs(np.sin(theta))
            with np.errstate(divide="ignore"):
                hi = np.minimum(hx[rows] / c, hy[rows] / s)
            return np.zeros(theta.shape), hi

        kinks = np.concatenate([corner, np.pi - corner, np.pi + corner, -corner], axis=-1)
        return _full_turn(g.n, as_points("offset", self.offset), kinks, radii)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        hx, hy = self.half_sizes(g)
        z_pred = g.z1[i] + as_points("offset", self.offset)
        return rectangular_gate(z2, z_pred, hx[i] / self.k, hy[i] / self.k, self.k).inside


def _sector(
    g: MarkGeometry, r_c: np.ndarray, az_c: np.ndarray, W_R: np.ndarray, W_az: np.ndarray
) -> StarRegion:
    """Ranges r_c +- W_R over azimuths az_c +- W_az about the radar, relative to z1."""
    r_lo = np.maximum(r_c - W_R, 0.0)[:, None]
    r_hi = (r_c + W_R)[:, None]
    W_az = np.minimum(W_az, np.pi)

    def radii(theta: np.ndarray, rows: Rows = _ALL) -> tuple[np.ndarray, np.ndarray]:
        return (np.broadcast_to(r_lo[rows], theta.shape), np.broadcast_to(r_hi[rows], theta.shape))

    # azimuth az (clockwise from north) is the math angle pi/2 - az
    return StarRegion(-g.z1, 0.5 * np.pi - az_c - W_az, 2.0 * W_az, _no_kinks(g.n), radii)


@dataclass(frozen=True)
class SectorGate:
    """Polar sector gate about the prediction z1 + offset (seed 002 eq. 1-2, seed 003).

    Windows K_R sqrt(sigma_r2^2 + sigma_r_pred^2) and K_az sqrt(sigma_az2^2 +
    sigma_az_pred^2); the prediction's sigmas default to the first mark's.
    """

    K_R: float
    K_az: float
    offset: tuple[float, float] = (0.0, 0.0)
    sigma_r_pred: float | None = None
    sigma_az_pred: float | None = None

    def _prediction(self, g: MarkGeometry) -> tuple[np.ndarray, ...]:
        r_p, az_p = cartesian_to_polar(g.z1 + as_points("offset", self.offset))
        s_r = (
            g.sigma_r1
            if self.sigma_r_pred is None
            else standard_deviation("sigma_r_pred", self.sigma_r_pred)
        )
        s_az = (
            g.sigma_az1
            if self.sigma_az_pred is None
            else standard_deviation("sigma_az_pred", self.sigma_az_pred)
        )
        return r_p, az_p, to_pairs(s_r, g.n), to_pairs(s_az, g.n)

    def region(self, g: MarkGeometry) -> StarRegion:
        K_R = positive_coefficient("K_R", self.K_R)
        K_az = positive_coefficient("K_az", self.K_az)
        r_p, az_p, s_r, s_az = self._prediction(g)
        return _sector(
            g, r_p, az_p, K_R * np.hypot(g.sigma_r2, s_r), K_az * np.hypot(g.sigma_az2, s_az)
        )

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        r_p, az_p, s_r, s_az = self._prediction(g)
        r2, az2 = cartesian_to_polar(z2)
        return sector_gate(
            r2,
            az2,
            r_p[i],
            az_p[i],
            g.sigma_r2[i],
            g.sigma_az2[i],
            s_r[i],
            s_az[i],
            self.K_R,
            self.K_az,
        ).inside


@dataclass(frozen=True)
class FirstAssociationGate:
    """Polar first-association windows about the first mark (seed 002 eq. 3-4)."""

    v_max: float
    K_R: float
    K_az: float

    def region(self, g: MarkGeometry) -> StarRegion:
        _, R_max = ring_radii(g.tau, 0.0, self.v_max)
        K_R = positive_coefficient("K_R", self.K_R)
        K_az = positive_coefficient("K_az", self.K_az)
        W_R = R_max + K_R * np.hypot(g.sigma_r1, g.sigma_r2)
        turn = np.arcsin(np.minimum(1.0, R_max / g.r))
        return _sector(g, g.r, g.az, W_R, turn + K_az * np.hypot(g.sigma_az1, g.sigma_az2))

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        r2, az2 = cartesian_to_polar(z2)
        return first_association_gate(
            g.r[i],
            g.az[i],
            r2,
            az2,
            g.tau,
            self.v_max,
            g.sigma_r1[i],
            g.sigma_az1[i],
            g.sigma_r2[i],
            g.sigma_az2[i],
            self.K_R,
            self.K_az,
        ).inside


Gate = (
    RingGate
    | CombinedGate
    | ExpandedGate
    | EllipseGate
    | RectangularGate
    | SectorGate
    | FirstAssociationGate
)
"""Any gate kind that has a region."""
