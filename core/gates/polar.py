"""Polar gates: range and azimuth windows about a sensor.

Mu, Wang, Zhang and Gao (track initiation in polar coordinates), section 3.1: the
sector gate about a prediction, eq. (1) (range) and eq. (2) (azimuth), and the
first-association windows before any velocity is known, eq. (3) (range, grown by
v_max tau) and eq. (4) (azimuth, grown by the largest bearing change); the polar gate
of the secondary-processing textbook, Fig. 3.6 a. Azimuth differences are wrapped to
(-pi, pi]. Each gate kind is a frozen dataclass of its parameters with its vectorized
``test``, its ``region`` and ``contains`` on a gating problem (as in
:mod:`plotgate.core.gates.capture`). Both gates' ``test`` is a compiled kernel
(:mod:`plotgate.core.gates.kernels`) beside its numpy ``test_reference``. Symbols and
batching as in :mod:`plotgate.core.gates` and :mod:`plotgate.core.gates.results`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from plotgate.core.errors import PlotgateError
from plotgate.core.frames import cartesian_to_polar, wrap_angle
from plotgate.core.gates.kernels import as_rows, first_association_test, sector_test
from plotgate.core.gates.parameters import positive_coefficient, ring_radii, standard_deviation
from plotgate.core.gates.regions import MarkGeometry, StarRegion, sector_region
from plotgate.core.gates.results import GateResult, gate_result, window_statistic
from plotgate.core.validation import (
    as_array,
    as_float_array,
    as_points,
    pair_count,
    require_nonnegative,
    to_pairs,
)

__all__ = ["FirstAssociationGate", "SectorGate", "bearing_turn"]


def bearing_turn(R_max: ArrayLike, r: ArrayLike) -> np.ndarray:
    """Largest bearing change, rad, of a target at range r (m) that moves at most R_max m.

    .. math:: \\arcsin\\left(\\min\\left(1, \\frac{R_{max}}{r}\\right)\\right)

    pi/2 within R_max of the sensor (r = 0 included). The tangential term of the
    azimuth window of Mu et al., eq. (4), with R_max = v_max tau: the first-association
    windows here, and initiation's track windows about an extrapolated range.

    >>> bearing_turn([100.0, 100.0], [200.0, 50.0]).round(4)
    array([0.5236, 1.5708])
    """
    R_max, r = np.asarray(R_max, dtype=float), np.asarray(r, dtype=float)
    far = r > R_max
    ratio = np.divide(R_max, r, out=np.ones(np.broadcast(R_max, r).shape), where=far)
    turn: np.ndarray = np.arcsin(ratio)
    return turn


@dataclass(frozen=True)
class SectorGate:
    """Polar sector gate around a predicted range and azimuth.

    .. math:: |r - \\hat r| \\le K_R\\sqrt{\\sigma_r^2 + \\hat\\sigma_r^2}, \\quad
              |\\mathrm{wrap}(az - \\widehat{az})| \\le
              K_{az}\\sqrt{\\sigma_{az}^2 + \\hat\\sigma_{az}^2}

    Attributes
    ----------
    K_R, K_az : float
        Window coefficients, > 0.
    offset : (2,) tuple of float
        In a gating problem (``region``, ``contains``): the predicted displacement
        z_pred - z1, m. Default none.
    sigma_r_pred, sigma_az_pred : float or None
        In a gating problem: the prediction's range (m) and azimuth (rad) sigmas;
        default the first mark's. The second mark's are the problem's.

    References
    ----------
    .. [1] C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar
       coordinates, section 3.1, eq. (1) (range) and eq. (2) (azimuth).
    .. [2] The secondary-processing textbook, the polar gate of Fig. 3.6 a.
    """

    K_R: float
    K_az: float
    offset: tuple[float, float] = (0.0, 0.0)
    sigma_r_pred: float | None = None
    sigma_az_pred: float | None = None

    def test(
        self,
        r: ArrayLike,
        az: ArrayLike,
        r_pred: ArrayLike,
        az_pred: ArrayLike,
        sigma_r: ArrayLike,
        sigma_az: ArrayLike,
        sigma_r_pred: ArrayLike,
        sigma_az_pred: ArrayLike,
    ) -> GateResult:
        """Test measured ranges and azimuths against predicted ones.

        Parameters
        ----------
        r : float or (N,) array_like
            Measured range, metres, >= 0.
        az : float or (N,) array_like
            Measured azimuth, radians.
        r_pred : float or (N,) array_like
            Predicted range, metres.
        az_pred : float or (N,) array_like
            Predicted azimuth, radians.
        sigma_r, sigma_az : float or (N,) array_like
            Measurement standard deviations of range (m) and azimuth (rad), > 0.
        sigma_r_pred, sigma_az_pred : float or (N,) array_like
            Prediction standard deviations of range (m) and azimuth (rad), > 0.

        Returns
        -------
        result : GateResult
            ``statistic`` is the larger of the two offsets as a fraction of its
            window, :math:`\\max(|\\Delta r|/W_R, |\\Delta az|/W_{az})`, and
            ``threshold`` is 1.

        Raises
        ------
        NonFiniteError
            If an input contains NaN or infinity.
        ParameterError
            If r < 0, a sigma or coefficient is <= 0, or the shapes do not fit.

        Examples
        --------
        Windows of 15 m and 0.015 rad; the second mark is 20 m off in range. The third
        sits across the +-pi seam from its prediction, 0.0032 rad away.

        >>> res = SectorGate(K_R=3.0, K_az=3.0).test(
        ...     [10_010.0, 10_020.0, 5_000.0], [0.11, 0.1, -3.14],
        ...     [10_000.0, 10_000.0, 5_000.0], [0.1, 0.1, 3.14], 3.0, 0.003, 4.0, 0.004)
        >>> res.inside, res.statistic.round(3)
        (array([ True, False,  True]), array([0.667, 1.333, 0.212]))
        """
        inputs = {
            "r": r,
            "az": az,
            "r_pred": r_pred,
            "az_pred": az_pred,
            "sigma_r": sigma_r,
            "sigma_az": sigma_az,
            "sigma_r_pred": sigma_r_pred,
            "sigma_az_pred": sigma_az_pred,
        }
        try:
            arrays = {name: as_float_array(name, value) for name, value in inputs.items()}
            K_R = positive_coefficient("K_R", self.K_R)
            K_az = positive_coefficient("K_az", self.K_az)
            n = pair_count(**{name: x.shape for name, x in arrays.items()})
        except PlotgateError:
            return self.test_reference(**inputs)  # raises the reference's error
        statistic, inside = np.empty(n), np.empty(n, dtype=bool)
        a = {name: as_rows(x) for name, x in arrays.items()}
        marks = (a["r"], a["az"], a["r_pred"], a["az_pred"])
        sigmas = (a["sigma_r"], a["sigma_az"], a["sigma_r_pred"], a["sigma_az_pred"])
        if sector_test(*marks, *sigmas, K_R, K_az, statistic, inside) >= 0:
            return self.test_reference(**inputs)  # raises the reference's error
        return GateResult(inside, statistic, 1.0)

    def test_reference(
        self,
        r: ArrayLike,
        az: ArrayLike,
        r_pred: ArrayLike,
        az_pred: ArrayLike,
        sigma_r: ArrayLike,
        sigma_az: ArrayLike,
        sigma_r_pred: ArrayLike,
        sigma_az_pred: ArrayLike,
    ) -> GateResult:
        """:meth:`test` in numpy: the reference its compiled kernel is tested against.

        Same parameters, result and errors as :meth:`test`, one vectorized pass per step.
        """
        K_R, K_az = self.K_R, self.K_az
        r = as_array("r", r)
        az = as_array("az", az)
        r_pred = as_array("r_pred", r_pred)
        az_pred = as_array("az_pred", az_pred)
        require_nonnegative("r", r)
        sigma_r = standard_deviation("sigma_r", sigma_r)
        sigma_az = standard_deviation("sigma_az", sigma_az)
        sigma_r_pred = standard_deviation("sigma_r_pred", sigma_r_pred)
        sigma_az_pred = standard_deviation("sigma_az_pred", sigma_az_pred)
        K_R = positive_coefficient("K_R", K_R)
        K_az = positive_coefficient("K_az", K_az)
        n = pair_count(
            r=r.shape,
            az=az.shape,
            r_pred=r_pred.shape,
            az_pred=az_pred.shape,
            sigma_r=sigma_r.shape,
            sigma_az=sigma_az.shape,
            sigma_r_pred=sigma_r_pred.shape,
            sigma_az_pred=sigma_az_pred.shape,
        )
        W_R = K_R * np.hypot(sigma_r, sigma_r_pred)
        W_az = K_az * np.hypot(sigma_az, sigma_az_pred)
        statistic = window_statistic(r - r_pred, wrap_angle(az - az_pred), W_R, W_az)
        return gate_result(n, statistic <= 1.0, statistic, 1.0)

    def _prediction(self, g: MarkGeometry) -> tuple[np.ndarray, ...]:
        """Range, azimuth and their sigmas of each problem's prediction z1 + offset."""
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
        """The sector of the windows about the prediction, seen from the radar."""
        K_R = positive_coefficient("K_R", self.K_R)
        K_az = positive_coefficient("K_az", self.K_az)
        r_p, az_p, s_r, s_az = self._prediction(g)
        return sector_region(
            g, r_p, az_p, K_R * np.hypot(g.sigma_r2, s_r), K_az * np.hypot(g.sigma_az2, s_az)
        )

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        r_p, az_p, s_r, s_az = self._prediction(g)
        r2, az2 = cartesian_to_polar(z2)
        return self.test(
            r2, az2, r_p[i], az_p[i], g.sigma_r2[i], g.sigma_az2[i], s_r[i], s_az[i]
        ).inside


@dataclass(frozen=True)
class FirstAssociationGate:
    """Polar windows for the first association, before any velocity is known.

    .. math:: |r_2 - r_1| \\le W_R = v_{max}\\tau + K_R\\sqrt{\\sigma_{r1}^2 + \\sigma_{r2}^2}

    .. math:: |\\mathrm{wrap}(az_2 - az_1)| \\le W_{az} =
              \\arcsin\\left(\\min\\left(1, \\frac{v_{max}\\tau}{r_1}\\right)\\right)
              + K_{az}\\sqrt{\\sigma_{az1}^2 + \\sigma_{az2}^2}

    The arcsine term is the largest bearing change a target at range r1 can make
    in tau; within v_max tau of the sensor it is pi/2.

    Attributes
    ----------
    v_max : float
        Largest target speed in m/s, >= 0.
    K_R, K_az : float
        Window coefficients, > 0.

    References
    ----------
    .. [1] C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar
       coordinates, section 3.1, eq. (3) (first range window) and eq. (4) (azimuth
       window with the tangential speed bound).
    """

    v_max: float
    K_R: float
    K_az: float

    def test(
        self,
        r1: ArrayLike,
        az1: ArrayLike,
        r2: ArrayLike,
        az2: ArrayLike,
        tau: float,
        sigma_r1: ArrayLike,
        sigma_az1: ArrayLike,
        sigma_r2: ArrayLike,
        sigma_az2: ArrayLike,
    ) -> GateResult:
        """Test second marks (r2, az2) against first marks (r1, az1), tau seconds apart.

        Parameters
        ----------
        r1, az1 : float or (N,) array_like
            Range (m, >= 0) and azimuth (rad) of the first mark.
        r2, az2 : float or (N,) array_like
            Range (m, >= 0) and azimuth (rad) of the second mark.
        tau : float
            Time between the marks in seconds, > 0.
        sigma_r1, sigma_az1, sigma_r2, sigma_az2 : float or (N,) array_like
            Range (m) and azimuth (rad) standard deviations of the two marks, > 0.

        Returns
        -------
        result : GateResult
            ``statistic`` is :math:`\\max(|r_2 - r_1|/W_R, |\\Delta az|/W_{az})` and
            ``threshold`` is 1.

        Raises
        ------
        NonFiniteError
            If an input contains NaN or infinity.
        ParameterError
            If a range is negative, tau <= 0, v_max < 0, a sigma or coefficient is
            <= 0, or the shapes do not fit.

        Examples
        --------
        A ground target at 10 km, v_max = 25 m/s, tau = 1 s: W_R = 46.2 m and
        W_az = 0.0038 rad, so a mark 40 m further is inside and 0.005 rad off is not.

        >>> res = FirstAssociationGate(v_max=25.0, K_R=3.0, K_az=3.0).test(
        ...     10_000.0, 0.5, [10_040.0, 10_000.0], [0.5, 0.505], tau=1.0,
        ...     sigma_r1=5.0, sigma_az1=3e-4, sigma_r2=5.0, sigma_az2=3e-4)
        >>> res.inside, res.statistic.round(3)
        (array([ True, False]), array([0.866, 1.325]))
        """
        marks = {"r1": r1, "az1": az1, "r2": r2, "az2": az2}
        sigmas = {
            "sigma_r1": sigma_r1,
            "sigma_az1": sigma_az1,
            "sigma_r2": sigma_r2,
            "sigma_az2": sigma_az2,
        }
        try:
            m = {name: as_float_array(name, value) for name, value in marks.items()}
            _, R_max = ring_radii(tau, 0.0, self.v_max)
            s = {name: as_float_array(name, value) for name, value in sigmas.items()}
            K_R = positive_coefficient("K_R", self.K_R)
            K_az = positive_coefficient("K_az", self.K_az)
            n = pair_count(**{name: x.shape for name, x in (m | s).items()})
        except PlotgateError:
            return self.test_reference(tau=tau, **marks, **sigmas)  # raises its error
        statistic, inside = np.empty(n), np.empty(n, dtype=bool)
        a = {name: as_rows(x) for name, x in (m | s).items()}
        first = (a["r1"], a["az1"], a["r2"], a["az2"])
        sigma = (a["sigma_r1"], a["sigma_az1"], a["sigma_r2"], a["sigma_az2"])
        if first_association_test(*first, R_max, *sigma, K_R, K_az, statistic, inside) >= 0:
            return self.test_reference(tau=tau, **marks, **sigmas)  # raises its error
        return GateResult(inside, statistic, 1.0)

    def test_reference(
        self,
        r1: ArrayLike,
        az1: ArrayLike,
        r2: ArrayLike,
        az2: ArrayLike,
        tau: float,
        sigma_r1: ArrayLike,
        sigma_az1: ArrayLike,
        sigma_r2: ArrayLike,
        sigma_az2: ArrayLike,
    ) -> GateResult:
        """:meth:`test` in numpy: the reference its compiled kernel is tested against.

        Same parameters, result and errors as :meth:`test`, one vectorized pass per step.
        """
        v_max, K_R, K_az = self.v_max, self.K_R, self.K_az
        r1 = as_array("r1", r1)
        az1 = as_array("az1", az1)
        r2 = as_array("r2", r2)
        az2 = as_array("az2", az2)
        require_nonnegative("r1", r1)
        require_nonnegative("r2", r2)
        _, R_max = ring_radii(tau, 0.0, v_max)
        sigma_r1 = standard_deviation("sigma_r1", sigma_r1)
        sigma_az1 = standard_deviation("sigma_az1", sigma_az1)
        sigma_r2 = standard_deviation("sigma_r2", sigma_r2)
        sigma_az2 = standard_deviation("sigma_az2", sigma_az2)
        K_R = positive_coefficient("K_R", K_R)
        K_az = positive_coefficient("K_az", K_az)
        n = pair_count(
            r1=r1.shape,
            az1=az1.shape,
            r2=r2.shape,
            az2=az2.shape,
            sigma_r1=sigma_r1.shape,
            sigma_az1=sigma_az1.shape,
            sigma_r2=sigma_r2.shape,
            sigma_az2=sigma_az2.shape,
        )
        W_R = R_max + K_R * np.hypot(sigma_r1, sigma_r2)
        W_az = bearing_turn(R_max, r1) + K_az * np.hypot(sigma_az1, sigma_az2)
        statistic = window_statistic(r2 - r1, wrap_angle(az2 - az1), W_R, W_az)
        return gate_result(n, statistic <= 1.0, statistic, 1.0)

    def region(self, g: MarkGeometry) -> StarRegion:
        """The sector of the windows about the first mark, seen from the radar."""
        _, R_max = ring_radii(g.tau, 0.0, self.v_max)
        K_R = positive_coefficient("K_R", self.K_R)
        K_az = positive_coefficient("K_az", self.K_az)
        W_R = R_max + K_R * np.hypot(g.sigma_r1, g.sigma_r2)
        W_az = bearing_turn(R_max, g.r) + K_az * np.hypot(g.sigma_az1, g.sigma_az2)
        return sector_region(g, g.r, g.az, W_R, W_az)

    def contains(self, g: MarkGeometry, i: int, z2: np.ndarray) -> np.ndarray:
        """The test of second marks z2 (M, 2) in problem i of g: (M,) bool."""
        r2, az2 = cartesian_to_polar(z2)
        return self.test(
            g.r[i],
            g.az[i],
            r2,
            az2,
            g.tau,
            g.sigma_r1[i],
            g.sigma_az1[i],
            g.sigma_r2[i],
            g.sigma_az2[i],
        ).inside
