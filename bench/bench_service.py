"""Service throughput with recording on and off, measured in one run.

Starts ``plotgate serve`` (one worker) on a loopback port, once recording and once not,
and loads each with ``wrk`` (Debian package ``wrk``: a C load generator, so the client is
not the bottleneck on a two-core machine) posting the same gate test: combined gate, 10
candidates, at 1, 10 and 50 concurrent connections. Rounds alternate off/on so drift hits
both alike; the best round of each is kept. Besides wrk's requests per second it reports
the server's CPU time per request (from /proc), the load-independent cost of recording.

    python bench/bench_service.py [--seconds 10 --connections 1,10,50 --rounds 3]
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.servers import serve  # noqa: E402 - after the sys.path line

LUA = """wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
local f = io.open("{body}", "rb"); wrk.body = f:read("*a"); f:close()
"""


def body(candidates: int) -> bytes:
    """A combined-gate test of one first mark against ``candidates`` seeded marks."""
    rng = np.random.default_rng(1)
    cov = [[200.0**2, 0.0], [0.0, 200.0**2]]
    z = rng.uniform(-2500, 2500, (candidates, 2)) + [0.0, 50_000.0]
    plots = [{"frame": "cartesian", "x": float(x), "y": float(y), "covariance": cov} for x, y in z]
    return json.dumps(
        {
            "gate": {"kind": "combined", "tau": 5.0, "v_min": 100.0, "v_max": 500.0, "P_G": 0.9},
            "first": {"frame": "cartesian", "x": 0.0, "y": 50_000.0, "covariance": cov},
            "candidates": plots,
        }
    ).encode()


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _ms(text: str) -> float:
    match = re.fullmatch(r"([\d.]+)(us|ms|s|m)", text)
    if match is None:
        raise ValueError(f"unexpected wrk latency {text!r}")
    value, unit = match.groups()
    return float(value) * {"us": 1e-3, "ms": 1.0, "s": 1e3, "m": 6e4}[unit]


def _wrk(url: str, script: Path, seconds: int, connections: int) -> dict[str, float]:
    out = subprocess.run(
        [
            "wrk",
            "-t1",
            f"-c{connections}",
            f"-d{seconds}s",
            "--latency",
            "-s",
            str(script),
            url + "/v1/gates/test",
        ],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "Non-2xx" not in out and "Socket errors" not in out, out
    return {
        "requests": float(re.search(r"(\d+) requests in", out).group(1)),
        "rate": float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1)),
        "p50": _ms(re.search(r"^\s*50%\s+(\S+)", out, re.M).group(1)),
        "p99": _ms(re.search(r"^\s*99%\s+(\S+)", out, re.M).group(1)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=int, default=10)
    parser.add_argument(
        "--connections", default="1,10,50", help="comma-separated concurrent clients (1,10,50)"
    )
    parser.add_argument("--candidates", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if not shutil.which("wrk"):
        sys.exit("wrk not found: apt-get install wrk")
    levels = [int(c) for c in args.connections.split(",")]
    best: dict[tuple[int, str], dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        payload = Path(tmp) / "body.json"
        payload.write_bytes(body(args.candidates))
        script = Path(tmp) / "post.lua"
        script.write_text(LUA.format(body=payload))
        for _ in range(args.rounds):
            for mode, flags in (("off", ["--no-record"]), ("on", [])):
                with serve(Path(tmp) / mode, *flags) as (proc, url):
                    _wrk(url, script, 2, max(levels))  # warm-up
                    for c in levels:
                        cpu = _cpu_seconds(proc.pid)
                        run = _wrk(url, script, args.seconds, c)
                        run["cpu_ms"] = (_cpu_seconds(proc.pid) - cpu) / run["requests"] * 1e3
                        if (c, mode) not in best or run["rate"] > best[c, mode]["rate"]:
                            best[c, mode] = run
        size = sum(f.stat().st_size for f in (Path(tmp) / "on").glob("*.mcap"))
        print(
            f"wrk -t1 -d{args.seconds}s, best of {args.rounds} rounds, "
            f"{args.candidates} candidates per request ({payload.stat().st_size} bytes)"
        )
    print("| clients | recording | requests/s | p50 ms | p99 ms | server CPU ms/request |")
    print("|---:|---|---:|---:|---:|---:|")
    for c in levels:
        for mode in ("off", "on"):
            r = best[c, mode]
            print(
                f"| {c} | {mode} | {r['rate']:,.0f} | {r['p50']:.2f} | {r['p99']:.2f} | "
                f"{r['cpu_ms']:.3f} |"
            )
    for c in levels:
        ratio = best[c, "on"]["rate"] / best[c, "off"]["rate"]
        print(f"{c} clients: throughput on/off {ratio:.3f} (recording costs {1 - ratio:.1%})")
    print(f"recordings written: {size / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
