"""Settings of the track-initiation logic (Mu et al.; Konovalov; the secondary-processing
textbook; Blackman and Popoli).

One frozen :class:`InitiationConfig` holds every rule: the mode (Cartesian logic or the
polar method of Mu et al.), the capture gate and its 2/N or 2/T criterion, branch or
nearest association, the filter, the tracking gates and how they widen after misses,
the confirmation (k/m, or the sequential track score with Wald's thresholds) and the
k/m - l drop. :meth:`InitiationConfig.digest` fingerprints
the settings, so a state made under other settings is recognised as foreign.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field

from plotgate.core.errors import ParameterError

__all__ = ["CHOICES", "EXISTENCE_SETTINGS", "InitiationConfig"]

EXISTENCE_SETTINGS = ("survival", "existence_birth", "existence_confirm", "existence_delete")
"""The settings only existence confirmation reads."""

CHOICES = {
    "mode": ("cartesian", "polar"),
    "capture_gate": ("ring", "expanded", "combined"),
    "association": ("branch", "nearest"),
    "filter": ("kalman", "alpha_beta"),
    "confirmation": ("k_of_m", "score", "existence"),
}
"""The settings that name a choice, and their options."""


@dataclass(frozen=True)
class InitiationConfig:
    """Rules of track initiation; SI units, angles in radians.

    Attributes
    ----------
    mode : ``"cartesian"`` or ``"polar"``
        Cartesian: the logic method (capture gate about the first plot, constant-velocity
        filter, chi-square gates). Polar: Mu et al.'s method (first-association sector
        windows, range-only linear extrapolation, the azimuth window of the tangential
        speed bound, the radial acceleration check before confirmation).
    v_min, v_max : float
        Target speed bounds, m/s (0 <= v_min <= v_max, v_max > 0).
    capture_gate : ``"ring"``, ``"expanded"`` or ``"combined"``
        Cartesian capture gate about an initiator (Konovalov).
    capture_P_G : float
        Gating probability of the combined gate's ellipse stage.
    capture_p : float
        Probability of the expanded gate's expansion coefficient.
    capture_scans : int
        Criterion 2/N: an initiator may be captured by a plot of its next
        capture_scans - 1 scans (>= 2).
    capture_time : float or None
        Criterion 2/T instead: by a plot at most capture_time seconds later (> 0).
    association : ``"branch"`` or ``"nearest"``
        Every plot in an initiator's capture gate starts its own tentative track (seed
        003, approach 1), or only the one nearest the initiator (approach 2).
    filter : ``"kalman"`` or ``"alpha_beta"``
        Cartesian track filter: constant-velocity Kalman with white-acceleration noise
        ``q`` (m^2/s^3), or the secondary-processing textbook's alpha-beta smoother
        alpha_n = 2(2n-1)/(n(n+1)), beta_n = 6/(n(n+1)) (n plots so far), floored at
        alpha_min, beta_min.
    gate_P_G : float
        Gating probability of a track's chi-square gate (Cartesian) or, through
        K_R = K_az = sqrt(chi2.ppf(P_G, 2)) when those are None, of its polar windows.
    gate_widening : tuple of float
        The secondary-processing textbook's narrow / medium / wide gates: the gate
        threshold (gamma, or K^2 for the polar windows) is multiplied by
        gate_widening[min(misses, len - 1)] after that many misses in a row; each
        factor >= 1, non-decreasing.
    confirm_k, confirm_m : int
        Confirmation k/m: k plots within the track's first m scans (counted from its
        first plot, both capture plots included; 1 <= k <= m). Under score
        confirmation, k is the fewest plots a track confirms with (m is not used).
    drop_misses : int
        l of k/m - l: a track is dropped after l misses in a row (>= 1); a tentative
        one also when k can no longer be reached within its first m scans.
    K_R, K_az : float or None
        Polar window coefficients (> 0); None derives them from gate_P_G.
    a_max, K_A : float
        Polar mode: largest radial acceleration (m/s^2, > 0) and its factor (> 1) in
        the check |r_3 - 2 r_2 + r_1| / tau^2 <= K_A a_max (divided differences for
        unequal intervals). The default 30 m/s^2 leaves room for the range noise's own
        second difference, sqrt(6) sigma_r / tau^2 rms (12 m/s^2 for 5 m at 1 s).
    history : int
        Plot ids kept per track for the plot-reuse rules (>= confirm_m, and >= 2: a track
        starts with two plots). Under score confirmation, which has no m, a track that
        confirms after more plots than this is judged by its last ``history`` plots
        (sharing rules, and the evaluation's labels).
    confirmation : ``"k_of_m"`` or ``"score"``
        k_of_m: confirm_k plots within the first confirm_m scans. score: the sequential
        log-likelihood-ratio track score (Blackman and Popoli, ch. 6;
        :mod:`plotgate.core.initiation.score`) reaches ln((1 - beta) / alpha), alpha =
        false_confirmation, beta = true_deletion, on a track of at least confirm_k
        plots (a threshold low enough for a true track that missed a scan is passed by
        many clutter pairs); a tentative track whose score falls to ln(beta / (1 - alpha))
        is dropped (Wald's sequential test). Either way, polar
        mode's windows and acceleration check still apply, and l misses in a row drop
        any track.
    P_D : float
        Score: detection probability of a target in a scan, in (0, 1).
    clutter_density : float or None
        Score: false plots per m^2 per scan (> 0); None estimates it per scan as
        max(n, 1) / surveillance_area from the scan's own n plots.
    surveillance_area : float or None
        Score: the area the scans cover, m^2 (> 0); needed when clutter_density is None.
    new_target_density : float
        Score: new targets per m^2 per scan (> 0), the prior of a track's first plot.
    false_confirmation, true_deletion : float
        Score: alpha, the wanted probability of confirming a false track, and beta, of
        dropping a true one; each in (0, 1), alpha + beta < 1.
    survival, existence_birth : float
        Existence (IPDA, :mod:`plotgate.core.initiation.existence`): p11, the probability
        that a target that exists in a scan still exists in the next, and p21, that a
        track which is not a target's becomes one; each in [0, 1]. The Markov chain
        P(k|k-1) = p11 P(k-1) + p21 (1 - P(k-1)) carries existence across a scan.
    existence_confirm, existence_delete : float
        Existence: tau_c, a tentative track confirms when its probability of existence
        reaches it (with at least confirm_k plots), and tau_d, it is dropped at or below
        it; 0 < tau_d < tau_c < 1. P_D, clutter_density, surveillance_area and
        new_target_density are the score's, and serve existence too (a single plot's
        odds of existence are P_D beta_NT / beta_FT, the score's first plot).
    """

    mode: str = "cartesian"
    v_min: float = 0.0
    v_max: float = 50.0
    capture_gate: str = "ring"
    capture_P_G: float = 0.99
    capture_p: float = 0.95
    capture_scans: int = 2
    capture_time: float | None = None
    association: str = "branch"
    filter: str = "kalman"
    q: float = 1.0
    alpha_min: float = 0.2
    beta_min: float = 0.05
    gate_P_G: float = 0.99
    gate_widening: tuple[float, ...] = field(default=(1.0, 2.0, 4.0))
    confirm_k: int = 3
    confirm_m: int = 4
    drop_misses: int = 2
    K_R: float | None = None
    K_az: float | None = None
    a_max: float = 10.0
    K_A: float = 3.0
    history: int = 8
    confirmation: str = "k_of_m"
    P_D: float = 0.9
    clutter_density: float | None = None
    surveillance_area: float | None = None
    new_target_density: float = 1e-8
    false_confirmation: float = 1e-3
    true_deletion: float = 0.1
    survival: float = 0.98
    existence_birth: float = 0.0
    existence_confirm: float = 0.99
    existence_delete: float = 0.02

    def __post_init__(self) -> None:
        for name, options in CHOICES.items():
            if getattr(self, name) not in options:
                raise ParameterError(
                    name, f"must be one of {', '.join(options)}, got {getattr(self, name)!r}"
                )
        object.__setattr__(self, "gate_widening", tuple(float(w) for w in self.gate_widening))
        self._check()

    def _check(self) -> None:
        def number(name: str, ok: bool, rule: str) -> None:
            value = getattr(self, name)
            if not (
                isinstance(value, (int, float))
                and not isinstance(value, bool)
                and math.isfinite(value)
                and ok
            ):
                raise ParameterError(name, f"must be {rule}, got {value!r}")

        number("v_min", self.v_min >= 0, "finite and >= 0")
        number("v_max", self.v_max > 0 and self.v_max >= self.v_min, "> 0 and >= v_min")
        for name in (
            "capture_P_G",
            "capture_p",
            "gate_P_G",
            "P_D",
            "false_confirmation",
            "true_deletion",
        ):
            number(name, 0 < getattr(self, name) < 1, "in (0, 1)")
        for name in ("q", "a_max", "new_target_density"):
            number(name, getattr(self, name) > 0, "> 0")
        for name in ("alpha_min", "beta_min"):
            number(name, 0 < getattr(self, name) <= 1, "in (0, 1]")
        number("K_A", self.K_A > 1, "> 1")
        for name in ("survival", "existence_birth"):
            number(name, 0 <= getattr(self, name) <= 1, "in [0, 1]")
        for name in ("existence_confirm", "existence_delete"):
            number(name, 0 < getattr(self, name) < 1, "in (0, 1)")
        for name in ("K_R", "K_az", "capture_time", "clutter_density", "surveillance_area"):
            if getattr(self, name) is not None:
                number(name, getattr(self, name) > 0, "> 0 or null")
        for name, low in (
            ("capture_scans", 2),
            ("confirm_k", 1),
            ("confirm_m", 1),
            ("drop_misses", 1),
            ("history", max(2, self.confirm_m)),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ParameterError(name, f"must be an integer >= {low}, got {value!r}")
        if self.confirm_k > self.confirm_m:
            raise ParameterError(
                "confirm_k", f"must be <= confirm_m = {self.confirm_m}, got {self.confirm_k}"
            )
        alpha, beta = self.false_confirmation, self.true_deletion
        self._check_existence()
        score = self.confirmation == "score"  # alpha + beta < 1 where they are used:
        if score and (1.0 - alpha) * (1.0 - beta) <= alpha * beta:  # without rounding
            raise ParameterError(
                "true_deletion",
                f"must be < 1 - false_confirmation = {1 - alpha:g}, got {beta!r} (the "
                "confirmation threshold must lie above the deletion threshold)",
            )
        scored = self.confirmation != "k_of_m"
        if scored and self.clutter_density is None and self.surveillance_area is None:
            raise ParameterError(
                "clutter_density",
                f"{self.confirmation} confirmation needs clutter_density, or "
                "surveillance_area to estimate it from each scan's plot count",
            )
        w = self.gate_widening
        if not w or not all(math.isfinite(x) and x >= 1 for x in w) or list(w) != sorted(w):
            raise ParameterError(
                "gate_widening", f"must be non-decreasing factors >= 1, got {list(w)}"
            )

    def _check_existence(self) -> None:
        """Existence confirmation: tau_d below tau_c, and the Cartesian mode (its gate
        probability P_G is the chi-square ellipse's, which polar windows do not have)."""
        if self.confirmation != "existence":
            return
        if self.existence_delete >= self.existence_confirm:
            raise ParameterError(
                "existence_delete",
                f"must be < existence_confirm = {self.existence_confirm}, "
                f"got {self.existence_delete!r}",
            )
        if self.mode != "cartesian":
            raise ParameterError(
                "mode", "existence confirmation runs in cartesian mode (its gates are ellipses)"
            )

    def digest(self) -> str:
        """A short fingerprint of these settings (stored in every state), computed once
        per settings object: initiation checks it on every call, and a Monte Carlo
        evaluation calls once a scan (7% of the score path's time before it was kept).
        The existence settings count only under existence confirmation, so every other
        configuration keeps the fingerprint it had before they were added."""
        kept: str | None = self.__dict__.get("_digest")
        if kept is None:
            settings = asdict(self)
            if self.confirmation != "existence":
                for name in EXISTENCE_SETTINGS:
                    del settings[name]
            text = json.dumps(settings, sort_keys=True)
            kept = hashlib.sha256(text.encode()).hexdigest()[:16]
            object.__setattr__(self, "_digest", kept)  # frozen: a cache, not a field
        return kept
