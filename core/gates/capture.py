"""Capture gates: is a second mark reachable from a first mark?

Konovalov (gate sizing and shaping for tentative track formation): the ring gate of
Fig. 1 (R_min = v_min tau, R_max = v_max tau, area eq. 5), the expanded ellipse gate of
his ref. [4] (Fig. 3, delta X(Y) = K_g sigma_X(Y)) and the two-stage combined gate of
Fig. 4 (ring, else the chi-square ellipse of eq. 1 with B = P1 + P2 centred on the
nearest circle). Each gate kind is a frozen dataclass of its parameters with its
vectorized ``test``, its ``region`` for gating probabilities and areas, and
``contains``, the test on a gating problem (what the Monte Carlo check samples).
The combined gate's ``test`` is a compiled kernel (:mod:`plotgate.core.gates.kernels`)
beside its numpy ``test_reference``, the oracle the tests hold it to. Symbols and
batching as in :mod:`plotgate.core.gates` and :mod:`plotgate.core.gates.results`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import GeometryError, PlotgateError
from plotgate.core.gates.kernels import as_rows, combined_test
from plotgate.core.gates.parameters import ring_radii, standard_deviation
from plotgate.core.gates.regions import (
    MarkGeometry,
    StarRegion,
    axes_covariance,
    no_kinks,
    radial_form,
    radial_region,
)
from plotgate.core.gates.results import GateResult, GateStage, difference, gate_result
from plotgate.core.gates.thresholds import expansion_coefficient, gate_threshold
from plotgate.core.sym2 import largest_eigenvalue, quadratic_form, sym2
from plotgate.core.validation import (
    as_covariance,
    as_float_array,
    as_points,
    first_index,
    pair_count,
    require_scalar,
)

__all__ = ["CombinedGate", "ExpandedGate", "RingGate"]


@dataclass(frozen=True)
class RingGate:
    """Ring capture gate: the distance travelled must fit the speed bounds.

    .. math:: R_{min} \\le |\\mathbf{z}_2 - \\mathbf{z}_1| \\le R_{max}, \\quad
              R_{min} = v_{min}\\tau, \\; R_{max} = v_{max}\\tau

    Attributes
    ----------
    v_min, v_max : float
        Speed bounds in m/s, 0 <= v_min <= v_max (checked when the gate is used).

    References
    ----------
    .. [1] A. A. Konovalov, gate sizing and shaping for tentative track formation,
       ring gate of Fig. 1: :math:`R_{min} = v_{min}\\tau`,
       :math:`R_{max} = v_{max}\\tau`, area eq. (5).
    """

    v_min: float
    v_max: float

    def test(self, z1: ArrayLike, z2: ArrayLike, tau: float) -> GateResult:
        """Test second marks z2 against first marks z1, taken tau seconds apart.

        Parameters
        ----------
        z1 : (2,) or (N, 2) array_like
            First mark (gate centre), metres.
        z2 : (2,) or (N, 2) array_like
            Second mark, metres.
        tau : float
            Time between the marks in seconds, > 0.

        Returns
        -------
        result : GateResult
            ``statistic`` is the distance |d| in metres and ``threshold`` is R_max.
            The lower bound R_min also applies, so here ``inside`` is
            ``(R_min <= statistic) & (statistic <= threshold)``.

        Raises
        ------
        NonFiniteError
            If an input contains NaN or infinity.
        ParameterError
            If tau <= 0, v_min < 0, v_min > v_max, or the shapes do not fit.

        Examples
        --------
        >>> res = RingGate(v_min=20.0, v_max=500.0).test(
        ...     [0.0, 0.0], [[300.0, 400.0], [30.0, 40.0], [3000.0, 4000.0]], tau=5.0)
        >>> res.inside, res.statistic, res.threshold
        (array([ True, False, False]), array([ 500.,   50., 5000.]), 2500.0)
        """
        v_min, v_max = self.v_min, self.v_max
        z1 = as_points("z1", z1)
        z2 = as_points("z2", z2)
        R_min, R_max = ring_radii(tau, v_min, v_max)
        n = pair_count(z1=z1.shape[:-1], z2=z2.shape[:-1])
        dx, dy = difference(z1, z2)
        dist = np.sqrt(dx * dx + dy * dy)
        inside = (dist >= R_min) & (dist <= R_max)
        return gate_result(n, inside, dist, R_max)

    def region(self, g: MarkGeometry) -> StarRegion:
        """Every direction: [R_min, R_max] about z1."""
        R_min, R_max = ring_radii(g.tau, self.v_min, self.v_max)
        n = g.n
        return radial_region(n, np.zeros(2), no_kinks(n), radial_form(n, (R_min, R_max)))

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        return self.test(g.z1[i], z2, g.tau).inside


@dataclass(frozen=True)
class ExpandedGate:
    """Expanded ellipse gate: the outer circle grown by K_g sigmas along and across the LOS.

    In the frame of the line of sight from the sensor to z1 (X along it, Y across),

    .. math:: \\left(\\frac{d_X}{a}\\right)^2 + \\left(\\frac{d_Y}{b}\\right)^2 \\le 1,
              \\quad a = R_{max} + K_g\\sigma_X, \\; b = R_{max} + K_g\\sigma_Y,

    with :math:`\\sigma_X = \\sigma_r`, :math:`\\sigma_Y = r_1\\sigma_{az}`,
    :math:`r_1 = |\\mathbf{z}_1 - \\mathbf{s}|` and
    :math:`K_g = \\sqrt{-2\\ln(1-p)}`
    (:func:`plotgate.core.gates.thresholds.expansion_coefficient`).

    Attributes
    ----------
    v_max : float
        Largest target speed in m/s, >= 0; R_max = v_max tau.
    p : float
        Probability behind K_g, in (0, 1).

    References
    ----------
    .. [1] A. A. Konovalov, expanded gate after his ref. [4] (Fig. 3):
       :math:`\\delta X(Y) = K_g\\sigma_{X(Y)}` with X along the radar-target
       direction; semi-axes :math:`a = v_{max}\\tau + K_g\\sigma_{1X}`,
       :math:`b = v_{max}\\tau + K_g\\sigma_{1Y}` in the false-mark comparison.
    """

    v_max: float
    p: float

    def test(
        self,
        z1: ArrayLike,
        z2: ArrayLike,
        tau: float,
        sigma_r: ArrayLike,
        sigma_az: ArrayLike,
        sensor: ArrayLike = (0.0, 0.0),
    ) -> GateResult:
        """Test second marks z2 against first marks z1 seen from ``sensor``.

        Parameters
        ----------
        z1 : (2,) or (N, 2) array_like
            First mark (gate centre), metres.
        z2 : (2,) or (N, 2) array_like
            Second mark, metres.
        tau : float
            Time between the marks in seconds, > 0.
        sigma_r : float or (N,) array_like
            Range standard deviation of the first mark, metres, > 0.
        sigma_az : float or (N,) array_like
            Azimuth standard deviation of the first mark, radians, > 0.
        sensor : (2,) or (N, 2) array_like, optional
            Sensor position in metres. Default the origin.

        Returns
        -------
        result : GateResult
            ``statistic`` is :math:`(d_X/a)^2 + (d_Y/b)^2` (dimensionless) and
            ``threshold`` is 1.

        Raises
        ------
        NonFiniteError
            If an input contains NaN or infinity.
        ParameterError
            If tau <= 0, v_max < 0, a sigma <= 0, p is not in (0, 1), or the shapes
            do not fit.
        GeometryError
            If z1 is at the sensor, where the line of sight is undefined (``field="z1"``).

        Examples
        --------
        A first mark 10 km north of the sensor: the gate is longer along the line of
        sight (a = 929 m) than across it (b = 715 m).

        >>> res = ExpandedGate(v_max=100.0, p=0.9).test(
        ...     [0.0, 10_000.0], [[0.0, 10_900.0], [900.0, 10_000.0]], tau=5.0,
        ...     sigma_r=200.0, sigma_az=0.01)
        >>> res.inside, res.statistic.round(3)
        (array([ True, False]), array([0.938, 1.586]))
        """
        v_max, p = self.v_max, self.p
        z1 = as_points("z1", z1)
        z2 = as_points("z2", z2)
        sensor = as_points("sensor", sensor)
        _, R_max = ring_radii(tau, 0.0, v_max)
        sigma_r = standard_deviation("sigma_r", sigma_r)
        sigma_az = standard_deviation("sigma_az", sigma_az)
        require_scalar("p", p)
        K_g = float(expansion_coefficient(p))
        n = pair_count(
            z1=z1.shape[:-1],
            z2=z2.shape[:-1],
            sensor=sensor.shape[:-1],
            sigma_r=sigma_r.shape,
            sigma_az=sigma_az.shape,
        )
        los_x, los_y = difference(sensor, z1)
        r1 = np.sqrt(los_x * los_x + los_y * los_y)
        at_sensor = r1 == 0.0
        if at_sensor.any():
            raise GeometryError(
                "z1", "is at the sensor, so the line of sight is undefined", first_index(at_sensor)
            )
        e_x, e_y = los_x / r1, los_y / r1
        dx, dy = difference(z1, z2)
        d_X = (dx * e_x + dy * e_y) / (R_max + K_g * sigma_r)
        d_Y = (dy * e_x - dx * e_y) / (R_max + K_g * r1 * sigma_az)
        statistic = d_X * d_X + d_Y * d_Y
        return gate_result(n, statistic <= 1.0, statistic, 1.0)

    def semi_axes(self, g: MarkGeometry) -> tuple[np.ndarray, np.ndarray]:
        """a (along the line of sight) and b (across it), m, from the first mark's sigmas."""
        _, R_max = ring_radii(g.tau, 0.0, self.v_max)
        require_scalar("p", self.p)
        K_g = float(expansion_coefficient(self.p))
        return R_max + K_g * g.sigma_r1, R_max + K_g * g.r * g.sigma_az1

    def region(self, g: MarkGeometry) -> StarRegion:
        """Direction u: [0, the ellipse's radius], the ellipse about z1 on its line of sight."""
        a, b = self.semi_axes(g)
        S = axes_covariance(a, b, 0.5 * np.pi - g.az)  # a along the line of sight
        form = radial_form(g.n, (0.0, 0.0), (0.0, 1.0), (S, 1.0))
        return radial_region(g.n, np.zeros(2), no_kinks(g.n), form)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        return self.test(g.z1[i], z2, g.tau, g.sigma_r1[i], g.sigma_az1[i]).inside


@dataclass(frozen=True)
class CombinedGate:
    """Two-stage combined gate: the ring, else an ellipse on its nearest circle.

    A mark in the ring is accepted at once. Otherwise, with
    :math:`\\mathbf{u} = \\mathbf{d}/|\\mathbf{d}|`, the gate centre moves to the
    inner or outer circle along the ray from z1 through z2,

    .. math:: \\mathbf{c} = \\mathbf{z}_1 + R\\,\\mathbf{u}, \\quad
              R = \\begin{cases} R_{min} & |\\mathbf{d}| < R_{min} \\\\
                  R_{max} & |\\mathbf{d}| > R_{max} \\end{cases}, \\quad
              \\boldsymbol{\\nu} = \\mathbf{z}_2 - \\mathbf{c}, \\quad
              \\rho = \\boldsymbol{\\nu}^T \\mathbf{B}^{-1} \\boldsymbol{\\nu} \\le \\gamma,

    with :math:`\\mathbf{B} = \\mathbf{P}_1 + \\mathbf{P}_2` and
    :math:`\\gamma` = ``gate_threshold(P_G, 2)``. Since
    :math:`\\boldsymbol{\\nu} = (|\\mathbf{d}| - R)\\mathbf{u}`, this is computed as
    :math:`\\rho = \\delta^2\\, \\mathbf{d}^T\\mathbf{B}^{-1}\\mathbf{d} / |\\mathbf{d}|^2`
    with :math:`\\delta = \\max(|\\mathbf{d}| - R_{max}, R_{min} - |\\mathbf{d}|, 0)`,
    in closed form for all pairs at once. If d = 0 the direction is undefined and
    the most favourable one is used: :math:`\\rho = R_{min}^2/\\lambda_{max}(\\mathbf{B})`
    (a mark with :math:`|\\mathbf{d}|` below about 1e-154 m counts as d = 0).

    Attributes
    ----------
    v_min, v_max : float
        Speed bounds in m/s, 0 <= v_min <= v_max.
    P_G : float
        Gating probability of the ellipse stage, in (0, 1).

    References
    ----------
    .. [1] A. A. Konovalov, the proposed two-stage gating procedure
       (Fig. 4): ring test, :math:`\\mathbf{c}_{min}`, :math:`\\mathbf{c}_{max}`,
       :math:`\\boldsymbol{\\nu}`, :math:`\\rho = \\boldsymbol{\\nu}^T\\mathbf{B}^{-1}
       \\boldsymbol{\\nu}` against :math:`\\gamma`; B = P1 + P2 before eq. (1).
    """

    v_min: float
    v_max: float
    P_G: float

    def test(
        self, z1: ArrayLike, P1: ArrayLike, z2: ArrayLike, P2: ArrayLike, tau: float
    ) -> GateResult:
        """Test second marks (z2, P2) against first marks (z1, P1), tau seconds apart.

        Parameters
        ----------
        z1 : (2,) or (N, 2) array_like
            First mark, metres.
        P1 : (2, 2) or (N, 2, 2) array_like
            Covariance of z1, m^2, symmetric positive definite.
        z2 : (2,) or (N, 2) array_like
            Second mark, metres.
        P2 : (2, 2) or (N, 2, 2) array_like
            Covariance of z2, m^2, symmetric positive definite.
        tau : float
            Time between the marks in seconds, > 0.

        Returns
        -------
        result : GateResult
            ``statistic`` is rho (0 for marks in the ring), ``threshold`` is gamma,
            and ``stage`` gives the :class:`GateStage` that accepted each mark
            (``NONE`` for rejected marks).

        Raises
        ------
        NonFiniteError
            If an input contains NaN or infinity.
        CovarianceError
            If P1 or P2 is not symmetric positive definite.
        ParameterError
            If tau <= 0, v_min < 0, v_min > v_max, P_G is not in (0, 1), or the
            shapes do not fit.

        Examples
        --------
        B = 2e4 I m^2 and a ring from 100 m to 500 m: a mark in the ring, one 100 m
        beyond it, one 60 m short of it, one 400 m beyond it, and one at z1.

        >>> P = np.diag([1e4, 1e4])
        >>> z2 = [[300.0, 0.0], [0.0, 600.0], [40.0, 0.0], [0.0, 900.0], [0.0, 0.0]]
        >>> res = CombinedGate(v_min=10.0, v_max=50.0, P_G=0.9).test(
        ...     [0.0, 0.0], P, z2, P, tau=10.0)
        >>> res.inside
        array([ True,  True,  True, False,  True])
        >>> res.statistic.round(3), round(res.threshold, 3)
        (array([0.  , 0.5 , 0.18, 8.  , 0.5 ]), 4.605)
        >>> [GateStage(s).name for s in res.stage]
        ['RING', 'OUTER_ELLIPSE', 'INNER_ELLIPSE', 'NONE', 'INNER_ELLIPSE']
        """
        try:
            z1_k = as_float_array("z1", z1, (2,))
            z2_k = as_float_array("z2", z2, (2,))
            P1_k = as_float_array("P1", P1, (2, 2))
            P2_k = as_float_array("P2", P2, (2, 2))
            R_min, R_max = ring_radii(tau, self.v_min, self.v_max)
            require_scalar("P_G", self.P_G)
            gamma = float(gate_threshold(self.P_G))
            n = pair_count(
                z1=z1_k.shape[:-1], P1=P1_k.shape[:-2], z2=z2_k.shape[:-1], P2=P2_k.shape[:-2]
            )
        except PlotgateError:
            return self.test_reference(z1, P1, z2, P2, tau)  # raises the reference's error
        rho, inside, stage = np.empty(n), np.empty(n, dtype=bool), np.empty(n, dtype=np.int8)
        args = (as_rows(z1_k, 2), as_rows(P1_k, 4), as_rows(z2_k, 2), as_rows(P2_k, 4))
        if combined_test(*args, R_min, R_max, gamma, rho, inside, stage) >= 0:
            return self.test_reference(z1, P1, z2, P2, tau)  # raises the reference's error
        return GateResult(inside, rho, gamma, stage)

    def test_reference(
        self, z1: ArrayLike, P1: ArrayLike, z2: ArrayLike, P2: ArrayLike, tau: float
    ) -> GateResult:
        """:meth:`test` in numpy: the reference its compiled kernel is tested against.

        Same parameters, result and errors as :meth:`test`; rho in closed form for all
        pairs at once, one vectorized pass per step.
        """
        v_min, v_max, P_G = self.v_min, self.v_max, self.P_G
        z1 = as_points("z1", z1)
        z2 = as_points("z2", z2)
        P1 = as_covariance("P1", P1)
        P2 = as_covariance("P2", P2)
        R_min, R_max = ring_radii(tau, v_min, v_max)
        require_scalar("P_G", P_G)
        gamma = float(gate_threshold(P_G))
        n = pair_count(z1=z1.shape[:-1], P1=P1.shape[:-2], z2=z2.shape[:-1], P2=P2.shape[:-2])
        B = sym2(P1 + P2)
        dx, dy = difference(z1, z2, n)
        dist2 = dx * dx + dy * dy
        dist = np.sqrt(dist2)
        inner = dist < R_min
        outer = dist > R_max
        # delta = |nu|: how far z2 lies outside the ring, 0 inside it
        delta = np.maximum(dist - R_max, R_min - dist)
        np.maximum(delta, 0.0, out=delta)
        delta *= delta
        at_z1 = dist2 == 0.0
        any_at_z1 = bool(at_z1.any())
        if any_at_z1:
            dist2[at_z1] = 1.0
        rho = quadratic_form(dx, dy, B)
        rho *= delta
        rho /= dist2
        if any_at_z1:
            rho = np.where(at_z1, R_min * R_min / largest_eigenvalue(B), rho)
        inside = rho <= gamma
        # RING + inner + 2 outer is RING, INNER_ELLIPSE or OUTER_ELLIPSE; times inside
        # it becomes NONE for rejected marks
        stage = outer.astype(np.int8)
        stage <<= 1
        stage += inner
        stage += GateStage.RING
        stage *= inside
        return gate_result(n, inside, rho, gamma, stage)

    def region(self, g: MarkGeometry) -> StarRegion:
        """Direction u: [max(0, R_min - h), R_max + h], h = sqrt(gamma / u^T B^-1 u)."""
        R_min, R_max = ring_radii(g.tau, self.v_min, self.v_max)
        require_scalar("P_G", self.P_G)
        gamma = float(gate_threshold(self.P_G))
        n = g.n
        form = radial_form(n, (R_min, R_max), (-1.0, 1.0), (g.B, gamma))

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
        return radial_region(n, np.zeros(2), kinks, form)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        return self.test(g.z1[i], g.P1[i], z2, g.P2[i], g.tau).inside
