"""Replay recorded sessions against this build (or a live server) and report what changed.

Every recorded request with a recorded response is run again: in-process through the
operation registry by default, or over HTTP against ``server``. Results are compared
field by field, floats with ``numpy.isclose(rtol, atol)``; a recorded error must fail
the same way again (same status, problem type and offending fields). Requests a killed
server never answered are counted, not compared.
"""

import contextlib
import json
import time
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from tqdm import tqdm

from clients.recordings import Exchange, read_recording, recording_files
from service.schemas import ENDPOINTS

__all__ = ["Change", "ReplayReport", "diff", "replay"]

Runner = Callable[[Exchange], tuple[int, Any]]
_MISSING = "<missing>"


@dataclass
class Change:
    """One exchange whose new answer differs from the recorded one."""

    file: str
    operation: str
    request_id: str
    field: str
    recorded: Any
    replayed: Any


@dataclass
class ReplayReport:
    """Counts per file and every change found."""

    files: list[dict[str, Any]] = field(default_factory=list)
    compared: int = 0
    unchanged: int = 0
    unanswered: int = 0
    changes: list[Change] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.changes

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "ok": self.ok}

    def text(self) -> str:
        lines = []
        for f in self.files:
            state = "complete" if f["complete"] else (
                f"truncated ({f['stopped_by']}), recovered {f['messages']} messages"
            )
            lines.append(f"{f['path']}: {f['exchanges']} exchanges, {state}")
        for c in self.changes[:50]:
            lines.append(
                f"CHANGED {c.operation} {c.request_id} {c.field}: "
                f"recorded {_short(c.recorded)}, replayed {_short(c.replayed)}"
            )
        if len(self.changes) > 50:
            lines.append(f"... and {len(self.changes) - 50} more changes")
        changed = len({(c.file, c.request_id) for c in self.changes})
        lines.append(
            f"{self.compared} compared: {self.unchanged} unchanged, {changed} changed, "
            f"{self.unanswered} never answered"
        )
        return "\n".join(lines)


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def diff(
    a: Any, b: Any, rtol: float, atol: float, path: str = ""
) -> Iterator[tuple[str, Any, Any]]:
    """Yield (field path, recorded, replayed) for every difference between two JSON trees."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(a.keys() | b.keys()):
            sub = f"{path}.{key}" if path else key
            if key not in a or key not in b:
                yield sub, a.get(key, _MISSING), b.get(key, _MISSING)
            else:
                yield from diff(a[key], b[key], rtol, atol, sub)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            yield f"{path}.length", len(a), len(b)
        elif a and all(map(_is_number, a)) and all(map(_is_number, b)):
            close = np.isclose(np.asarray(a, float), np.asarray(b, float), rtol, atol)
            for i in np.flatnonzero(~close)[:10]:
                yield f"{path}[{i}]", a[i], b[i]
        else:
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                yield from diff(x, y, rtol, atol, f"{path}[{i}]")
    elif _is_number(a) and _is_number(b):
        if not np.isclose(a, b, rtol, atol):
            yield path, a, b
    elif a != b:
        yield path, a, b


def _failure(status: int, problem: dict[str, Any]) -> dict[str, Any]:
    """What must stay the same when a request fails again."""
    return {
        "status": status,
        "type": problem.get("type"),
        "fields": sorted(e.get("field") for e in problem.get("errors", [])),
    }


def in_process() -> Runner:
    """Run exchanges through this build's registry, as the server would."""
    from service.registry import OPERATIONS, execute

    def run(exchange: Exchange) -> tuple[int, Any]:
        outcome = execute(OPERATIONS[exchange.operation], exchange.body, exchange.request_id)
        return outcome.status, outcome.json()

    return run


def over_http(http: httpx.Client) -> Runner:
    """Send exchanges to a live server through ``http`` (its base URL is the server)."""

    def run(exchange: Exchange) -> tuple[int, Any]:
        response = http.post(
            ENDPOINTS[exchange.operation].path,
            content=exchange.body,
            headers={"content-type": "application/json", "x-request-id": exchange.request_id},
        )
        return response.status_code, response.json()

    return run


def replay(
    path: Path,
    *,
    server: str | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    out: Path | None = None,
    progress: bool | None = None,
) -> ReplayReport:
    """Replay every file at ``path`` (a file or a folder) and compare.

    Parameters
    ----------
    server : base URL of a live server; None runs in-process.
    rtol, atol : float tolerances of the comparison.
    out : write the replayed session (recorded requests, new responses) to this MCAP file.
    progress : show a progress bar; None shows it only on a terminal.
    """
    report = ReplayReport()
    quiet = None if progress is None else not progress
    with contextlib.ExitStack() as resources:
        if server:
            run = over_http(resources.enter_context(httpx.Client(base_url=server, timeout=60)))
        else:
            run = in_process()
        writer = resources.enter_context(_SessionWriter(out, path)) if out else None
        for file in recording_files(path):
            rec = read_recording(file)
            report.files.append({
                "path": str(file), "exchanges": len(rec.exchanges), "complete": rec.complete,
                "stopped_by": rec.stopped_by, "messages": rec.messages,
            })
            for exchange in tqdm(rec.exchanges, desc=file.name, unit="req", disable=quiet):
                if exchange.response is None:
                    report.unanswered += 1
                    continue
                started = time.perf_counter()
                status, answer = run(exchange)
                if writer is not None:
                    writer(exchange, status, answer, time.perf_counter() - started)
                _compare(report, str(file), exchange, status, answer, rtol, atol)
    return report


def _compare(report: ReplayReport, file: str, exchange: Exchange, status: int, answer: Any,
             rtol: float, atol: float) -> None:
    recorded = exchange.response or {}
    if recorded.get("status", 0) < 400 and status < 400:
        old, new = recorded.get("result"), answer
    else:
        old = _failure(recorded.get("status", 0), recorded.get("error") or {})
        new = _failure(status, answer if status >= 400 else {})
    changes = [
        Change(file, exchange.operation, exchange.request_id, where or "result", a, b)
        for where, a, b in diff(old, new, rtol, atol)
    ]
    report.compared += 1
    report.changes.extend(changes)
    report.unchanged += not changes


class _SessionWriter:
    """Writes the replayed session (recorded requests, new answers) to one MCAP file."""

    def __init__(self, out: Path, source: Path) -> None:
        from service.provenance import VERSION
        from service.recorder import Recorder
        from service.registry import OPERATIONS

        out = Path(out)
        metadata = {"plotgate_version": VERSION, "replayed_from": str(source)}
        self._recorder = Recorder(
            out.parent, OPERATIONS.values(), file_name=out.name, metadata=metadata
        ).start()

    def __call__(self, exchange: Exchange, status: int, answer: Any, duration_s: float) -> None:
        from service.recorder import request_record, response_record

        op, rid = exchange.operation, exchange.request_id
        written = self._recorder.request(op, request_record(rid, op, exchange.body))
        content = json.dumps(answer).encode()
        self._recorder.response(written, response_record(rid, op, status, duration_s, content))
        self._recorder.flush()

    def __enter__(self) -> "_SessionWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self._recorder.close()
