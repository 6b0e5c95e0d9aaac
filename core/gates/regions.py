"""Gating problems, and gates as plane regions, for gating probabilities and areas.

A gating-probability problem (Konovalov) places the first mark z1 at range r and
azimuth az from the radar, gives both marks' range and azimuth errors, and asks how
likely the second mark, taken tau seconds later, falls in a gate built about z1.
:class:`MarkGeometry` holds that set-up for N problems at once (a curve against
range is N geometries). Each gate kind (:mod:`plotgate.core.gates.capture`,
:mod:`plotgate.core.gates.tracking`, :mod:`plotgate.core.gates.polar`) gives its
``region(geometry)``: the gate as a :class:`StarRegion`, the form the quadrature of
:mod:`plotgate.core.gates.probability` integrates over. This module holds the problem,
the region type and the pieces the gate kinds build their regions from.

Every gate is, seen from some origin o, a radial interval per direction: rays from o
in direction u(theta) = (cos theta, sin theta) (theta counter-clockwise from east)
meet the gate in [lo(theta), hi(theta)]. Ring, combined and expanded gates are
star-shaped about z1 (each ray from z1 meets them in one interval); ellipse and
rectangular gates about their centre; a polar sector is an interval of range over an
interval of azimuth about the radar. Positions in a region are relative to z1.

Decision (the paper is silent): B = P1 + P2 with both covariances evaluated at the
first mark's position. The marks are at most v_max tau apart, small against the
range, so this is the paper's "B from both measurements"; it keeps the second mark's
distribution exactly Gaussian, which the probabilities of Konovalov, eq. 1-2, assume.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.compiled import kernel
from plotgate.core.errors import GeometryError
from plotgate.core.frames import (
    polar_covariance_to_cartesian,
    polar_to_cartesian,
)
from plotgate.core.gates.parameters import standard_deviation
from plotgate.core.sym2 import Sym2, sym2
from plotgate.core.validation import (
    as_array,
    as_covariance,
    as_scalar,
    first_index,
    is_valid_covariance,
    pair_count,
    require_positive,
    to_pairs,
)

__all__ = [
    "ALL_ROWS",
    "RADIAL_FORM",
    "MarkGeometry",
    "RadialForm",
    "Rows",
    "StarRegion",
    "column_sym2",
    "full_turn",
    "inverse_form",
    "mark_geometry",
    "no_kinks",
    "axes_covariance",
    "radial_form",
    "radial_radii",
    "radial_radii_along",
    "radial_radii_reference",
    "radial_region",
    "rows_of",
    "sector_region",
]

TWO_PI = 2.0 * np.pi
Rows = slice | np.ndarray
"""Problems a radii call is for: all (``slice(None)``) or an index array, one per row."""
ALL_ROWS = slice(None)
"""All problems, the default ``rows`` of a radii call."""


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
        P1 + P2, the covariance of the second mark about its mean (Konovalov, eq. 1).
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
        The second mark's; default equal to the first's (Konovalov's example).

    Examples
    --------
    The paper's example at 50 km: B has 2 sigma_r^2 = 8e4 m^2 along the line of
    sight and 2 (r sigma_az)^2 = 3.8e5 m^2 across it.

    >>> g = mark_geometry(50e3, 0.0, 200.0, np.radians(0.5), tau=5.0)
    >>> g.n, np.round(g.B.xx), np.round(g.B.yy)
    (1, array([380772.]), array([80000.]))
    """
    scalars = (r, az, sigma_r, sigma_az, sigma_r2, sigma_az2)
    if all(type(x) is float or x is None for x in scalars) and type(tau) is float:
        one = _one_geometry(*scalars, tau)  # type: ignore[arg-type]
        if one is not None:
            return one
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


def _one_geometry(
    r: float,
    az: float,
    sigma_r: float,
    sigma_az: float,
    sigma_r2: float | None,
    sigma_az2: float | None,
    tau: float,
) -> MarkGeometry | None:
    """:func:`mark_geometry` of one problem given as Python floats (a request's mark),
    without its array checks; None when a value would fail one (the full path then
    raises its error). sin and cos are numpy's on the same (1,) array, the rest the
    arithmetic of :func:`plotgate.core.frames.polar_covariance_to_cartesian` and
    :func:`plotgate.core.frames.polar_to_cartesian` in the same order on Python floats
    (IEEE doubles, as numpy's), so the geometry is the same to the bit."""
    s_r2 = sigma_r if sigma_r2 is None else sigma_r2
    s_az2 = sigma_az if sigma_az2 is None else sigma_az2
    finite = math.isfinite(r + az + sigma_r + sigma_az + s_r2 + s_az2 + tau)
    if not (finite and r > 0.0 and min(sigma_r, sigma_az, s_r2, s_az2, tau) > 0.0):
        return None
    values = np.array([r, az, sigma_r, sigma_az, s_r2, s_az2])
    az_ = values[1:2]
    s, c = float(np.sin(az_)[0]), float(np.cos(az_)[0])
    P = np.empty((3, 2, 2))  # P1, P2, B
    for row, (s_r, s_az) in enumerate(((sigma_r, sigma_az), (s_r2, s_az2))):
        var_r = s_r * s_r
        cross = r * s_az
        var_t = cross * cross  # cross-range variance
        P[row, 0, 0] = s * s * var_r + c * c * var_t
        P[row, 1, 1] = c * c * var_r + s * s * var_t
        P[row, 0, 1] = P[row, 1, 0] = s * c * (var_r - var_t)
    P[2] = P[0] + P[1]
    if not is_valid_covariance(P[2, 0, 0], P[2, 0, 1], P[2, 1, 0], P[2, 1, 1]):
        return None
    z1 = np.array([[r * s, r * c]])
    sigmas = (values[2:3], values[3:4], values[4:5], values[5:6])
    return MarkGeometry(values[0:1], az_, *sigmas, tau, z1, P[0:1], P[1:2], sym2(P[2:3]))


class RadialForm(NamedTuple):
    """Radii of the form every gate but the rectangle has, for N problems ((N,) each):

    lo = max(a_lo + k_lo h, 0), hi = a_hi + k_hi h, h = 1 / sqrt(u^T W u),

    W the adjugate of the covariance S of the gate's ellipse d^T S^-1 d <= gamma, whose
    radius in direction u is sqrt(gamma |S|) h; that factor is folded into k, so W holds
    S's own components and h rounds as the gate test's u^T S^-1 u does (at an axis ratio
    of 279 a scaled S^-1 moved the ellipse's area by 1.6e-12). The ring has k = 0, the
    combined gate k_lo = -k_hi, an ellipse a = 0, a polar sector k = 0 (about the radar).
    Stated once so that the compiled conditional probability evaluates the radii itself
    (:func:`radial_radii`) instead of calling back into numpy.
    """

    a_lo: np.ndarray
    k_lo: np.ndarray
    a_hi: np.ndarray
    k_hi: np.ndarray
    wxx: np.ndarray
    wxy: np.ndarray
    wyy: np.ndarray


RADIAL_FORM = "UniTuple(Array(float64, 1, 'C', readonly=True), 7)"
"""numba type of a :class:`RadialForm`."""


def radial_form(
    n: int,
    a: tuple[float | np.ndarray, float | np.ndarray],
    k: tuple[float, float] = (0.0, 0.0),
    ellipse: tuple[Sym2, float] | None = None,
) -> RadialForm:
    """The :class:`RadialForm` of n problems: a = (a_lo, a_hi), k = (k_lo, k_hi) in units
    of the radius of ``ellipse`` = (S, gamma), the ellipse d^T S^-1 d <= gamma (none: the
    identity, unused when k = 0)."""
    if ellipse is None:  # the identity: W = I, scale 1
        parts: tuple[float | np.ndarray, ...] = (a[0], k[0], a[1], k[1], 1.0, -0.0, 1.0)
    else:
        S, gamma = ellipse
        scale = np.sqrt(gamma * S.det)
        parts = (a[0], k[0] * scale, a[1], k[1] * scale, S.yy, -S.xy, S.xx)
    block = np.empty((7, n))  # one allocation: a request builds its record anew
    for row, x in zip(block, parts, strict=True):
        row[:] = x
    return RadialForm(*block)


def axes_covariance(a: np.ndarray, b: np.ndarray, axis: np.ndarray) -> Sym2:
    """S of the ellipse d^T S^-1 d <= 1 of semi-axes a (along the math angle ``axis``) and b."""
    c, s = np.cos(axis), np.sin(axis)
    aa, bb = a * a, b * b
    return Sym2(aa * c * c + bb * s * s, (aa - bb) * c * s, aa * s * s + bb * c * c, aa * bb)


def radial_radii_reference(
    form: RadialForm, theta: np.ndarray, rows: Rows = ALL_ROWS
) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of :class:`RadialForm` at directions theta, (N, T) or (P, T) with
    ``rows`` (P,), with numpy: the reference of :func:`radial_radii`."""
    a_lo, k_lo, a_hi, k_hi, wxx, wxy, wyy = (x[rows][:, None] for x in form)
    c, s = np.cos(theta), np.sin(theta)
    h = 1.0 / np.sqrt(wxx * c * c + 2.0 * wxy * c * s + wyy * s * s)
    return np.maximum(a_lo + k_lo * h, 0.0), a_hi + k_hi * h


@kernel(f"UniTuple(float64, 2)({RADIAL_FORM}, int64, float64, float64)")
def radial_radii_along(
    form: tuple[np.ndarray, ...], i: int, c: float, s: float
) -> tuple[float, float]:
    """:func:`radial_radii` along u = (c, s) = (cos theta, sin theta), for a caller that
    has the direction's cosine and sine already (the conditional probability's rays)."""
    h = 1.0 / math.sqrt(form[4][i] * c * c + 2.0 * form[5][i] * c * s + form[6][i] * s * s)
    return max(form[0][i] + form[1][i] * h, 0.0), form[2][i] + form[3][i] * h


@kernel(f"UniTuple(float64, 2)({RADIAL_FORM}, int64, float64)")
def radial_radii(form: tuple[np.ndarray, ...], i: int, theta: float) -> tuple[float, float]:
    """:func:`radial_radii_reference` of problem i at one direction, compiled: (lo, hi)."""
    return radial_radii_along(form, i, math.cos(theta), math.sin(theta))


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
    symmetric : bool
        The region is symmetric about its origin: radii(theta + pi) = radii(theta).
    form : RadialForm or None
        The radii as a :class:`RadialForm` (``radii`` is then its numpy reference), or
        None for a region whose radii have no such form (the rectangle).
    """

    origin: np.ndarray
    start: np.ndarray
    span: np.ndarray
    kinks: np.ndarray
    radii: Callable[..., tuple[np.ndarray, np.ndarray]]
    symmetric: bool = False
    form: RadialForm | None = None


def full_turn(
    n: int,
    origin: np.ndarray,
    kinks: np.ndarray,
    radii: Callable[..., tuple[np.ndarray, np.ndarray]],
) -> StarRegion:
    """A region seen over every direction from ``origin`` (relative to z1), for n problems.

    Every gate seen over a full turn is a ring, an ellipse, the union of the two, or a
    rectangle, each centred on its origin, so the region is ``symmetric`` (the tests check
    radii(theta + pi) = radii(theta) for every such gate kind).
    """
    origins = np.empty((n, 2))
    origins[:] = origin
    return StarRegion(origins, np.zeros(n), np.full(n, TWO_PI), kinks, radii, True)


def radial_region(n: int, origin: np.ndarray, kinks: np.ndarray, form: RadialForm) -> StarRegion:
    """:func:`full_turn` with the radii of ``form``."""
    region = full_turn(n, origin, kinks, functools.partial(radial_radii_reference, form))
    return region._replace(form=form)


def no_kinks(n: int) -> np.ndarray:
    """The ``kinks`` of a region whose boundary is smooth in every direction."""
    return np.full((n, 1), np.nan)


def inverse_form(S: Sym2, theta: np.ndarray) -> np.ndarray:
    """u^T S^-1 u for u = (cos theta, sin theta); S components are (N, 1) or scalars."""
    c, s = np.cos(theta), np.sin(theta)
    form: np.ndarray = (S.yy * c * c - 2.0 * S.xy * c * s + S.xx * s * s) / S.det
    return form


def column_sym2(S: Sym2) -> Sym2:
    """(N,) components as (N, 1) columns, to broadcast against (N, T) directions."""
    return Sym2(*(np.asarray(x)[:, None] for x in S))


def rows_of(S: Sym2, rows: Rows) -> Sym2:
    """The components of the problems in ``rows``."""
    return Sym2(*(x[rows] for x in S))


def sector_region(
    g: MarkGeometry, r_c: np.ndarray, az_c: np.ndarray, W_R: np.ndarray, W_az: np.ndarray
) -> StarRegion:
    """Ranges r_c +- W_R over azimuths az_c +- W_az about the radar, relative to z1.

    The region of the polar gates (Mu et al., eq. 1-4): centre range r_c and azimuth
    az_c, windows W_R (m) and W_az (rad), each (N,).
    """
    form = radial_form(g.n, (np.maximum(r_c - W_R, 0.0), r_c + W_R))
    W_az = np.minimum(W_az, np.pi)
    radii = functools.partial(radial_radii_reference, form)
    # azimuth az (clockwise from north) is the math angle pi/2 - az
    start = 0.5 * np.pi - az_c - W_az
    return StarRegion(-g.z1, start, 2.0 * W_az, no_kinks(g.n), radii, False, form)
