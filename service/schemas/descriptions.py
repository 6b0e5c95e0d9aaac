"""What each operation computes, for its OpenAPI ``description``: the method, the paper by
author and equation, the units, and what comes back.

Markdown, as Swagger UI and ReDoc render it. The OpenAPI document adds each operation's
example request (:data:`plotgate.service.schemas.examples.EXAMPLES`) after the text, so
every description shows one. Units are SI (metres, seconds, metres per second); angles on
the wire are degrees in fields named ``*_deg``, azimuths clockwise from north.
"""

__all__ = ["DESCRIPTIONS"]

_CAPTURE = (
    "The capture gates follow Konovalov: the ring R_min <= |d| <= R_max with "
    "R = v tau, the expanded ellipse of semi-axes R_max + K_g sigma, and the combined "
    "two-stage gate (inside the ring, or within the chi-square ellipse of B = P1 + P2 "
    "about the ring's nearest point)."
)

DESCRIPTIONS: dict[str, str] = {
    "gates.test": (
        "Tests one first plot z1 against many candidate plots z2: for each candidate, "
        "whether it falls in the gate and the gate's statistic. " + _CAPTURE + " The "
        "prediction gates are the chi-square ellipse nu^T S^-1 nu <= gamma(P_G), the "
        "rectangular gate |dx| <= k sigma_x, |dy| <= k sigma_y (the secondary-processing "
        "textbook) and Mu et al.'s polar sector and first-association windows (eq. 1-4). "
        "Plots are Cartesian (x, y in m with a 2 x 2 covariance in m^2) or polar (range in "
        "m, azimuth in degrees, with their sigmas, about a sensor); `tau` is the interval "
        "between the marks, s. The combined gate also says which stage accepted each mark."
    ),
    "gates.pairs": (
        "Tests many independent (first, second) plot pairs against one gate, each pair "
        "with its own first plot: the batch form of `gates.test`, for pairs collected "
        "from many tracks. " + _CAPTURE + " Units and plot forms as in `gates.test`; "
        "index i of every answer array answers pair i."
    ),
    "gates.probability": (
        "The probability that the second mark falls in a capture gate. With `velocity` "
        "(m/s) it is Konovalov's conditional probability, eq. 2: the integral of the "
        "density of d ~ N(v tau, B) over the gate. With `prior` it is the unconditional "
        "probability of eq. 3-6: heading uniform over [0, 2 pi) and speed either weighted "
        "as the paper's eq. 4 (`area`: true position uniform over the ring) or uniform on "
        "[v_min, v_max] (`speed`). Computed by deterministic quadrature along rays (a "
        "closed form in erf) and over direction, not by sampling; the answer carries its "
        "estimated absolute error (target below 1e-6). The mark is at range `r` (m) and "
        "azimuth `az_deg` from the radar, with sigmas in m and degrees; `tau` in s."
    ),
    "gates.probability_curve": (
        "Konovalov's gating probability (eq. 2 conditional on a velocity, or eq. 3-6 over "
        "a speed prior) at many values at once: against target speed (m/s, conditional, "
        "at `course_deg` clockwise from north) or against the first mark's range (m, "
        "conditional at `speed` or unconditional over `prior`), each point with its "
        "quadrature error. The curves of the paper's Fig. 2 (ring gate) and Fig. 5 "
        "(combined gate, P_G = 0.9); `plotgate plot fig2` draws them from this operation."
    ),
    "gates.analysis": (
        "What a capture gate costs and captures, after Konovalov: its area S (m^2, exact "
        "quadrature; for the combined gate also the paper's approximation S_ring + "
        "S_ellipse / 2), the resolution cells it covers S' = S / (dR R dAz) with R the "
        "first mark's range, the Poisson false marks in it (mean F S', P(at least one) = "
        "1 - exp(-F S')) for a false-alarm probability F per cell, and, with a speed "
        "prior, the unconditional gating probability (eq. 3-6) and the capture "
        "probability P = P_gate P_D1 P_D2. The paper's worked numbers: about 49 cells "
        "for the expanded gate against 31 for the combined one at 50 km."
    ),
    "gates.design": (
        "Sizes a capture gate for a wanted capture probability P_gate P_D1 P_D2 over a "
        "speed prior (Konovalov, eq. 3-6): the combined gate's P_G (and its gamma = "
        "chi2.ppf(P_G, 2)) or the expanded gate's p (and K_g = sqrt(-2 ln(1 - p))), found "
        "by Brent's method on the unconditional gating probability, with the gate's area "
        "(m^2), resolution cells and false marks at that size."
    ),
    "solves.position": (
        "Single-shot positions of a target from multistatic range sums l_k = |x - rx_k| + "
        "|x - tx_k| (m), after Fadeev, Myakinkov and Ogurtsov: the maximum-likelihood "
        "solution by weighted Gauss-Newton (eq. 6) with Levenberg-Marquardt step control, "
        "its covariance (H^T G H)^-1 (m^2), residuals, cost, a chi-square consistency test "
        "and, with three receivers in 2D, the alternative solution when it is also "
        "consistent; optionally the closed-form sum-range (spherical intersection) or "
        "difference-range (Chan-style) solution. Positions in m, 2D or 3D; a batch of "
        "independent problems, index i answering problems[i]."
    ),
    "solves.trajectory": (
        "A constant-velocity track (x0, v) fitted by maximum likelihood to range sums at "
        "several sample times (Fadeev et al., eq. 6 over a trajectory), with transmitter "
        "and receivers fixed, moving at constant velocity, or given per sample. Returns "
        "the state at the first sample time and the position with its covariance at any "
        "requested times. Positions in m, velocities in m/s, times in s."
    ),
    "solves.crlb": (
        "The Cramer-Rao bound of multistatic positioning (Fadeev et al., eq. 3): J = sum "
        "over samples and receivers of grad l grad l^T / sigma^2, single shot at each "
        "target position and accumulated along a track. Returns sigma_x, sigma_y (m) and "
        "the GDOP sqrt(trace(J^-1)) / sigma_ref, with sigma_ref the harmonic-mean sigma."
    ),
    "solves.noise": (
        "The range-sum noise estimated from the data (Fadeev et al., eq. 5): a quadratic "
        "(or higher-degree) fit of each range-sum series l_k(t) in sliding windows, with "
        "sigma^2 from the residuals over their degrees of freedom; and polynomial smoothing "
        "of solved coordinates in a sliding window. Range sums and sigmas in m, times in s."
    ),
    "solves.study": (
        "The Monte Carlo accuracy study of Fadeev et al., Fig. 3: along a constant-velocity "
        "target's track, `runs` seeded noisy range-sum series, and at every sample time "
        "the six curves (1 single-shot CRLB, 2 accumulated CRLB, 3 ML track, 4 ML single "
        "shot, 5 sum-range, 6 difference-range; RMSE per axis, m) with the diagnostics "
        "(Monte Carlo standard error, false minima, chi-square consistency) and the eq. 5 "
        "noise estimate. Seeded: the same request gives the same numbers. "
        "`plotgate study` judges the answer against the bounds."
    ),
    "initiation.initiate": (
        "Starts and confirms tracks from scans of plots in clutter, statelessly: the "
        "answer's `state` goes back with the next call's scans. Capture of a second plot "
        "in a ring, expanded or combined gate (Konovalov) within 2/N scans or T seconds, "
        "tentative tracks predicted at constant velocity and gated by chi-square (Kalman "
        "or the alpha-beta smoother of the secondary-processing textbook), and "
        "confirmation by k/m logic or by the sequential track score (Wald's thresholds "
        "from `false_confirmation` and `true_deletion`). The polar mode is Mu et al.'s "
        "method: sector gates (eq. 1-4), range-only extrapolation and the radial "
        "acceleration check. Plots in m (Cartesian) or m and degrees (polar), times in s."
    ),
    "initiation.simulate": (
        "Seeded scans of targets in Poisson clutter, every plot labelled with its source "
        "(a target's index, or -1 for clutter), and the true positions. The default is Mu "
        "et al.'s scenario: five ground targets at 25 m/s, radar at the origin, a 15 km "
        "square, P_D = 0.8, sigma_r = 5 m, sigma_az = 0.2 degrees, 1 s scans. Positions "
        "in m, times in s; the same seed gives the same scans."
    ),
    "initiation.evaluate": (
        "A Monte Carlo of track initiation on a simulated scenario (Mu et al.'s by "
        "default): per run, targets initiated and false tracks, scored by plot labels (a "
        "confirmed track is true when more than half of its plots come from one target "
        "not yet counted), with the means, their standard errors, the by-distance score "
        "and the time to confirmation. With `sweep`, one operating point per value of a "
        "setting, all on the same simulated scans. Seeds are spawned per run, so the "
        "numbers are the same in-process and on any Dask cluster."
    ),
    "identification.pair": (
        "Is a passive (ESM) bearing track the same object as an active radar bearing "
        "track? Kvasnov's Fisher Z-test: Z = (mean_active - mean_passive) / (sigma / "
        "sqrt(m)) with circular means and the difference wrapped, sigma known or estimated "
        "from the passive samples; the two-sided p-value and critical value at level "
        "`alpha`, the decision, the type II error beta for a stated minimum separation, "
        "the paper's conditions (n >> m, a normal passive sample) as flags, and the "
        "decision after each active sample. Bearings in degrees."
    ),
    "identification.picture": (
        "Many passive and active bearing tracks at once (Kvasnov's Z-test): the Z matrix "
        "and p-values of every passive x active pair, and a one-to-one identification by "
        "assignment on the pairs that pass the test. Bearings in degrees."
    ),
    "identification.simulate": (
        "Kvasnov's experiment by Monte Carlo: `runs` seeded tests with n passive bearings "
        "N(theta_0, sigma) and m active bearings uniform over a sector of `width_deg` (or "
        "normal), the active object `separation_deg` away: the fraction rejected (the "
        "realized type I error when the separation is 0) and identified (the type II "
        "error beta otherwise), with their binomial standard error. Angles in degrees."
    ),
}
"""Operation name -> its description (markdown), before the example request."""
