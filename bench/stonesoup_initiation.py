"""Mu et al.'s track initiation run through Stone Soup's MultiMeasurementInitiator.

Run from the repository root (needs ``pip install -e ".[bench]"``, i.e. stonesoup)::

    python bench/stonesoup_initiation.py --runs 500

For comparison with plotgate's initiation ("Comparing with Stone
Soup"): the same scans our ``evaluate()`` sees (run r simulates ``mu_scenario``
with ``default_rng(SeedSequence(seed).spawn(runs)[r])``), the same scoring by labels (a
returned track is true when more than half of its plots come from one target, each target
once; every other returned track is false), and the time per scan. Prints a markdown
table of mean true targets, mean false tracks and seconds per scan per clutter level.

Choices, as close as Stone Soup allows to plotgate's polar 3-of-4 logic:

* detections: our simulated plots as they are (Stone Soup's radar models have no P_D),
  each a Cartesian ``Detection`` with its own 2x2 covariance R as a ``LinearGaussian``
  model on the constant-velocity state [x, vx, y, vy] (mapping (0, 2)), sorted by
  (x, y) before they go into the set Stone Soup wants;
* prior: position from the first detection (Stone Soup's internal
  ``SimpleMeasurementInitiator`` overwrites the mapped dimensions with the plot and R),
  velocity zero with std 30 m/s per axis, since targets move at up to 30 m/s;
* motion: two ``ConstantVelocity(q=1.0)``, Kalman predictor and updater;
* gate: ``DistanceHypothesiser`` with ``Mahalanobis`` and missed distance
  sqrt(gate_threshold(0.99, 2)) = 3.03 (P_G 0.99, like our gate), then ``GNNWith2DAssignment``.
  Plain, Stone Soup computes the distance of every tentative track to every detection in
  Python (about 24 s per scan at 250 clutter plots, some 13 hours for 500 runs), so by
  default a kd-tree prefilter (:class:`PrefilteredGNN`, exact: same tracks, checked)
  hands each track only the detections that can pass its gate; ``--no-prefilter`` times
  the plain associator;
* confirmation and deletion: ``min_points=3`` updates (the first plot counts), and
  ``UpdateTimeStepsDeleter(2)`` drops a tentative track after 2 scans without an
  update. It is not a sliding window: a track survives any single miss.

Stone Soup draws no random numbers here, so the result is fixed by the seed; its sets are
ordered by object identity, but with continuous distances the assignment is unique.
The time per scan is the wall time of ``initiate`` calls only (time.perf_counter).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
from scipy.spatial import KDTree
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
from stonesoup.deleter.time import UpdateTimeStepsDeleter
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.initiator.simple import MultiMeasurementInitiator
from stonesoup.measures import Mahalanobis
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.transition.linear import (
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
)
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.update import Update
from stonesoup.updater.kalman import KalmanUpdater

from plotgate.core.gates.thresholds import gate_threshold
from plotgate.core.initiation.scan import Scan
from plotgate.core.initiation.simulate import mu_scenario, simulate

EPOCH = datetime(2026, 1, 1)


class PrefilteredGNN(GNNWith2DAssignment):
    """GNNWith2DAssignment that hands each track only the detections that can pass its gate.

    Exact: a Mahalanobis distance d <= gamma needs |nu| <= gamma sqrt(lambda_max(S)), and
    lambda_max(S) <= lambda_max(H P H^T) + max over detections of lambda_max(R), so a kd-tree
    ball of that radius loses no hypothesis the hypothesiser would keep. (Stone Soup's own
    DetectionKDTreeGNN2D needs one measurement model for all detections.)
    """

    def generate_hypotheses(self, tracks, detections, timestamp, **kwargs):
        dets = list(detections)
        if not tracks or not dets:
            return super().generate_hypotheses(tracks, detections, timestamp, **kwargs)
        hyp = self.hypothesiser
        tree = KDTree(np.array([d.state_vector.ravel() for d in dets], dtype=float))
        r_max = max(np.linalg.eigvalsh(d.measurement_model.covar()).max() for d in dets)
        out = {}
        for track in tracks:
            pred = hyp.predictor.predict(track, timestamp=timestamp)
            P = np.asarray(pred.covar, dtype=float)[np.ix_((0, 2), (0, 2))]
            radius = hyp.missed_distance * np.sqrt(np.linalg.eigvalsh(P).max() + r_max)
            near = tree.query_ball_point(
                np.asarray(pred.state_vector, dtype=float)[[0, 2], 0], (1.0 + 1e-9) * radius
            )
            out[track] = hyp.hypothesise(track, {dets[i] for i in near}, timestamp, **kwargs)
        return out


def make_initiator(
    min_points: int = 3,
    q: float = 1.0,
    v_sigma: float = 30.0,
    P_G: float = 0.99,
    miss_steps: int = 2,
    prefilter: bool = True,
) -> MultiMeasurementInitiator:
    """A fresh MultiMeasurementInitiator with the choices of the module docstring."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    predictor = KalmanPredictor(transition)
    updater = KalmanUpdater(measurement_model=None)  # every detection carries its own
    hypothesiser = DistanceHypothesiser(
        predictor, updater, Mahalanobis(), missed_distance=float(np.sqrt(gate_threshold(P_G, 2)))
    )
    # position entries are replaced by each first detection; velocity is the prior
    prior = GaussianState(
        [[0.0], [0.0], [0.0], [0.0]], np.diag([0.0, v_sigma**2, 0.0, v_sigma**2]), timestamp=EPOCH
    )
    return MultiMeasurementInitiator(
        prior_state=prior,
        measurement_model=None,
        deleter=UpdateTimeStepsDeleter(time_steps_since_update=miss_steps),
        data_associator=(PrefilteredGNN if prefilter else GNNWith2DAssignment)(hypothesiser),
        updater=updater,
        min_points=min_points,
    )


def detections(scan: Scan, labels: np.ndarray, index: int) -> set[Detection]:
    """The plots of a scan as Detections sorted by (x, y), labelled in their metadata."""
    when = EPOCH + timedelta(seconds=scan.t)
    out = []
    for i in np.lexsort((scan.z[:, 1], scan.z[:, 0])):
        model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=scan.R[i])
        out.append(
            Detection(
                scan.z[i].reshape(2, 1),
                timestamp=when,
                measurement_model=model,
                metadata={"label": int(labels[i]), "scan": index, "plot": int(i)},
            )
        )
    return set(out)


def track_source(track, targets: int) -> int:
    """The target more than half of a track's plots come from, else -1."""
    sources = np.array(
        [
            s.hypothesis.measurement.metadata["label"]
            for s in track
            if isinstance(s, Update) and s.hypothesis
        ],
        dtype=int,
    )
    counts = np.bincount(sources[sources >= 0], minlength=targets)
    return int(np.argmax(counts)) if counts.max(initial=0) * 2 > sources.size else -1


def stonesoup_initiation(
    clutter: float,
    runs: int,
    seed: int,
    min_points: int = 3,
    q: float = 1.0,
    v_sigma: float = 30.0,
    P_G: float = 0.99,
    miss_steps: int = 2,
    prefilter: bool = True,
) -> dict:
    """Monte Carlo of MultiMeasurementInitiator on Mu et al.'s scenario, scored like ours.

    Returns {"mean_true", "mean_false", "se_true", "se_false", "seconds_per_scan", "runs"}
    (se: the standard error of the mean over the runs).
    """
    scenario = mu_scenario(clutter)
    targets = scenario.x0.shape[0]
    true, false = [], []
    elapsed, scans = 0.0, 0
    for child in np.random.SeedSequence(seed).spawn(runs):
        sim = simulate(scenario, np.random.default_rng(child))
        initiator = make_initiator(min_points, q, v_sigma, P_G, miss_steps, prefilter)
        found, wrong = set(), 0
        for i, (scan, labels) in enumerate(zip(sim.scans, sim.labels, strict=True)):
            dets = detections(scan, labels, i)
            start = time.perf_counter()
            confirmed = initiator.initiate(dets, EPOCH + timedelta(seconds=scan.t))
            elapsed += time.perf_counter() - start
            scans += 1
            for target in sorted(track_source(track, targets) for track in confirmed):
                if target >= 0 and target not in found:
                    found.add(target)
                else:
                    wrong += 1
        true.append(len(found))
        false.append(wrong)
    return {
        "mean_true": float(np.mean(true)),
        "mean_false": float(np.mean(false)),
        "se_true": float(np.std(true, ddof=1) / np.sqrt(runs)) if runs > 1 else float("nan"),
        "se_false": float(np.std(false, ddof=1) / np.sqrt(runs)) if runs > 1 else float("nan"),
        "seconds_per_scan": elapsed / scans,
        "runs": runs,
    }


def sweep(
    path: Path, clutter: list[float], settings: list[tuple[int, float]], runs: int, seed: int
) -> None:
    """Stone Soup's points for the operating curves: one JSON line per (clutter,
    min_points, P_G) appended to ``path``; points already there are not run again."""
    done = set()
    if path.exists():
        for line in path.read_text().splitlines():
            row = json.loads(line)
            done.add((row["clutter"], row["min_points"], row["P_G"], row["runs"], row["seed"]))
    for c in clutter:
        for min_points, P_G in settings:
            if (c, min_points, P_G, runs, seed) in done:
                continue
            r = stonesoup_initiation(c, runs, seed, min_points=min_points, P_G=P_G)
            row = {"clutter": c, "min_points": min_points, "P_G": P_G, "seed": seed, **r}
            with path.open("a") as out:
                out.write(json.dumps(row) + "\n")
            print(json.dumps(row), flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=500)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument(
        "--clutter", default="20,250", help="comma-separated mean clutter plots per scan"
    )
    parser.add_argument(
        "--no-prefilter",
        action="store_true",
        help="plain GNNWith2DAssignment (exact same tracks, much slower)",
    )
    parser.add_argument(
        "--sweep",
        type=Path,
        help="append the operating points of --settings to this JSON-lines file instead",
    )
    parser.add_argument(
        "--settings",
        default="2:0.95,2:0.99,2:0.999,3:0.95,3:0.99,3:0.999,4:0.95,4:0.99,4:0.999",
        help="with --sweep: comma-separated min_points:P_G",
    )
    args = parser.parse_args(argv)
    clutter = [float(c) for c in args.clutter.split(",")]
    if args.sweep:
        settings = [
            (int(m), float(p)) for m, p in (x.split(":") for x in args.settings.split(","))
        ]
        sweep(args.sweep, clutter, settings, args.runs, args.seed)
        return 0
    print(
        f"Stone Soup MultiMeasurementInitiator, Mu et al. scenario, {args.runs} runs, "
        f"seed {args.seed}, prefilter {'off' if args.no_prefilter else 'on'}\n"
    )
    print("| clutter / scan | mean true (of 5) | mean false | ms / scan |")
    print("|---:|---:|---:|---:|")
    for level in clutter:
        r = stonesoup_initiation(level, args.runs, args.seed, prefilter=not args.no_prefilter)
        print(
            f"| {level:g} | {r['mean_true']:.3f} | {r['mean_false']:.3f} | "
            f"{1e3 * r['seconds_per_scan']:.2f} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
