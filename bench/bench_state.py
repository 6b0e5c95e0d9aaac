"""One ``initiation.initiate`` call carrying a state at the schema's ceilings: the worst time.

Run from the repository root::

    python bench/bench_state.py                   # both tables (~4 min)
    python bench/bench_state.py --scale 0.25      # a quick look at a quarter of them
    python bench/bench_state.py --rule-only       # the plot-reuse rule against its baseline

Each row is one HTTP call through the service in-process (Starlette's TestClient, recording
on: parsing, the schema, the state's checks, the logic, the answer and its record), best of
``--repeats``. The states are built valid (every invariant of
``core.initiation.state_json.check_state`` holds) and as costly as we know how:

- ``branches``: tracks with full histories of ``history`` plots, every plot shared by every
  track (one initiator's branches that always took the same plots), all reaching k = m =
  history at the call's one scan, whose plot lies in every gate: the confirmation rule
  meets every track and every pair of its plots (history (history - 1) / 2 keys a track).
- ``coasting``: confirmed tracks, one per target, and ``drop_misses`` = 100 empty scans:
  every track is predicted, gated and kept for 99 scans before it is dropped.
- ``initiators``: initiators of the last scan, capture 2/100, and 99 scans of 100 plots
  far from all of them: every scan searches every initiator's capture gate.
- ``both``: the tracks of ``coasting`` and the initiators of ``initiators`` in one state.
- ``stateless``: for comparison, no state: one scan of as many plots as ``initiators``
  has initiators (less the 99 that follow), then 99 scans of one plot far from them.

A second table times the confirmation's plot-reuse rule alone on ``branches``' histories
(every track holding the same plots, history 8):
:func:`plotgate.core.initiation.sharing.keep_greedy`
against the baseline it replaced, a join on plot ids followed by the greedy over the
clashing pairs (:func:`join_greedy`, checked equal first), whose work grows as the square
of the tracks holding one plot.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy
from fastapi.testclient import TestClient

from plotgate.core.initiation import PLOT_STRIDE, InitiationConfig, Initiators, Tracks
from plotgate.core.initiation.held_checks import remade_tracks
from plotgate.core.initiation.sharing import keep_greedy
from plotgate.core.initiation.state import STATE_VERSION, HeldPlots, InitiationState
from plotgate.core.initiation.state_json import check_state
from plotgate.service.app import create_app
from plotgate.service.config import Settings
from plotgate.service.schemas import MAX_STATE_INITIATORS, MAX_STATE_TRACKS
from plotgate.service.schemas.initiation_state import MAX_HISTORY, MAX_HISTORY_CELLS

R = 100.0  # plot variance, m^2 (10 m sigma)
SETTINGS = {"cartesian": {"v_max": 50.0}}


def _wire(config: InitiationConfig) -> dict:
    out = {k: v for k, v in config.__dict__.items()}
    out["gate_widening"] = list(out["gate_widening"])
    return out


def _tracks(
    n: int, H: int, scans: int, xy: np.ndarray, index: np.ndarray, confirmed: bool
) -> Tracks:
    """n tracks at positions xy (n, 2), standing still, each with a plot (of plot index
    ``index``) in each of the last min(scans, H) scans, the last one at scan scans - 1."""
    h = min(scans, H)
    plots = np.full((n, H), -1, dtype=np.int64)
    scan_of = np.arange(scans - h, scans)
    plots[:, H - h :] = scan_of * PLOT_STRIDE + index[:, None]
    times = np.full((n, H), np.nan)
    times[:, H - h :] = scan_of.astype(float)
    r = np.hypot(xy[:, 0], xy[:, 1])
    ranges = np.where(plots >= 0, r[:, None], np.nan)
    sigma_r = np.where(plots >= 0, 10.0, np.nan)
    P = np.tile(np.diag([R, R, 4.0, 4.0]), (n, 1, 1))
    return Tracks(
        id=np.arange(n, dtype=np.int64),
        confirmed=np.full(n, confirmed),
        x=np.column_stack([xy, np.zeros((n, 2))]),
        P=P,
        t=np.full(n, scans - 1.0),
        n=np.full(n, scans, dtype=np.int64),
        first_scan=np.zeros(n, dtype=np.int64),
        confirmed_scan=np.full(n, scans - 1 if confirmed else -1, dtype=np.int64),
        misses=np.zeros(n, dtype=np.int64),
        cost=np.zeros(n),
        plots=plots,
        ranges=ranges,
        times=times,
        sigma_r=sigma_r,
        az=np.arctan2(xy[:, 0], xy[:, 1]),
        sigma_az=10.0 / r,
        sensor=np.zeros((n, 2)),
        score=np.zeros(n),
    )


def _initiators(m: int, scan: int, first_index: int, xy: np.ndarray) -> Initiators:
    r = np.hypot(xy[:, 0], xy[:, 1])
    return Initiators(
        plot=scan * PLOT_STRIDE + first_index + np.arange(m, dtype=np.int64),
        scan=np.full(m, scan, dtype=np.int64),
        t=np.full(m, float(scan)),
        z=xy,
        R=np.tile(np.eye(2) * R, (m, 1, 1)),
        sensor=np.zeros((m, 2)),
        r=r,
        az=np.arctan2(xy[:, 0], xy[:, 1]),
        sigma_r=np.full(m, 10.0),
        sigma_az=10.0 / r,
        score=np.zeros(m),
    )


def _empty_initiators() -> Initiators:
    return _initiators(0, 0, 0, np.zeros((0, 2)))


def _held(tracks: Tracks) -> HeldPlots:
    """The tentative tracks' plots, each where its track stands (the last holder's)."""
    tentative = tracks.plots[~tracks.confirmed]
    rows = np.repeat(np.flatnonzero(~tracks.confirmed), tracks.plots.shape[1])
    ids, first = np.unique(tentative.ravel(), return_index=True)
    keep = ids >= 0
    z = tracks.x[rows[first[keep]], :2]
    return HeldPlots(ids[keep], z, np.tile(np.eye(2) * R, (int(keep.sum()), 1, 1)))


def _state(config: InitiationConfig, scans: int, tracks: Tracks, initiators: Initiators) -> dict:
    """The state, its tentative tracks made again from their plots (as the service checks
    them: core.initiation.held_checks)."""
    state = InitiationState(
        STATE_VERSION,
        config.digest(),
        scans,
        scans - 1.0,
        tracks.size,
        initiators,
        tracks,
        _held(tracks),
    )
    rows, x, P = remade_tracks(state, config)
    xs, Ps = tracks.x.copy(), tracks.P.copy()
    xs[rows], Ps[rows] = x, P
    state = state.replace(tracks=replace(tracks, x=xs, P=Ps))
    check_state(state, config)
    return state.to_json()


def _plot(x: float, y: float) -> dict:
    return {"frame": "cartesian", "x": x, "y": y, "covariance": [[R, 0.0], [0.0, R]]}


def branches(n: int, H: int) -> tuple[InitiationConfig, dict, list[dict]]:
    config = InitiationConfig(v_max=50.0, history=H, confirm_k=H, confirm_m=H, drop_misses=2)
    xy = np.tile([0.0, 5e4], (n, 1))
    tracks = _tracks(n, H, H - 1, xy, np.zeros(n, dtype=np.int64), confirmed=False)
    return (
        config,
        _state(config, H - 1, tracks, _empty_initiators()),
        [{"t": H - 1.0, "plots": [_plot(0.0, 5e4)]}],
    )


def coasting(n: int, H: int) -> tuple[InitiationConfig, dict, list[dict]]:
    config = InitiationConfig(v_max=50.0, history=H, drop_misses=100)
    side = int(np.ceil(np.sqrt(n)))
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n]
    xy = grid * 1000.0 + [1e4, 1e4]
    tracks = _tracks(n, H, H, xy, np.arange(n, dtype=np.int64), confirmed=True)
    return (
        config,
        _state(config, H, tracks, _empty_initiators()),
        [{"t": H + float(k), "plots": []} for k in range(100)],
    )


def initiators(m: int, H: int) -> tuple[InitiationConfig, dict, list[dict]]:
    config = InitiationConfig(v_max=50.0, history=H, capture_scans=100)
    rng = np.random.default_rng(0)
    xy = rng.uniform(1e4, 6e4, (m, 2))
    ini = _initiators(m, 0, 0, xy)
    far = [_plot(-5e5 + 100.0 * j, -5e5) for j in range(100)]
    empty = _tracks(0, H, 1, np.zeros((0, 2)), np.zeros(0, dtype=np.int64), False)
    return config, _state(config, 1, empty, ini), [{"t": 1.0 + k, "plots": far} for k in range(99)]


def both(n: int, H: int) -> tuple[InitiationConfig, dict, list[dict]]:
    """``coasting`` and ``initiators`` at once: every track and every initiator each scan."""
    config = InitiationConfig(v_max=50.0, history=H, drop_misses=100, capture_scans=100)
    side = int(np.ceil(np.sqrt(n)))
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n]
    tracks = _tracks(
        n, H, H, grid * 1000.0 + [1e4, 1e4], np.arange(n, dtype=np.int64), confirmed=True
    )
    m = min(MAX_STATE_INITIATORS, (n + 100) * MAX_STATE_INITIATORS // MAX_STATE_TRACKS)
    xy = np.random.default_rng(0).uniform(1e4, 6e4, (m, 2))
    waiting = _initiators(m, H - 1, n, xy)
    far = [_plot(-5e5 + 100.0 * j, -5e5) for j in range(100)]
    return (
        config,
        _state(config, H, tracks, waiting),
        [{"t": H + float(k), "plots": far} for k in range(99)],
    )


def stateless(m: int, H: int) -> tuple[InitiationConfig, None, list[dict]]:
    """No state: one scan of m plots, then 99 scans of one plot far from them (the same
    initiators searched as often, from a request's own plots)."""
    config = InitiationConfig(v_max=50.0, history=H, capture_scans=100)
    xy = np.random.default_rng(0).uniform(1e4, 6e4, (m, 2))
    return (
        config,
        None,
        [{"t": 0.0, "plots": [_plot(x, y) for x, y in xy.tolist()]}]
        + [{"t": 1.0 + k, "plots": [_plot(-5e5, -5e5 + 1e3 * k)]} for k in range(99)],
    )


def join_greedy(plots: np.ndarray) -> np.ndarray:
    """The baseline: row pairs sharing two or more plots by a join on plot ids (one row
    per (row, row, shared plot)), then the greedy over them in row order."""
    ai, ak = np.nonzero(plots >= 0)
    av = plots[ai, ak]
    order = np.argsort(av, kind="stable")
    bv, bi = av[order], ai[order]
    lo, hi = np.searchsorted(bv, av, "left"), np.searchsorted(bv, av, "right")
    counts = hi - lo
    first = np.repeat(lo - np.cumsum(counts) + counts, counts)
    j = bi[first + np.arange(counts.sum())]
    p = plots.shape[0]
    pairs, shared = np.unique(np.repeat(ai, counts) * p + j, return_counts=True)
    pairs = pairs[shared >= 2]
    i, j = pairs // p, pairs % p
    i, j = i[i > j], j[i > j]  # each clash once, (later, earlier)
    keep = np.ones(p, dtype=bool)
    sort = np.lexsort((j, i))
    i, j = i[sort], j[sort]
    starts = np.flatnonzero(np.r_[True, i[1:] != i[:-1]]) if i.size else i
    for s, e in zip(starts, np.r_[starts[1:], i.size] if i.size else i, strict=True):
        keep[i[s]] = not keep[j[s:e]].any()
    return keep


def rule_table(repeats: int) -> None:
    print("| tracks (history 8) | join on plot ids, s | plot-pair keys, s | ratio |")
    print("|---:|---:|---:|---:|")
    for n in (1_000, 2_000, 4_000):
        _, state, _ = branches(n, 8)
        plots = np.array(state["tracks"]["plots"])
        plots[:, 0] = 7 * PLOT_STRIDE  # the plot every track takes at the call's scan
        plots = np.roll(plots, -1, axis=1)
        assert (join_greedy(plots) == keep_greedy(plots)).all()
        times = []
        for rule in (join_greedy, keep_greedy):
            best = np.inf
            for _ in range(repeats):
                start = time.perf_counter()
                rule(plots)
                best = min(best, time.perf_counter() - start)
            times.append(best)
        print(
            f"| {n:,} | {times[0]:.3f} | {times[1]:.3f} | {times[0] / times[1]:.0f}x |", flush=True
        )


def _call(
    client: TestClient, config: InitiationConfig, state: dict | None, scans: list[dict]
) -> tuple[float, float, dict]:
    body = json.dumps({"config": _wire(config), "state": state, "scans": scans}).encode()
    start = time.perf_counter()
    r = client.post(
        "/v1/initiation/initiate", content=body, headers={"content-type": "application/json"}
    )
    seconds = time.perf_counter() - start
    assert r.status_code == 200, r.text[:500]
    return seconds, len(body) / 2**20, r.json()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scale",
        type=float,
        default=1.0,
        help="fraction of the ceilings to build (1: at the ceilings)",
    )
    parser.add_argument("--repeats", type=int, default=2, help="best of this many (2)")
    parser.add_argument(
        "--rule-only", action="store_true", help="only the plot-reuse rule against its baseline"
    )
    args = parser.parse_args(argv)
    print(
        f"python {platform.python_version()}, numpy {np.__version__}, scipy "
        f"{scipy.__version__}, {platform.machine()}",
        file=sys.stderr,
    )
    rule_table(args.repeats)
    if args.rule_only:
        return 0
    cases = [
        ("branches", branches, MAX_HISTORY, MAX_HISTORY_CELLS // MAX_HISTORY),
        ("branches", branches, 8, MAX_STATE_TRACKS),
        ("coasting", coasting, 8, MAX_STATE_TRACKS),
        ("coasting", coasting, MAX_HISTORY, MAX_HISTORY_CELLS // MAX_HISTORY),
        ("initiators", initiators, 8, MAX_STATE_INITIATORS),
        ("both", both, 8, MAX_STATE_TRACKS - 100),  # its scans start 100 tracks
        ("stateless", stateless, 8, MAX_STATE_INITIATORS - 100),
    ]
    print(
        "\n| scenario | history | tracks | initiators | scans | body MB | seconds | tracks after |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as folder:
        settings = Settings(log_dir=Path(folder), git_commit="bench")
        with TestClient(create_app(settings)) as client:
            for name, make, H, size in cases:
                size = max(1, int(size * args.scale))
                config, state, scans = make(size, H)
                best = np.inf
                for _ in range(args.repeats):
                    seconds, mb, out = _call(client, config, state, scans)
                    best = min(best, seconds)
                tracks, waiting = (
                    (0, 0)
                    if state is None
                    else (len(state["tracks"]["id"]), len(state["initiators"]["plot"]))
                )
                print(
                    f"| {name} | {H} | {tracks:,} | {waiting:,} | {len(scans)} | {mb:.1f} | "
                    f"{best:.2f} | {len(out['tracks']):,} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
