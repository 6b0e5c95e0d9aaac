"""Compiled per-pair gate tests: the input checks and the statistic fused in one pass.

Each kernel is its gate's ``test`` (``ellipse_test`` is what ``EllipseGate.test`` runs,
and so on) and tests N pairs the way the gate's numpy ``test_reference`` does, with the
same arithmetic in the same order (so the statistic agrees to rounding), and checks the
inputs the reference checks (finite values, signs, covariances as
:func:`plotgate.core.validation.is_valid_covariance`) in the same pass. A kernel returns the
first pair whose inputs fail a check, or -1: the gate then runs its reference, whose
error names the field and the row as it always has.

Inputs are checked float64 C-contiguous arrays whose leading axis is N or 1 (one value
shared by every pair): marks (M, 2), covariances (M, 4) as [P11, P12, P21, P22], per-pair
scalars (M,). The results are written into (N,) arrays the caller allocates.

The kernels run on one thread: on the 2-core machine they were measured on, splitting the
pairs over both cores (``numba.prange``) gained nothing, and tripled the compile time.

References
----------
.. [1] A. A. Konovalov, gate sizing and shaping for tentative track formation: the
   ellipse test rho = nu^T B^-1 nu against gamma and the two-stage combined gate (Fig. 4).
.. [2] C. Mu, W. Wang, M. Zhang, Y. Gao, track initiation in polar coordinates,
   section 3.1, eqs. (1)-(4): the sector gate and the first-association windows.
"""

from __future__ import annotations

import math

import numpy as np

from plotgate.core.compiled import kernel
from plotgate.core.validation import is_valid_covariance

__all__ = [
    "ROWS",
    "VALUES",
    "as_rows",
    "combined_test",
    "ellipse_test",
    "first_association_test",
    "sector_test",
    "stride",
    "wrapped",
]

TWO_PI = 2.0 * math.pi

ROWS = "Array(float64, 2, 'C', readonly=True)"
"""numba type of an input of rows (marks, covariances): read-only accepted, never written."""
VALUES = "Array(float64, 1, 'C', readonly=True)"
"""numba type of an input of per-pair scalars."""


def as_rows(x: np.ndarray, width: int = 0) -> np.ndarray:
    """A checked float input as a kernel reads it: C-contiguous (M, width), or (M,) if 0.

    An unbatched input becomes one row (M = 1), shared by every pair.
    """
    return np.ascontiguousarray(x.reshape((-1, width) if width else -1))


@kernel("float64(float64)")
def wrapped(a: float) -> float:
    """An angle known to be finite wrapped to (-pi, pi], as ``frames.wrap_finite``."""
    w = math.pi - (math.pi - a) % TWO_PI
    if w <= -math.pi:
        w += TWO_PI
    return w


@kernel("int64(int64, int64)")
def stride(m: int, n: int) -> int:
    """Row step of an input with M rows among N pairs: 1 when batched, 0 when shared."""
    return 1 if m == n and m > 1 else 0


@kernel(f"int64({ROWS}, {ROWS}, {ROWS}, float64, float64[::1], boolean[::1])")
def ellipse_test(
    z: np.ndarray,
    z_pred: np.ndarray,
    S: np.ndarray,
    gamma: float,
    rho: np.ndarray,
    inside: np.ndarray,
) -> int:
    """rho = nu^T S^-1 nu (LDL^T form) and rho <= gamma of nu = z - z_pred; first bad pair."""
    n = rho.shape[0]
    s_z, s_p, s_S = stride(z.shape[0], n), stride(z_pred.shape[0], n), stride(S.shape[0], n)
    bad = n
    for i in range(n):
        j = i * s_z
        k = i * s_p
        m = i * s_S
        Sxx, Sxy, Syx, Syy = S[m, 0], S[m, 1], S[m, 2], S[m, 3]
        nu_x = z[j, 0] - z_pred[k, 0]
        nu_y = z[j, 1] - z_pred[k, 1]
        if not (math.isfinite(nu_x) and math.isfinite(nu_y)) or not is_valid_covariance(
            Sxx, Sxy, Syx, Syy
        ):
            bad = min(bad, i)
        det = Sxx * Syy - Sxy * Sxy
        t = Sxx * nu_y - Sxy * nu_x
        r = nu_x * nu_x / Sxx + t * t / (Sxx * det)
        rho[i] = r
        inside[i] = r <= gamma
    return -1 if bad == n else bad


@kernel(
    f"int64({ROWS}, {ROWS}, {ROWS}, {ROWS}, float64, float64, float64,"
    " float64[::1], boolean[::1], int8[::1])"
)
def combined_test(
    z1: np.ndarray,
    P1: np.ndarray,
    z2: np.ndarray,
    P2: np.ndarray,
    R_min: float,
    R_max: float,
    gamma: float,
    rho: np.ndarray,
    inside: np.ndarray,
    stage: np.ndarray,
) -> int:
    """The combined gate's rho, decision and stage (RING 1, INNER 2, OUTER 3, NONE 0)."""
    n = rho.shape[0]
    s_z1, s_P1 = stride(z1.shape[0], n), stride(P1.shape[0], n)
    s_z2, s_P2 = stride(z2.shape[0], n), stride(P2.shape[0], n)
    bad = n
    for i in range(n):
        j1, k1, j2, k2 = i * s_z1, i * s_P1, i * s_z2, i * s_P2
        dx = z2[j2, 0] - z1[j1, 0]
        dy = z2[j2, 1] - z1[j1, 1]
        if (
            not (math.isfinite(dx) and math.isfinite(dy))
            or not is_valid_covariance(P1[k1, 0], P1[k1, 1], P1[k1, 2], P1[k1, 3])
            or not is_valid_covariance(P2[k2, 0], P2[k2, 1], P2[k2, 2], P2[k2, 3])
        ):
            bad = min(bad, i)
        Bxx = P1[k1, 0] + P2[k2, 0]
        Bxy = P1[k1, 1] + P2[k2, 1]
        Byy = P1[k1, 3] + P2[k2, 3]
        dist2 = dx * dx + dy * dy
        dist = math.sqrt(dist2)
        delta = max(max(dist - R_max, R_min - dist), 0.0)
        delta *= delta
        if dist2 == 0.0:
            half_diff = 0.5 * (Bxx - Byy)
            lambda_max = 0.5 * (Bxx + Byy) + math.sqrt(half_diff * half_diff + Bxy * Bxy)
            r = R_min * R_min / lambda_max
        else:
            det = Bxx * Byy - Bxy * Bxy
            t = Bxx * dy - Bxy * dx
            r = (dx * dx / Bxx + t * t / (Bxx * det)) * delta / dist2
        accepted = r <= gamma
        rho[i] = r
        inside[i] = accepted
        if not accepted:
            stage[i] = 0
        elif dist > R_max:
            stage[i] = 3
        elif dist < R_min:
            stage[i] = 2
        else:
            stage[i] = 1
    return -1 if bad == n else bad


@kernel(
    f"int64({VALUES}, {VALUES}, {VALUES}, {VALUES}, {VALUES}, {VALUES}, {VALUES}, {VALUES},"
    " float64, float64, float64[::1], boolean[::1])"
)
def sector_test(
    r: np.ndarray,
    az: np.ndarray,
    r_pred: np.ndarray,
    az_pred: np.ndarray,
    sigma_r: np.ndarray,
    sigma_az: np.ndarray,
    sigma_r_pred: np.ndarray,
    sigma_az_pred: np.ndarray,
    K_R: float,
    K_az: float,
    statistic: np.ndarray,
    inside: np.ndarray,
) -> int:
    """max(|r - r_pred| / W_R, |wrap(az - az_pred)| / W_az) <= 1 of the sector gate."""
    n = statistic.shape[0]
    s_r, s_az = stride(r.shape[0], n), stride(az.shape[0], n)
    s_rp, s_azp = stride(r_pred.shape[0], n), stride(az_pred.shape[0], n)
    s_sr, s_saz = stride(sigma_r.shape[0], n), stride(sigma_az.shape[0], n)
    s_srp, s_sazp = stride(sigma_r_pred.shape[0], n), stride(sigma_az_pred.shape[0], n)
    bad = n
    for i in range(n):
        ri, azi = r[i * s_r], az[i * s_az]
        rp, azp = r_pred[i * s_rp], az_pred[i * s_azp]
        sr, saz = sigma_r[i * s_sr], sigma_az[i * s_saz]
        srp, sazp = sigma_r_pred[i * s_srp], sigma_az_pred[i * s_sazp]
        dr = ri - rp
        daz = azi - azp
        if not (
            math.isfinite(dr)
            and math.isfinite(daz)
            and ri >= 0.0
            and sr > 0.0
            and saz > 0.0
            and srp > 0.0
            and sazp > 0.0
            and math.isfinite(sr + saz + srp + sazp)
        ):
            bad = min(bad, i)
        W_R = K_R * math.hypot(sr, srp)
        W_az = K_az * math.hypot(saz, sazp)
        s = max(abs(dr) / W_R, abs(wrapped(daz)) / W_az)
        statistic[i] = s
        inside[i] = s <= 1.0
    return -1 if bad == n else bad


@kernel(
    f"int64({VALUES}, {VALUES}, {VALUES}, {VALUES}, float64, {VALUES}, {VALUES}, {VALUES},"
    f" {VALUES}, float64, float64, float64[::1], boolean[::1])"
)
def first_association_test(
    r1: np.ndarray,
    az1: np.ndarray,
    r2: np.ndarray,
    az2: np.ndarray,
    R_max: float,
    sigma_r1: np.ndarray,
    sigma_az1: np.ndarray,
    sigma_r2: np.ndarray,
    sigma_az2: np.ndarray,
    K_R: float,
    K_az: float,
    statistic: np.ndarray,
    inside: np.ndarray,
) -> int:
    """max(|r2 - r1| / W_R, |wrap(az2 - az1)| / W_az) <= 1 of the first-association windows."""
    n = statistic.shape[0]
    s_r1, s_az1 = stride(r1.shape[0], n), stride(az1.shape[0], n)
    s_r2, s_az2 = stride(r2.shape[0], n), stride(az2.shape[0], n)
    s_sr1, s_saz1 = stride(sigma_r1.shape[0], n), stride(sigma_az1.shape[0], n)
    s_sr2, s_saz2 = stride(sigma_r2.shape[0], n), stride(sigma_az2.shape[0], n)
    bad = n
    for i in range(n):
        ri1, ai1 = r1[i * s_r1], az1[i * s_az1]
        ri2, ai2 = r2[i * s_r2], az2[i * s_az2]
        sr1, sa1 = sigma_r1[i * s_sr1], sigma_az1[i * s_saz1]
        sr2, sa2 = sigma_r2[i * s_sr2], sigma_az2[i * s_saz2]
        dr = ri2 - ri1
        daz = ai2 - ai1
        if not (
            math.isfinite(dr)
            and math.isfinite(daz)
            and ri1 >= 0.0
            and ri2 >= 0.0
            and sr1 > 0.0
            and sa1 > 0.0
            and sr2 > 0.0
            and sa2 > 0.0
            and math.isfinite(sr1 + sa1 + sr2 + sa2)
        ):
            bad = min(bad, i)
        turn = math.asin(R_max / ri1) if ri1 > R_max else math.asin(1.0)
        W_R = R_max + K_R * math.hypot(sr1, sr2)
        W_az = turn + K_az * math.hypot(sa1, sa2)
        s = max(abs(dr) / W_R, abs(wrapped(daz)) / W_az)
        statistic[i] = s
        inside[i] = s <= 1.0
    return -1 if bad == n else bad
