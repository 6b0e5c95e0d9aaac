"""Monte Carlo evaluation of track initiation on simulated scans.

Each run simulates a scenario's scans (:func:`plotgate.core.initiation.simulate.simulate`, run r
seeded by ``SeedSequence(seed).spawn``, so one run can be replayed alone), feeds them to
:func:`plotgate.core.initiation.initiate` scan by scan, and scores every track at the scan it is
confirmed:

* by labels: a confirmed track is true when more than half of its plots come from one
  target; each target counts once, and every other confirmed track is false;
* by distance: true when its position is within ``distance`` of a target's true
  position at that scan; again each target once.

It also reports the time to confirmation: from a target's first detection to the
confirmation of its first true track, in seconds.

:func:`sweep` traces an operating curve: the same runs (the same simulated scans) under
each value of one setting, so the differences between the values are not Monte Carlo
noise between different scans.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from plotgate.core.chunks import Mapper, mapped, spans
from plotgate.core.errors import ParameterError
from plotgate.core.initiation.config import InitiationConfig
from plotgate.core.initiation.logic import initiate
from plotgate.core.initiation.simulate import Scenario, SimulatedScans, simulate
from plotgate.core.initiation.state import PLOT_STRIDE

__all__ = [
    "CHUNK_RUNS",
    "K_OF_M",
    "SWEEPABLE",
    "Evaluation",
    "Mapper",
    "RunScore",
    "run_chunk",
    "evaluate",
    "score_run",
    "sweep",
    "swept",
]

K_OF_M = re.compile(r"([0-9]{1,3})/([0-9]{1,3})", re.ASCII)
"""k/m as :func:`swept` reads it: ASCII digits, at most three each, no spaces."""
CHUNK_RUNS = 25
"""Runs per chunk of an evaluation: fixed, so the chunks (and the numbers) do not depend
on how many workers run them."""
SWEEPABLE = ("confirm", *(f.name for f in fields(InitiationConfig)))
"""What :func:`sweep` may vary: any setting by its name, or ``"confirm"``, k/m as a
string ``"k/m"`` (confirm_k and confirm_m together)."""


@dataclass(frozen=True)
class RunScore:
    """The score of one run."""

    true: int
    false: int
    true_by_distance: int
    false_by_distance: int
    confirmation_times: tuple[float, ...]


@dataclass(frozen=True)
class Evaluation:
    """Means over the runs of :func:`evaluate`.

    Attributes
    ----------
    runs : int
    targets : int
        Targets in the scenario.
    ceiling : float
        Mean targets detected often enough to be confirmable at all (k of the first m
        scans after their first detection, counted in the simulated detections; the
        config's k/m under score confirmation too, as a reference).
    mean_true, mean_false : float
        Targets initiated and false tracks per run, by labels.
    se_true, se_false : float
        Their standard errors, sample standard deviation / sqrt(runs) (NaN for one run).
    mean_true_by_distance, mean_false_by_distance : float
        The same by distance.
    mean_time_to_confirmation : float
        Seconds from a target's first detection to its confirmation (NaN if none).
    true, false : (runs,) ndarray of int
        Per run, by labels.
    """

    runs: int
    targets: int
    ceiling: float
    mean_true: float
    mean_false: float
    se_true: float
    se_false: float
    mean_true_by_distance: float
    mean_false_by_distance: float
    mean_time_to_confirmation: float
    true: np.ndarray
    false: np.ndarray


def score_run(
    scenario: Scenario,
    config: InitiationConfig,
    seed: np.random.SeedSequence | int,
    distance: float,
) -> tuple[RunScore, int]:
    """Simulate and initiate one run; its score, and how many targets were confirmable.

    Returns the score and the number of targets that were detected in k of the m
    scans from their first detection (the ceiling of this run) as a second element.
    """
    sim = simulate(scenario, np.random.default_rng(seed))
    return _score(scenario, sim, config, distance)


def _score(
    scenario: Scenario, sim: SimulatedScans, config: InitiationConfig, distance: float
) -> tuple[RunScore, int]:
    """:func:`score_run` on scans already simulated."""
    k = scenario.x0.shape[0]
    first_seen = np.full(k, np.nan)
    labelled, near = set(), set()
    false = false_d = 0
    times = []
    state = None
    for i, (scan, label) in enumerate(zip(sim.scans, sim.labels, strict=True)):
        seen = label[label >= 0]
        first_seen[seen] = np.where(np.isnan(first_seen[seen]), scan.t, first_seen[seen])
        state, (report,) = initiate(state, [scan], config)
        if report.confirmed.size == 0:
            continue
        rows = np.flatnonzero(np.isin(state.tracks.id, report.confirmed))
        for row in rows:  # the few tracks confirmed by this scan
            plots = state.tracks.plots[row]
            plots = plots[plots >= 0]
            sources = np.array([sim.labels[p // PLOT_STRIDE][p % PLOT_STRIDE] for p in plots])
            counts = np.bincount(sources[sources >= 0], minlength=k)
            target = int(np.argmax(counts)) if counts.max(initial=0) * 2 > plots.size else -1
            if target >= 0 and target not in labelled:
                labelled.add(target)
                times.append(scan.t - first_seen[target])
            else:
                false += 1
            gap = np.linalg.norm(sim.truth[i] - state.tracks.x[row, :2], axis=1)
            hits = [j for j in np.flatnonzero(gap <= distance) if j not in near]
            if hits:
                near.add(int(hits[np.argmin(gap[hits])]))
            else:
                false_d += 1
    detected = np.zeros((scenario.scans, k), dtype=bool)
    for i, label in enumerate(sim.labels):
        detected[i, label[label >= 0]] = True
    confirmable = 0
    for j in range(k):  # per target: k detections within m scans of its first
        hit = np.flatnonzero(detected[:, j])
        if hit.size and detected[hit[0] : hit[0] + config.confirm_m, j].sum() >= config.confirm_k:
            confirmable += 1
    return RunScore(len(labelled), false, len(near), false_d, tuple(times)), confirmable


def evaluate(
    scenario: Scenario,
    config: InitiationConfig,
    runs: int,
    seed: int,
    distance: float = 100.0,
    mapper: Mapper | None = None,
) -> Evaluation:
    """Monte Carlo of track initiation on a scenario: targets initiated, false tracks.

    Parameters
    ----------
    scenario : Scenario
    config : InitiationConfig
    runs : int
        Monte Carlo runs, >= 1.
    seed : int
        Seed (>= 0); run r uses ``numpy.random.SeedSequence(seed).spawn(runs)[r]``.
    distance : float, optional
        Radius of the distance score, m (> 0). Default 100 (at 11 km a 0.2 degree
        azimuth error alone is about 38 m).
    mapper : Mapper, optional
        How the chunks of CHUNK_RUNS runs are run: a ``map`` (default the builtin, in
        this process; a cluster's to spread them). The result is the same bit for bit.

    Returns
    -------
    evaluation : Evaluation

    Examples
    --------
    >>> from plotgate.core.initiation.simulate import mu_scenario
    >>> ev = evaluate(mu_scenario(20.0), InitiationConfig(mode="polar", v_max=30.0),
    ...               runs=5, seed=1)
    >>> ev.targets, ev.mean_true <= ev.ceiling
    (5, True)
    """
    (evaluation,) = _evaluations(scenario, [config], runs, seed, distance, mapper)
    return evaluation


def swept(config: InitiationConfig, parameter: str, value: Any) -> InitiationConfig:
    """``config`` with ``parameter`` set to ``value`` (``"confirm"``: a ``"k/m"`` string).

    Raises
    ------
    ParameterError
        ``"parameter"`` for a name not in :data:`SWEEPABLE`; ``"confirm"`` for a value
        that is not ``"k/m"``; the setting's own name for a value it refuses.

    >>> swept(InitiationConfig(), "confirm", "2/3").confirm_m
    3
    """
    if parameter not in SWEEPABLE:
        raise ParameterError(
            "parameter", f"must be one of {', '.join(SWEEPABLE)}, got {parameter!r}"
        )
    if parameter != "confirm":
        return replace(config, **{parameter: value})
    match = K_OF_M.fullmatch(value) if isinstance(value, str) else None
    if match is None:
        raise ParameterError("confirm", f"must be a string k/m such as '3/4', got {value!r}")
    k, m = int(match[1]), int(match[2])
    return replace(config, confirm_k=k, confirm_m=m, history=max(config.history, m))


def sweep(
    scenario: Scenario,
    config: InitiationConfig,
    parameter: str,
    values: Sequence[Any],
    runs: int,
    seed: int,
    distance: float = 100.0,
    baseline: bool = False,
    mapper: Mapper | None = None,
) -> list[Evaluation]:
    """An operating curve: :func:`evaluate` under each value of one setting, same scans.

    Every run is simulated once and initiated under every value, so the curve's points
    differ by the setting alone (common random numbers). Each point equals
    ``evaluate(scenario, swept(config, parameter, value), runs, seed, distance)``.

    Parameters
    ----------
    scenario, config, runs, seed, distance
        As :func:`evaluate`.
    parameter : str
        A name in :data:`SWEEPABLE`: a setting (``"gate_P_G"``, ``"false_confirmation"``,
        ``"K_A"``...), or ``"confirm"`` for k/m.
    values : sequence
        Its values (``"k/m"`` strings for ``"confirm"``), at least one.
    baseline : bool, optional
        Also evaluate ``config`` itself on the same runs, first in the list.
    mapper : Mapper, optional
        As :func:`evaluate`'s.

    Returns
    -------
    curve : list of Evaluation
        One per value, in order (after ``config``'s own with ``baseline``).

    Raises
    ------
    ParameterError
        As :func:`swept` (with the value's index), and as :func:`evaluate`.

    Examples
    --------
    >>> from plotgate.core.initiation.simulate import mu_scenario
    >>> curve = sweep(mu_scenario(20.0), InitiationConfig(mode="polar", v_max=30.0),
    ...               "confirm", ["2/4", "4/4"], runs=5, seed=1)
    >>> curve[0].mean_true >= curve[1].mean_true
    True
    """
    if isinstance(values, (str, bytes)) or len(values) < 1:
        raise ParameterError("values", f"must be a non-empty list, got {values!r}")
    configs = []
    for i, value in enumerate(values):
        try:
            configs.append(swept(config, parameter, value))
        except ParameterError as exc:
            if exc.field == "parameter":
                raise
            raise ParameterError("values", f"{exc.field}: {exc.reason}", i) from exc
    return _evaluations(scenario, [config] * baseline + configs, runs, seed, distance, mapper)


def _evaluations(
    scenario: Scenario,
    configs: Sequence[InitiationConfig],
    runs: int,
    seed: int,
    distance: float,
    mapper: Mapper | None = None,
) -> list[Evaluation]:
    """Each config evaluated on the same simulated runs, in chunks of CHUNK_RUNS runs
    mapped by ``mapper`` (default: the builtin ``map``, in this process)."""
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise ParameterError("runs", f"must be an integer >= 1, got {runs!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError("seed", f"must be an integer >= 0, got {seed!r}")
    if not distance > 0:
        raise ParameterError("distance", f"must be > 0, got {distance!r}")
    chunks = [
        (scenario, tuple(configs), seed, start, stop, distance)
        for start, stop in spans(runs, CHUNK_RUNS)
    ]
    parts = mapped(mapper, run_chunk, chunks)
    scores: list[list[RunScore]] = [[] for _ in configs]
    ceiling: list[list[int]] = [[] for _ in configs]
    for part_scores, part_ceiling in parts:  # in run order, whatever ran them
        for j in range(len(configs)):
            scores[j].extend(part_scores[j])
            ceiling[j].extend(part_ceiling[j])
    return [_summary(scenario, s, c) for s, c in zip(scores, ceiling, strict=True)]


def run_chunk(
    chunk: tuple[Scenario, tuple[InitiationConfig, ...], int, int, int, float],
) -> tuple[list[list[RunScore]], list[list[int]]]:
    """Runs start to stop - 1 of an evaluation under each config: one chunk of the work.

    ``chunk`` is (scenario, configs, seed, start, stop, distance). Run r is seeded by the
    r-th child of ``SeedSequence(seed)`` (``SeedSequence(seed, spawn_key=(r,))``, the
    child ``spawn`` would give), so a chunk depends on nothing but its own runs, and any
    chunking, run anywhere in any order, gives the same runs bit for bit. Returns per
    config the runs' scores and confirmable counts, in run order.
    """
    scenario, configs, seed, start, stop, distance = chunk
    scores: list[list[RunScore]] = [[] for _ in configs]
    ceiling: list[list[int]] = [[] for _ in configs]
    for r in range(start, stop):  # independent, seeded runs
        child = np.random.SeedSequence(seed, spawn_key=(r,))
        sim = simulate(scenario, np.random.default_rng(child))
        for j, config in enumerate(configs):
            score, confirmable = _score(scenario, sim, config, distance)
            scores[j].append(score)
            ceiling[j].append(confirmable)
    return scores, ceiling


def _summary(scenario: Scenario, scores: list[RunScore], ceiling: list[int]) -> Evaluation:
    runs = len(scores)
    times = [t for s in scores for t in s.confirmation_times]
    true = np.array([s.true for s in scores])
    false = np.array([s.false for s in scores])

    def se(x: np.ndarray) -> float:
        return float(np.std(x, ddof=1) / np.sqrt(runs)) if runs > 1 else float("nan")

    return Evaluation(
        runs=runs,
        targets=scenario.x0.shape[0],
        ceiling=float(np.mean(ceiling)),
        mean_true=float(true.mean()),
        mean_false=float(false.mean()),
        se_true=se(true),
        se_false=se(false),
        mean_true_by_distance=float(np.mean([s.true_by_distance for s in scores])),
        mean_false_by_distance=float(np.mean([s.false_by_distance for s in scores])),
        mean_time_to_confirmation=float(np.mean(times)) if times else float("nan"),
        true=true,
        false=false,
    )
