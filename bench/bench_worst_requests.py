"""The slowest and largest request each operation accepts, in a fresh process.

For each of the registry's operations, the requests at the bounds the server accepts by
default (the schema's bounds and the default caps on work sizes, ``Endpoint.caps``),
along every dimension that drives its time or its memory: the most candidates, the
largest matrix, the most Monte Carlo runs x samples, the densest clutter initiation still
takes, the most eccentric error ellipse and the widest gate of every costly gate kind...
Where a cap bounds a product or a weighted estimate, the largest accepted value along
each dimension is found by bisection against the caps themselves (:func:`_largest`), so a
rerun after a cap changes measures the new bound. Each request runs in its own Python
process, through the registry exactly as the server runs it (``parse`` then ``run`` with
the caps in force, after one small request of the same operation, as a server that has
answered before), and reports its status, wall time, CPU time (what a shared machine
inflates least) and peak RSS (``ru_maxrss``: the whole process, imports and parsing
included). The server promises every accepted row
under ``TIME_BUDGET_S`` (10 s on one core) and ``MEMORY_BUDGET_MIB``; the last table
names each operation's slowest accepted request.

    python bench/bench_worst_requests.py [--only OPERATION ...] [--no-limits]
    python bench/bench_worst_requests.py --quick   # every body built, gates.test's measured

A full run (every operation, the caps in force) ends with the ``SUMMARY`` lines of the front
table (bench/README.md): the slowest accepted request's CPU time and the largest one's peak
RSS against the budgets.

``--no-limits`` runs the same requests without the caps (the schema's bounds alone): on a
build without default caps, or to see what a cap saves. A request the caps refuse shows its
status (422), its time and memory: the refusal's cost. To re-derive a cap after core gets
faster: raise it (``PLOTGATE_LIMITS``, which this script applies too), rerun the
operation with ``--only``, and keep the largest value whose slowest row stays under 10 s.
"""

import argparse
import json
import math
import resource
import subprocess
import sys
import tempfile
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS, over_caps, parse
from plotgate.service.schemas import MEMORY_BUDGET_MIB, TIME_BUDGET_S
from plotgate.service.table import ENDPOINTS

Body = dict[str, Any]
Candidate = Callable[[], tuple[str, Body]]

ROOT = Path(__file__).resolve().parent.parent

_CHILD = """
import json, resource, sys, time
from plotgate.service.config import Settings
from plotgate.service.registry import OPERATIONS, execute, failed, parse, run
name, path, no_limits = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
op = OPERATIONS[name]
caps = None if no_limits else Settings(record=False).limits.get(name, {})
execute(op, json.dumps(op.endpoint.example).encode())  # as a server that has answered before
body = open(path, "rb").read()
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start, cpu = time.perf_counter(), time.process_time()
parsed = parse(op, body)
outcome = failed(op, parsed.problem, None) if parsed.request is None else run(
    op, parsed.request, None, caps)
seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
detail = "" if outcome.ok else outcome.json().get("detail", "")
print(json.dumps({"status": outcome.status, "seconds": seconds, "cpu": cpu, "base_kib": base,
    "peak_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
    "answer_bytes": len(outcome.content), "detail": detail[:160]}))
"""


@lru_cache
def _caps(name: str) -> dict[str, int]:
    """The caps a server applies to an operation: the defaults with PLOTGATE_LIMITS over
    them."""
    return dict(Settings(record=False).limits.get(name, {}))


def _cap(name: str, size: str, bound: int) -> int:
    """The largest value of a work size the server accepts: its cap, else ``bound`` (the
    schema's)."""
    return min(bound, _caps(name).get(size, bound))


def _accepted(name: str, body: Body) -> bool:
    """Whether the server takes ``body``: valid, and within the caps (no cluster)."""
    op = OPERATIONS[name]
    parsed = parse(op, json.dumps(body).encode())
    return parsed.request is not None and over_caps(op, parsed.request, _caps(name)) is None


def _largest(name: str, build: Callable[[int], Body], lo: int, hi: int) -> int:
    """The largest n in [lo, hi] whose ``build(n)`` the server accepts, by bisection (the
    work sizes grow with n); ``lo`` when none is."""
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if _accepted(name, build(mid)):
            lo = mid
        else:
            hi = mid - 1
    return lo


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


GATES: dict[str, Body] = {
    "ring": {"kind": "ring", "v_min": 0.0},
    "combined": {"kind": "combined", "v_min": 0.0},
    "expanded": {"kind": "expanded"},
    "first_association": {"kind": "first_association"},
}
"""The gate kinds whose unconditional probability costs most (bench/HISTORY.md)."""

PRIORS: dict[str, tuple[float, float, str, float]] = {
    "paper's prior": (5.0, 100.0, "area", 500.0),
    "10 km prior": (1000.0, 0.0, "speed", 10_000.0),
}
"""tau, v_min, prior kind, v_max: the paper's ring of 0.5-2.5 km, and a 10 km disc (a prior
ring far wider than B costs more grading levels)."""


def _unconditional(name: str, kind: str, prior: str) -> Candidate:
    """The operation's example with ``kind``'s gate over ``prior``, sigma_r cut until B's
    axis ratio reaches the cap (default: 30, the seconds of bench/HISTORY.md's axis-ratio
    table, when no cap is set)."""

    def build() -> tuple[str, Body]:
        body = ENDPOINTS[name].example
        tau, v_min, prior_kind, v_max = PRIORS[prior]
        body["tau"] = tau
        body["prior"] = {"kind": prior_kind, "v_min": v_min, "v_max": v_max}
        body["gate"] = {**GATES[kind], "v_max": v_max}
        if "v_min" in GATES[kind]:
            body["gate"]["v_min"] = v_min
        ratio = _cap(name, "mark.axis_ratio", 30)
        mark = body["mark"]
        cross = mark["r"] * math.radians(mark["sigma_az_deg"])  # m, across the line of sight
        mark["sigma_r"] = cross / ratio * (1 + 1e-9)  # the ratio is rounded up
        return f"{kind}, {prior}, axis ratio {ratio}", body

    return build


def _conditional_curve() -> tuple[str, Body]:
    """The most points of a conditional curve (a known velocity per speed)."""
    name = "gates.probability_curve"
    body = ENDPOINTS[name].example
    n = _cap(name, "values", 1000)  # MAX_CURVE_POINTS
    body["values"] = [100.0 + 400.0 * i / (n - 1) for i in range(n)]
    return f"{n} conditional speeds", body


def _unconditional_curve(kind: str, prior: str) -> Candidate:
    """The most points of an unconditional curve against range with ``kind``'s gate, from
    10 km out to the range where B's axis ratio reaches the cap (200 m, 0.5 deg)."""
    name = "gates.probability_curve"

    def body_of(n: int) -> Body:
        _, body = _unconditional("gates.probability", kind, prior)()
        ratio = _cap(name, "mark.axis_ratio", 30)
        far = ratio * 200.0 / math.radians(0.5) * (1 - 1e-9)
        body["mark"]["sigma_r"] = 200.0
        values = [10_000.0 + (far - 10_000.0) * i / max(n - 1, 1) for i in range(n)]
        return {**body, "against": "range", "values": values}

    def build() -> tuple[str, Body]:
        n = _largest(name, body_of, 1, 100)  # MAX_UNCONDITIONAL_POINTS
        return f"{n} unconditional ranges, {kind}, {prior}", body_of(n)

    return build


def _design(kind: str, capture: float) -> Candidate:
    def build() -> tuple[str, Body]:
        _, body = _unconditional("gates.design", "ring", "paper's prior")()
        body["gate"] = {"kind": kind, "v_max": 500.0}
        body["prior"] = ENDPOINTS["gates.design"].example["prior"] | {"v_max": 500.0}
        body["capture"] = capture
        ratio = _cap("gates.design", "mark.axis_ratio", 30)
        return f"{kind}, capture {capture}, axis ratio {ratio}", body

    return build


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


def _study(samples: int, receivers: int, tracks: bool) -> Candidate:
    """The most runs a study of ``samples`` x ``receivers`` takes, with or without tracks."""

    def body_of(runs: int) -> Body:
        body = ENDPOINTS["solves.study"].example
        body.update(
            receivers=[{"position": rx} for rx in _ring(receivers)],
            sample_times=[float(i) for i in range(samples)],
            runs=runs,
            tracks=tracks,
        )
        return body

    def build() -> tuple[str, Body]:
        runs = _largest("solves.study", body_of, 1, 10_000)  # MAX_STUDY_RUNS
        label = "tracks" if tracks else "no tracks"
        return f"{runs} runs x {samples} samples x {receivers} pairs, {label}", body_of(runs)

    return build


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


SCORE = json.loads((ROOT / "docs/examples/score_initiation.json").read_text())
"""The README's score configuration (Mu et al.'s scenario, bench/HISTORY.md)."""


def _evaluation(
    label: str, along: str, scenario: Body, config: Body | None = None, sweep: Body | None = None
) -> Candidate:
    """The evaluation of ``scenario`` (under ``config``, ``sweep``) with the most ``runs`` or
    ``scans`` (``along``) the caps take, the other one 1 (runs) or the scenario's (scans)."""
    bound = {"runs": 10_000, "scans": 1000}[along]

    def body_of(n: int) -> Body:
        body: Body = {"scenario": dict(scenario), "runs": 1, "seed": 1}
        if along == "runs":
            body["runs"] = n
        else:
            body["scenario"]["scans"] = n
        if config is not None:
            body["config"] = config
        if sweep is not None:
            body["sweep"] = sweep
        return body

    def build() -> tuple[str, Body]:
        n = _largest("initiation.evaluate", body_of, 1, bound)
        return f"{label}: {n} {along}", body_of(n)

    return build


_EVALUATIONS = [
    _evaluation("clutter 250, score config", "runs", {"clutter": 250.0}, SCORE),
    _evaluation("clutter 250, polar", "runs", {"clutter": 250.0}, {"mode": "polar"}),
    _evaluation(
        "clutter 250, sweep of 50 gate_P_G",
        "runs",
        {"clutter": 250.0},
        sweep={"parameter": "gate_P_G", "values": [0.5 + 0.009 * i for i in range(50)]},
    ),
    _evaluation(
        "one plot a run",
        "runs",
        {
            "scans": 1,
            "clutter": 0.0,
            "targets": [{"position": [5000.0, 5000.0], "velocity": [10.0, 0.0]}],
        },
    ),  # fmt: skip
    _evaluation("clutter 2000, 40 scans", "runs", {"clutter": 2000.0, "scans": 40}),
    _evaluation("1 run, clutter 2000 (0.07 a gate)", "scans", {"clutter": 2000.0}),
    _evaluation("1 run, clutter 5000 (0.17 a gate)", "scans", {"clutter": 5000.0}),
    _evaluation("1 run, clutter 10,000 (0.35 a gate)", "scans", {"clutter": 10_000.0}),
    _evaluation("1 run, polar, clutter 10,000", "scans", {"clutter": 10_000.0}, {"mode": "polar"}),
]
"""Along every dimension of the evaluation's work (EvaluateRequest.work): runs of a sparse
scenario, polar mode, a sweep, runs that are all overhead, scans of dense clutter."""


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


def _identification_simulate(n: int, m: int) -> Candidate:
    def build() -> tuple[str, Body]:
        draws = _cap("identification.simulate", "runs x (n + m)", 50_000_000)
        runs = min(10_000_000, draws // (n + m))  # MAX_SIMULATED_SAMPLES
        return f"{runs} runs x ({n} + {m})", {"n": n, "m": m, "runs": runs, "seed": 1}

    return build


WORST: list[tuple[str, Candidate]] = [
    ("gates.test", _gates_test),
    ("gates.pairs", _gates_pairs),
    *(
        (name, _unconditional(name, kind, prior))
        for name in ("gates.probability", "gates.analysis")
        for kind in GATES
        for prior in PRIORS
    ),
    ("gates.probability_curve", _conditional_curve),
    *(
        ("gates.probability_curve", _unconditional_curve(kind, prior))
        for kind in ("expanded", "first_association")
        for prior in PRIORS
    ),
    *(
        ("gates.design", _design(kind, capture))
        for kind in ("expanded", "combined")
        for capture in (0.9, 0.98)
    ),
    ("solves.position", _position),
    ("solves.trajectory", _trajectory),
    ("solves.crlb", _crlb),
    ("solves.noise", _noise),
    ("solves.study", _study(200, 3, tracks=False)),
    ("solves.study", _study(200, 3, tracks=True)),
    ("solves.study", _study(1000, 3, tracks=True)),
    ("solves.study", _study(200, 64, tracks=False)),
    ("initiation.initiate", _initiate),
    ("initiation.simulate", _simulate),
    *(("initiation.evaluate", candidate) for candidate in _EVALUATIONS),
    ("identification.pair", _pair),
    ("identification.picture", _picture),
    ("identification.picture", _ragged_picture),
    ("identification.simulate", _identification_simulate(50, 5)),
    ("identification.simulate", _identification_simulate(1000, 1000)),
]
"""Each operation's candidates for its slowest or largest request, one per dimension that
drives its time or memory."""


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


def _row(name: str, label: str, r: dict[str, Any]) -> str:
    size = f"{r['body_bytes'] / 2**20:.1f} MB" if "body_bytes" in r else ""
    wall = f"{r['seconds']:.1f}" if "seconds" in r else ""
    cpu = f"{r['cpu']:.1f}" if "cpu" in r else ""
    peak = f"{r['peak_kib'] / 1024:.0f}" if "peak_kib" in r else ""
    return f"| {name} | {label} | {size} | {r['status']} | {wall} | {cpu} | {peak} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="*", help="operations to run (default: all)")
    parser.add_argument("--no-limits", action="store_true", help="run without the caps")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="build every request (the bisections against the caps) but run only gates.test's",
    )
    args = parser.parse_args()
    header = (
        "| operation | request | body | status | wall s | CPU s | peak RSS MiB |\n"
        + "|---|---|"
        + ("---:|" * 5)
    )
    print(header)
    slowest: dict[str, tuple[float, str]] = {}
    accepted: list[tuple[str, dict[str, Any]]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, build in WORST:
            if args.only and name not in args.only:
                continue
            label, body = build()
            if args.quick and name != WORST[0][0]:
                print(f"| {name} | {label} | built, not run (--quick) |", flush=True)
                continue
            r = _measure(name, body, args.no_limits, Path(tmp))
            row = _row(name, label, r)
            print(row, flush=True)
            if r.get("detail"):
                print(f"<!-- {name}: {r['detail']} -->", file=sys.stderr, flush=True)
            if r["status"] == 200 and r["seconds"] > slowest.get(name, (-1.0, ""))[0]:
                slowest[name] = (r["seconds"], row)
            if r["status"] == 200:
                accepted.append((f"{name}, {label}", r))
    print(
        f"\nThe slowest accepted request of each operation (budget: {TIME_BUDGET_S:g} s, "
        f"{MEMORY_BUDGET_MIB} MiB):\n"
    )
    print(header)
    for _, row in slowest.values():
        print(row)
    if accepted:
        print()
        report(accepted, judged=not (args.quick or args.only or args.no_limits))


def report(accepted: list[tuple[str, dict[str, Any]]], judged: bool) -> None:
    """The SUMMARY lines: the most CPU and the most memory of the accepted requests; the
    budgets judged only for a full run with the caps in force."""
    workload = f"the {len(accepted)} accepted worst requests of the operations"
    cpu_label, cpu = max(accepted, key=lambda a: a[1]["cpu"])
    mib_label, mib = max(accepted, key=lambda a: a[1]["peak_kib"])
    summary(
        "worst_requests.cpu",
        workload + ", each in a fresh process: the most CPU",
        "—",
        f"{cpu['cpu']:.1f} s ({cpu_label})",
        f"<= {TIME_BUDGET_S:g} s",
        cpu["cpu"] <= TIME_BUDGET_S if judged else None,
    )
    summary(
        "worst_requests.memory",
        workload + ": the highest peak RSS",
        "—",
        f"{mib['peak_kib'] / 1024:.0f} MiB ({mib_label})",
        f"<= {MEMORY_BUDGET_MIB} MiB",
        mib["peak_kib"] / 1024 <= MEMORY_BUDGET_MIB if judged else None,
    )


def summary(row: str, workload: str, peer: str, measured: str, aim: str, met: bool | None) -> None:
    """One front-table row of bench/README.md, as bench/run_all.py reads it."""
    fields = {"workload": workload, "peer": peer, "measured": measured, "aim": aim, "met": met}
    print("SUMMARY " + json.dumps({"row": row, **fields}))


if __name__ == "__main__":
    main()
