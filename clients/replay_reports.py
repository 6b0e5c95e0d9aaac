"""Replay's report in the formats CI reads and people look at: JUnit XML (``--junit``), a
Markdown job summary (``--summary-md``) and one self-contained HTML page (``--html``).

Each is made from a :class:`~plotgate.clients.replay.ReplayReport` alone, so the serial and
the fleet replay write the same bytes. An exchange compared is a JUnit test case named by
its request id and time, in a test suite per operation; a changed exchange is a failure
whose message names the field, the recorded and replayed values and the rule that judged
it. The HTML page has no script and fetches nothing: its plot is inline SVG.
"""

import html
import math
import socket
from collections import defaultdict
from datetime import UTC, datetime
from pathlib import Path
from xml.etree import ElementTree as ET

from plotgate.clients.pairing import iso_time
from plotgate.clients.replay import Change, ReplayReport
from plotgate.files import write_bytes

__all__ = ["html_page", "junit_xml", "summary_markdown", "write_report_file"]

FIRST_DIFFERENCES = 20
"""Differences listed in the Markdown summary."""


def write_report_file(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` whole or not at all, through the project's one safe
    writer (:func:`plotgate.files.write_bytes`: a temporary beside it, renamed over it; a
    target that is a link, FIFO, device or folder is refused with
    :class:`~plotgate.files.NotRegularTarget`, never followed or replaced)."""
    write_bytes(path, text.encode())


def _by_exchange(report: ReplayReport) -> dict[tuple[str, str, str], list[Change]]:
    found: dict[tuple[str, str, str], list[Change]] = defaultdict(list)
    for c in report.changes:
        found[(c.operation, c.request_id, c.time)].append(c)
    return found


def _describe(c: Change) -> str:
    return (
        f"{c.field}: recorded {_short(c.recorded)}, replayed {_short(c.replayed)} "
        f"(judged by {c.rule})"
    )


def _short(value: object) -> str:
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= 80 else text[:77] + "..."


def junit_xml(report: ReplayReport) -> str:
    """JUnit XML (the Ant/JUnitReport form Jenkins, GitLab and GitHub's reporters read):
    ``testsuites``, a ``testsuite`` per operation, a ``testcase`` per exchange compared."""
    changes = _by_exchange(report)
    root = ET.Element("testsuites")
    stamp = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%S")
    host = socket.gethostname() or "localhost"
    by_operation: dict[str, list[tuple[str, str, bool]]] = defaultdict(list)
    for operation, rid, log_time, changed in report.cases or ():
        by_operation[operation].append((rid, iso_time(log_time) or "", changed))
    for number, (operation, cases) in enumerate(sorted(by_operation.items())):
        suite = ET.SubElement(
            root,
            "testsuite",
            name=operation,
            package="plotgate.replay",
            id=str(number),
            timestamp=stamp,
            hostname=host,
            tests=str(len(cases)),
            failures=str(sum(changed for _, _, changed in cases)),
            errors="0",
            skipped="0",
            time="0",
        )
        ET.SubElement(suite, "properties")
        for rid, when, changed in cases:
            case = ET.SubElement(
                suite, "testcase", name=f"{rid} at {when}", classname=operation, time="0"
            )
            if changed:
                found = changes.get((operation, rid, when), [])
                lines = [_describe(c) for c in found] or [
                    f"changed (past the first {len(report.changes)} differences listed)"
                ]
                failure = ET.SubElement(case, "failure", message=lines[0], type="changed")
                failure.text = "\n".join(lines)
        ET.SubElement(suite, "system-out").text = ""
        ET.SubElement(suite, "system-err").text = ""
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def _per_operation(report: ReplayReport) -> dict[str, list[int]]:
    return {
        operation: [row["compared"], row["changed"]]
        for operation, row in sorted(report.operations.items())
    }


def _cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def summary_markdown(report: ReplayReport) -> str:
    """A Markdown job summary: the verdict, counts per operation, the first differences and
    the latency table (when the replay measured one)."""
    verdict = "unchanged" if report.ok and report.compared else "CHANGED" if report.changed else ""
    lines = [
        f"## plotgate replay: {verdict or 'nothing compared'}",
        "",
        f"{report.exchanges} exchanges, {report.compared} compared: {report.unchanged} "
        f"unchanged, {report.changed} changed.",
        "",
        "| operation | compared | unchanged | changed |",
        "|---|---:|---:|---:|",
    ]
    for operation, (compared, changed) in _per_operation(report).items():
        lines.append(f"| {operation} | {compared} | {compared - changed} | {changed} |")
    if report.changes:
        lines += [
            "",
            "### First differences",
            "",
            "| operation | request id | field | recorded | replayed | rule |",
            "|---|---|---|---|---|---|",
        ]
        for c in report.changes[:FIRST_DIFFERENCES]:
            cells = (c.operation, c.request_id, c.field, c.recorded, c.replayed, c.rule)
            lines.append("| " + " | ".join(_cell(_short(x)) for x in cells) + " |")
    lines += _latency_markdown(report)
    return "\n".join(lines) + "\n"


def _latency_markdown(report: ReplayReport) -> list[str]:
    if not report.latency:
        return []
    lines = [
        "",
        "### Latency (seconds)",
        "",
        "| operation | recorded p50 | replayed p50 | recorded p99 | replayed p99 |",
        "|---|---:|---:|---:|---:|",
    ]
    for operation, row in sorted(report.latency.items()):
        keys = ("recorded_p50", "replayed_p50", "recorded_p99", "replayed_p99")
        values = [row[k] for k in keys]
        lines.append(f"| {operation} | " + " | ".join(f"{v:.4g}" for v in values) + " |")
    return lines


def _relative(c: Change) -> float | None:
    """|recorded - replayed| / |replayed| of a numeric change (None for anything else)."""
    a, b = c.recorded, c.replayed
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, int | float):
        return None
    if not isinstance(b, int | float):
        return None
    try:
        gap = abs(float(a) - float(b))
    except OverflowError:
        return None
    scale = abs(float(b)) or 1.0
    return gap / scale if math.isfinite(gap) else None


def _svg(changes: list[Change]) -> str:
    """Relative differences of the numeric changes, log10 on the vertical axis."""
    points = [(i, r) for i, c in enumerate(changes) if (r := _relative(c)) is not None]
    width, height, pad = 640, 240, 40
    parts = [
        f'<svg width="{width}" height="{height}" role="img" aria-label="relative differences">',
        f'<rect x="{pad}" y="10" width="{width - pad - 10}" height="{height - pad - 10}" '
        'fill="none" stroke="#888"/>',
    ]
    if points:
        logs = [math.log10(max(r, 1e-300)) for _, r in points]
        low, high = math.floor(min(logs)), math.ceil(max(logs)) + (min(logs) == max(logs))
        span = max(len(changes) - 1, 1)
        for (i, _), y in zip(points, logs, strict=True):
            cx = pad + (width - pad - 20) * i / span + 5
            cy = 10 + (height - pad - 10) * (high - y) / (high - low)
            parts.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="3" fill="#c0392b"/>')
        parts.append(f'<text x="2" y="20" font-size="11">1e{high}</text>')
        parts.append(f'<text x="2" y="{height - pad}" font-size="11">1e{low}</text>')
    parts.append(
        f'<text x="{pad}" y="{height - 10}" font-size="11">difference (in report order); '
        "vertical: |recorded - replayed| / |replayed|</text></svg>"
    )
    return "".join(parts)


def html_page(report: ReplayReport) -> str:
    """One self-contained page: counts per operation, each difference with its JSON path,
    and an inline SVG plot of the relative differences (no script, nothing fetched)."""
    e = html.escape
    rows = "".join(
        f"<tr><td>{e(op)}</td><td>{n}</td><td>{n - changed}</td><td>{changed}</td></tr>"
        for op, (n, changed) in _per_operation(report).items()
    )
    diffs = "".join(
        f'<tr><td>{e(c.operation)}</td><td>{e(c.request_id)}</td><td class="path">'
        f"{e(c.field)}</td><td>{e(_short(c.recorded))}</td><td>{e(_short(c.replayed))}</td>"
        f"<td>{e(c.rule)}</td></tr>"
        for c in report.changes
    )
    verdict = "unchanged" if report.ok and report.compared else "CHANGED"
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; '
        "style-src 'unsafe-inline'\"><title>plotgate replay</title><style>"
        "body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 8px}.path{font-family:monospace}"
        "</style></head><body>"
        f"<h1>plotgate replay: {verdict}</h1>"
        f"<p>{report.exchanges} exchanges, {report.compared} compared: "
        f"{report.unchanged} unchanged, {report.changed} changed.</p>"
        "<h2>Per operation</h2><table><tr><th>operation</th><th>compared</th>"
        f"<th>unchanged</th><th>changed</th></tr>{rows}</table>"
        '<h2>Differences</h2><table id="differences"><tr><th>operation</th><th>request id</th>'
        "<th>JSON path</th><th>recorded</th><th>replayed</th><th>rule</th></tr>"
        f"{diffs}</table><h2>Relative differences</h2>{_svg(report.changes)}"
        "</body></html>\n"
    )
