"""Summaries of recordings: each file's state and time range, and per operation the
exchanges, errors and latencies (every exchange once, paired across the files)."""

from array import array
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from plotgate.clients.recordings import Filters, Reader, file_state

__all__ = ["OperationStats", "format_inspection", "inspect"]


@dataclass
class OperationStats:
    """Counts and latency percentiles of one operation."""

    requests: int = 0
    responses: int = 0
    unanswered: int = 0
    """Requests never answered (the server stopped first)."""
    answers_without_request: int = 0
    """Answers whose request record was lost to damage."""
    replays: int = 0
    """Requests sent by ``plotgate replay`` (``replay_of`` set)."""
    errors: dict[int, int] = field(default_factory=dict)
    latency_ms: dict[str, float] = field(default_factory=dict)


def inspect(
    paths: Path | str | Iterable[Path | str], filters: Filters | None = None
) -> dict[str, Any]:
    """Per file: state (complete, open: still being written, or unfinished), time range,
    metadata and damage (or why it is skipped: empty, not MCAP); records written twice and
    conflicting records; per operation (the exchanges the filters take): counts, error
    counts by status, latency p50/p90/p99/max."""
    reader = Reader(paths, filters)
    durations: dict[str, array] = defaultdict(lambda: array("d"))
    stats: dict[str, OperationStats] = defaultdict(OperationStats)
    for ex in reader:
        s = stats[ex.operation]
        if ex.request_bytes is None:
            s.answers_without_request += 1
        else:
            s.requests += 1
            s.replays += ex.replay_of is not None
        if ex.status is None or ex.duration_s is None:
            s.unanswered += 1
            continue
        s.responses += 1
        if ex.status >= 400:
            s.errors[ex.status] = s.errors.get(ex.status, 0) + 1
        durations[ex.operation].append(ex.duration_s * 1e3)
    for op, values in durations.items():
        q = np.percentile(values, [50, 90, 99, 100])
        stats[op].latency_ms = dict(zip(("p50", "p90", "p99", "max"), map(float, q), strict=True))
    return {
        "files": [rec.summary() for rec in reader.files],
        "unreadable": reader.unreadable,
        "skipped": reader.skipped,
        "recordings": reader.recordings,
        "written_twice": reader.written_twice,
        "conflict_count": reader.conflict_count,
        "conflicts": reader.conflicts,
        "operations": {op: vars(s) for op, s in sorted(stats.items())},
    }


def format_inspection(summary: dict[str, Any]) -> str:
    """The summary as plain text: a line per file (and per damage listed), then a table."""
    lines = []
    for f in summary["files"]:
        if f["error"] or f["skipped"]:
            lines.append(f["error"] or f["skipped"])
            continue
        state = file_state(f)
        span = f"{f['first_time']} to {f['last_time']}" if f["first_time"] else "no messages"
        version = f["metadata"].get("plotgate", {}).get("plotgate_version")
        lines.append(
            f"{f['path']}: {f['messages']} messages, {span}, {state}"
            + (f", plotgate {version}" if version else "")
            + (f", {f['scene_messages']} scene messages" if f["scene_messages"] else "")
        )
        if f["damage_count"]:
            lines.append(f"  {f['damage_count']} damaged records skipped:")
            lines += [f"    {d}" for d in f["damage"]]
            if f["damage_count"] > len(f["damage"]):
                lines.append(f"    ... and {f['damage_count'] - len(f['damage'])} more")
    if summary["written_twice"]:
        lines.append(
            f"{summary['written_twice']} records written twice by the recorder, counted once"
        )
    lines += [f"CONFLICT {c}" for c in summary["conflicts"]]
    if summary["conflict_count"] > len(summary["conflicts"]):
        lines.append(f"... and {summary['conflict_count'] - len(summary['conflicts'])} more")
    lines.append(
        f"{'operation':<24}{'requests':>9}{'answered':>9}{'errors':>8}{'replays':>8}"
        f"{'p50 ms':>9}{'p90 ms':>9}{'p99 ms':>9}{'max ms':>9}"
    )
    for op, s in summary["operations"].items():
        lat = s["latency_ms"]
        cols = "".join(
            f"{lat[k]:>9.2f}" if k in lat else f"{'-':>9}" for k in ("p50", "p90", "p99", "max")
        )
        lines.append(
            f"{op:<24}{s['requests']:>9}{s['responses']:>9}"
            f"{sum(s['errors'].values()):>8}{s['replays']:>8}{cols}"
        )
        for status, count in sorted(s["errors"].items()):
            lines.append(f"{'':<24}  status {status}: {count}")
        if s["unanswered"]:
            lines.append(f"{'':<24}  never answered: {s['unanswered']}")
        if s["answers_without_request"]:
            lines.append(
                f"{'':<24}  answers whose request is lost: {s['answers_without_request']}"
            )
    return "\n".join(lines)
