"""Recordings for the replay gate's tests: ``gates.test`` exchanges as this build answers
them, with one answer's number moved by a chosen relative amount (a change a tolerance
rule may or may not pass)."""

import json
from pathlib import Path

from plotgate.service.recording import request_record, response_record
from plotgate.service.registry import OPERATIONS, execute
from tests.support.recorded import OP, write_files
from tests.support.requests import GOOD

T0, MS = 1_700_000_000 * 10**9, 10**6


def moved_recording(folder: Path, exchanges: int = 4, moved: float = 0.0) -> Path:
    """``exchanges`` of ``gates.test``, the last one's ``statistic[1]`` recorded moved by
    ``moved`` relative (0: a clean recording of this build's answers)."""
    body = json.dumps(GOOD).encode()
    answer = execute(OPERATIONS[OP], body)
    events = []
    for i in range(exchanges):
        result = json.loads(answer.content)
        if moved and i == exchanges - 1:
            result["statistic"][1] *= 1.0 + moved
        t = T0 + i * 10 * MS
        events.append((t, "request", request_record(f"r{i}", OP, body)))
        content = json.dumps(result).encode()
        events.append((t + MS, "response", response_record(f"r{i}", OP, 200, 0.002, content)))
    write_files(folder, events, set())
    return folder


def rules_file(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
