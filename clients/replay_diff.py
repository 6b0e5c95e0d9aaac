"""The ``/replay/diff`` channel of ``plotgate replay --out``: a ``foxglove.Log`` per changed
exchange, stamped at its replayed request, so Foxglove shows where the answers moved.

Its message names the replayed request id and the original's, then one line per changed
field: the JSON path, the recorded and the replayed values and the rule that judged it.
The level is a warning; the Log's ``name`` is the operation. The schema and the encoding
are foxglove-sdk's (protobuf), as ``plotgate view``'s ``/log``: it is the optional extra
``plotgate[view]``, and without it the session is written without the channel (:func:`log_channel`
is None, and the replay says so in its notes).
"""

from typing import Any

from plotgate.clients.recordings import DIFF_TOPIC

__all__ = ["DIFF_TOPIC", "NO_SDK", "diff_log", "log_channel"]

NO_SDK = f"{DIFF_TOPIC} not written to --out: it needs foxglove-sdk (pip install 'plotgate[view]')"
MAX_VALUE_CHARS = 200
"""A value longer than this (a whole list, say) is cut in the Log's text."""


def log_channel() -> tuple[str, str, bytes, str] | None:
    """The channel's ``(topic, schema name, schema, encoding)`` for the recorder, or None
    without foxglove-sdk."""
    try:
        import foxglove.messages as fm
    except ImportError:
        return None
    schema = fm.Log.get_schema()
    return DIFF_TOPIC, schema.name, bytes(schema.data), schema.encoding


def _value(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= MAX_VALUE_CHARS else text[: MAX_VALUE_CHARS - 3] + "..."


def diff_log(
    log_time: int,
    operation: str,
    request_ids: tuple[str, str],
    differences: tuple[tuple[str, Any, Any, str], ...],
) -> bytes:
    """The encoded Log of one changed exchange: ``log_time`` (ns since the epoch),
    ``request_ids`` (the replayed one, its original), each difference (field, recorded,
    replayed, rule)."""
    import foxglove.messages as fm

    replayed, original = request_ids
    lines = [f"{operation} {replayed} (replay of {original}) changed:"]
    lines += [
        f"{where}: recorded {_value(a)}, replayed {_value(b)} (rule {rule!r})"
        for where, a, b, rule in differences
    ]
    stamp = fm.Timestamp(sec=log_time // 1_000_000_000, nsec=log_time % 1_000_000_000)
    message = fm.Log(
        timestamp=stamp, level=fm.LogLevel.Warning, message="\n".join(lines), name=operation
    )
    return bytes(message.encode())
