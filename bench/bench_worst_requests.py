"""Peak memory and time of the largest request each operation accepts, in a fresh process.

For each of the registry's operations, one request at the bounds the server accepts by
default (the schema's bounds and the default caps on work sizes, ``Endpoint.caps``) along
the dimension whose memory grows fastest: the most candidates, the largest matrix, the most
Monte Carlo runs x samples, the densest clutter that initiation still takes... Each runs in
its own Python process, through the registry exactly as the server runs it (``parse`` then
``run`` with the caps in force), and reports its status, wall time and peak RSS
(``ru_maxrss``: the whole process, imports and parsing included). The table is what the
server promises: every row under ``MEMORY_BUDGET_MIB``.

    python bench/bench_worst_requests.py [--only OPERATION ...] [--no-limits]

``--no-limits`` runs the same requests without the caps (the schema's bounds alone): on a
build without default caps, or to see what a cap saves. A request the caps refuse shows its
status (422), its time and memory: the refusal's cost.
"""

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from plotgate.service.schemas import ENDPOINTS

Body = dict[str, Any]

_CHILD = """
import json, resource, sys, time
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS, failed, parse, run
name, path, no_limits = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
op = OPERATIONS[name]
caps = None if no_limits else Settings(record=False).limits.get(name, {})
body = open(path, "rb").read()
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
parsed = parse(op, body)
outcome = failed(op, parsed.problem, None) if parsed.request is None else run(
    op, parsed.request, None, caps)
seconds = time.perf_counter() - start
detail = "" if outcome.ok else outcome.json().get("detail", "")
print(json.dumps({"status": outcome.status, "seconds": seconds, "base_kib": base,
    "peak_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
    "answer_bytes": len(outcome.content), "detail": detail[:160]}))
"""


def _caps(name: str) -> dict[str, int]:
    """The default caps of an operation (none on a build that has none)."""
    return dict(getattr(ENDPOINTS[name], "caps", {}))


def _cap(name: str, size: str, bound: int) -> int:
    """The largest value of a work size the server accepts: its default cap, else ``bound``
    (the schema's)."""
    return min(bound, _caps(name).get(size, bound))


def _polar(r: float, az_deg: float) -> Body:
    return {"frame": "polar", "r": r, "az_deg": az_deg, "sigma_r": 200.0, "sigma_az_deg": 0.5}


def _gates_test() -> tuple[str, Body]:
    n = 100_000
    body = ENDPOINTS["gates.test"].example
    body["candidates"] = [_polar(50_000.0 + 0.1 * i, (i % 3600) / 10.0) for i in range(n)]
    return f"{n} polar candidates", body


def _gates_pairs() -> tuple[str, Body]:
    n = 100_000
    body = ENDPOINTS["gates.pairs"].example
    body["pairs"] = [
        {"first": _polar(50_000.0, i % 360), "second": _polar(51_000.0, i % 360 + 0.5)}
        for i in range(n)
    ]
    return f"{n} polar pairs", body


def _axis_ratio(name: str) -> tuple[str, Body]:
    """The example with sigma_r cut until B's axis ratio reaches the cap (default: 22, the
    seconds of bench/README.md's axis-ratio table, when no cap is set)."""
    body = ENDPOINTS[name].example
    ratio = _cap(name, "mark.axis_ratio", 22)
    mark = body["mark"]
    cross = mark["r"] * math.radians(mark["sigma_az_deg"])  # m, across the line of sight
    mark["sigma_r"] = cross / ratio
    return f"axis ratio {ratio}", body


def _curve() -> tuple[str, Body]:
    """The most points (conditional: a known velocity per speed). An unconditional curve
    holds at most 100 points, each costing what one gates.probability at its axis ratio
    costs in time, not in memory."""
    name = "gates.probability_curve"
    body = ENDPOINTS[name].example
    n = _cap(name, "values", 1000)  # MAX_CURVE_POINTS
    body["values"] = [100.0 + 400.0 * i / (n - 1) for i in range(n)]
    return f"{n} conditional speeds", body


def _ring(n: int, radius: float = 10_000.0) -> list[list[float]]:
    return [
        [radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n)]
        for k in range(n)
    ]


def _range_sums(x: list[float], receivers: list[list[float]]) -> list[float]:
    return [math.dist(x, [0.0, 0.0]) + math.dist(x, rx) for rx in receivers]


def _position() -> tuple[str, Body]:
    problems, pairs = 10_000, 10  # MAX_PROBLEMS x 10 = MAX_RANGE_SUMS
    receivers = _ring(pairs)
    rows = [
        {
            "range_sums": _range_sums([3000.0 + i % 100, 4000.0 - i // 100], receivers),
            "transmitter": [0.0, 0.0],
            "receivers": receivers,
            "sigma": 0.5,
        }
        for i in range(problems)
    ]
    return f"{problems} problems x {pairs} pairs", {"problems": rows, "method": "sum_range"}


def _track(n: int, pairs: int) -> Body:
    """A constant-velocity target seen by ``pairs`` receivers at ``n`` sample times."""
    receivers = _ring(pairs)
    times = [float(i) for i in range(n)]
    sums = [_range_sums([3000.0 + 0.05 * t, 4000.0 - 0.02 * t], receivers) for t in times]
    return {
        "sample_times": times,
        "range_sums": sums,
        "transmitter": {"position": [0.0, 0.0]},
        "receivers": [{"position": rx} for rx in receivers],
        "sigma": 0.5,
    }


def _trajectory() -> tuple[str, Body]:
    n, pairs = _cap("solves.trajectory", "sample_times", 10_000), 10
    return f"{n} samples x {pairs} pairs", _track(n, pairs)


def _crlb() -> tuple[str, Body]:
    n, pairs = _cap("solves.crlb", "targets", 10_000), 10  # MAX_RANGE_SUMS
    body = {
        "targets": [[3000.0 + i % 100, 4000.0 + i // 100] for i in range(n)],
        "transmitter": {"position": [0.0, 0.0]},
        "receivers": [{"position": rx} for rx in _ring(pairs)],
        "sigma": 0.5,
    }
    return f"{n} targets x {pairs} pairs", body


def _noise() -> tuple[str, Body]:
    """A window as long as the series at the sample_times x window cap (the square costs
    the most time: 1000 x 1000 took ten times 10,000 x 100); core fits in blocks, so the
    memory stays small at any window."""
    name = "solves.noise"
    n = min(
        _cap(name, "sample_times", 10_000), math.isqrt(_cap(name, "sample_times x window", 10**8))
    )
    window = n
    body = _track(n, 3)
    body = {k: body[k] for k in ("sample_times", "range_sums")}
    body.update(
        degree=10,
        positions=[[3000.0 + 0.05 * t, 4000.0 - 0.02 * t] for t in body["sample_times"]],
        window=window,
        smoothing_degree=10,
    )
    return f"{n} samples, window {window}, degrees 10", body


def _study() -> tuple[str, Body]:
    name = "solves.study"
    pairs, samples = 3, 200
    sums = _cap(name, "runs x sample_times x receivers", 2_400_000)  # MAX_STUDY_RANGE_SUMS
    runs = min(10_000, sums // (samples * pairs))
    body = ENDPOINTS[name].example
    body.update(sample_times=[float(i) for i in range(samples)], runs=runs, tracks=False)
    return f"{runs} runs x {samples} samples x {pairs} pairs, no tracks", body


def _study_tracks() -> tuple[str, Body]:
    """The default study's size with tracks, at MAX_STUDY_TRACK_WORK (runs x samples^2 x
    pairs): minutes of prefix solves."""
    body = ENDPOINTS["solves.study"].example
    body.update(sample_times=[float(i) for i in range(200)], runs=1000, tracks=True)
    return "1000 runs x 200 samples x 3 pairs, tracks", body


def _initiate() -> tuple[str, Body]:
    """Five scans of 19,000 plots (95,000 in all, under MAX_PLOTS), a plot every 2 km, each
    moving 25 m a scan: every initiator starts one track, and 19,000 live tracks stay under
    the state's 20,000."""
    side, n = 138, 19_000  # 138^2 > 19,000
    scans = []
    for k in range(5):
        plots = [
            {"frame": "polar", "r": 1e5 + 2000.0 * (i // side) + 25.0 * k,
             "az_deg": (i % side) * 2.0, "sigma_r": 5.0, "sigma_az_deg": 0.01}
            for i in range(n)
        ]  # fmt: skip
        scans.append({"t": float(k), "plots": plots})
    return f"5 scans x {n} plots", {"config": {"v_max": 50.0}, "state": None, "scans": scans}


def _simulate() -> tuple[str, Body]:
    scans = _cap("initiation.simulate", "scenario.scans", 100)
    clutter = 100_000 / scans - 5  # MAX_PLOTS expected plots in all, 5 targets
    body = {"scenario": {"scans": scans, "clutter": clutter}, "seed": 1}
    return f"{scans} scans x {clutter:.0f} clutter", body


def _evaluate() -> tuple[str, Body]:
    """Clutter a third of the gate rule's bound (0.35 plots per capture gate) over 400 scans
    of one run: 400,896 false tracks. Denser clutter over as many scans runs for longer
    than this bench waits (20,000 a scan over 200 scans: more than 400 s), or ends early
    in core's refusal of a tangle (28,000 a scan, 0.98 plots a gate, 40 scans: 2.6 s, 647
    MB)."""
    scans, clutter = 400, 10_000.0
    body = {"scenario": {"scans": scans, "clutter": clutter}, "runs": 1, "seed": 1}
    return f"1 run x {scans} scans x {clutter:.0f} clutter", body


def _pair() -> tuple[str, Body]:
    n = 100_000
    body = {
        "passive_bearings_deg": [10.0 + 0.001 * (i % 1000) for i in range(n)],
        "active_bearings_deg": [10.0 + 0.001 * (i % 997) for i in range(n)],
        "delta_deg": 0.5,
        "beta_max": 0.05,
        "sequential": True,
    }
    return f"{n} + {n} samples, sequential", body


def _picture() -> tuple[str, Body]:
    """A square picture at the passive x active cap, two samples a track (the shortest body
    for the largest matrix)."""
    cells = _cap("identification.picture", "passive_deg x active_deg", 10_000 * 10_000)
    side = min(10_000, math.isqrt(cells))
    body = {
        "passive_deg": [[0.01 * i, 0.01 * i + 0.1] for i in range(side)],
        "active_deg": [[0.01 * i, 0.01 * i + 0.05] for i in range(side)],
        "sigma_deg": 0.2,
    }
    return f"{side} x {side} tracks", body


def _ragged_picture() -> tuple[str, Body]:
    """Few samples in most tracks and the most in one: a padded matrix would be tracks x
    the longest track."""
    tracks = 9_000
    body = {
        "passive_deg": [[0.0, 0.1]] * (tracks - 1) + [[0.001 * i for i in range(100_000)]],
        "active_deg": [[0.0, 0.05]] * 100,
        "sigma_deg": 0.2,
    }
    return f"{tracks} passive tracks, one of 100,000 samples, x 100", body


def _identification_simulate() -> tuple[str, Body]:
    name = "identification.simulate"
    n, m = 50, 5
    draws = _cap(name, "runs x (n + m)", 50_000_000)  # MAX_SIMULATED_SAMPLES
    runs = min(10_000_000, draws // (n + m))
    return f"{runs} runs x ({n} + {m})", {"n": n, "m": m, "runs": runs, "seed": 1}


def _example(name: str) -> Callable[[], tuple[str, Body]]:
    return lambda: ("the example", ENDPOINTS[name].example)


WORST: list[tuple[str, Callable[[], tuple[str, Body]]]] = [
    ("gates.test", _gates_test),
    ("gates.pairs", _gates_pairs),
    ("gates.probability", lambda: _axis_ratio("gates.probability")),
    ("gates.probability_curve", _curve),
    ("gates.analysis", lambda: _axis_ratio("gates.analysis")),
    ("gates.design", _example("gates.design")),
    ("solves.position", _position),
    ("solves.trajectory", _trajectory),
    ("solves.crlb", _crlb),
    ("solves.noise", _noise),
    ("solves.study", _study),
    ("solves.study", _study_tracks),
    ("initiation.initiate", _initiate),
    ("initiation.simulate", _simulate),
    ("initiation.evaluate", _evaluate),
    ("identification.pair", _pair),
    ("identification.picture", _picture),
    ("identification.picture", _ragged_picture),
    ("identification.simulate", _identification_simulate),
]
"""Each operation's worst request (the picture has two: square and ragged)."""


ADDRESS_SPACE = 8 * 2**30
"""Each request's process runs under this address-space limit: a request that would take
the machine's memory fails as MemoryError (a 500, ``exit 1``) instead."""


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))


def _measure(name: str, body: Body, no_limits: bool, tmp: Path) -> dict[str, Any]:
    path = tmp / "body.json"
    path.write_bytes(json.dumps(body).encode())
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, name, str(path), "1" if no_limits else "0"],
        capture_output=True,
        text=True,
        timeout=1800,
        check=False,
        preexec_fn=_limited,
    )
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return {"status": f"exit {proc.returncode}", "detail": last[:160]}
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    result["body_bytes"] = path.stat().st_size
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="*", help="operations to run (default: all)")
    parser.add_argument("--no-limits", action="store_true", help="run without the caps")
    args = parser.parse_args()
    print("| operation | worst request | body | status | wall s | peak RSS MiB |")
    print("|---|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, build in WORST:
            if args.only and name not in args.only:
                continue
            label, body = build()
            r = _measure(name, body, args.no_limits, Path(tmp))
            size = f"{r['body_bytes'] / 2**20:.1f} MB" if "body_bytes" in r else ""
            wall = f"{r['seconds']:.1f}" if "seconds" in r else ""
            peak = f"{r['peak_kib'] / 1024:.0f}" if "peak_kib" in r else ""
            print(f"| {name} | {label} | {size} | {r['status']} | {wall} | {peak} |", flush=True)
            if r.get("detail"):
                print(f"<!-- {name}: {r['detail']} -->", file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
