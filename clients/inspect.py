"""Summaries of recordings: exchanges, errors and latency per operation."""

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from clients.recordings import read_recording, recording_files

__all__ = ["OperationStats", "inspect"]


@dataclass
class OperationStats:
    """Counts and latency percentiles of one operation."""

    requests: int = 0
    responses: int = 0
    errors: dict[int, int] = field(default_factory=dict)
    latency_ms: dict[str, float] = field(default_factory=dict)


def inspect(path: Path) -> dict[str, Any]:
    """Per-operation counts, error counts by status and latency p50/p90/p99/max, per path."""
    files = []
    durations: dict[str, list[float]] = defaultdict(list)
    stats: dict[str, OperationStats] = defaultdict(OperationStats)
    for file in recording_files(path):
        rec = read_recording(file)
        files.append({
            "path": str(file), "complete": rec.complete, "messages": rec.messages,
            "stopped_by": rec.stopped_by, "metadata": rec.metadata,
        })
        for ex in rec.exchanges:
            s = stats[ex.operation]
            s.requests += 1
            if ex.response is None:
                continue
            s.responses += 1
            status = ex.response["status"]
            if status >= 400:
                s.errors[status] = s.errors.get(status, 0) + 1
            durations[ex.operation].append(ex.response["duration_s"] * 1e3)
    for op, values in durations.items():
        q = np.percentile(values, [50, 90, 99, 100])
        stats[op].latency_ms = dict(zip(("p50", "p90", "p99", "max"), map(float, q), strict=True))
    return {"files": files, "operations": {op: vars(s) for op, s in sorted(stats.items())}}


def format_inspection(summary: dict[str, Any]) -> str:
    """The summary as a plain-text table."""
    lines = []
    for f in summary["files"]:
        state = "complete" if f["complete"] else f"truncated ({f['stopped_by']})"
        lines.append(f"{f['path']}: {f['messages']} messages, {state}")
    lines.append(
        f"{'operation':<20}{'requests':>9}{'answered':>9}{'errors':>8}"
        f"{'p50 ms':>9}{'p90 ms':>9}{'p99 ms':>9}{'max ms':>9}"
    )
    for op, s in summary["operations"].items():
        lat = s["latency_ms"]
        cols = "".join(f"{lat[k]:>9.2f}" if k in lat else f"{'-':>9}"
                       for k in ("p50", "p90", "p99", "max"))
        lines.append(
            f"{op:<20}{s['requests']:>9}{s['responses']:>9}{sum(s['errors'].values()):>8}{cols}"
        )
        for status, count in sorted(s["errors"].items()):
            lines.append(f"{'':<20}  status {status}: {count}")
    return "\n".join(lines)
