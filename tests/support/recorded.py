"""Recordings written directly, message by message, with the recorder's channels and
schemas: sessions a test composes (rotations, records written twice, conflicts) that a
running service would take long to produce."""

import json
from pathlib import Path

from mcap.writer import CompressionType, Writer

from plotgate.service.registry import OPERATIONS
from plotgate.service.schemas import request_schema, response_schema

OP = "gates.test"


def write_files(
    folder: Path,
    events: list[tuple[int, str, bytes]],
    cuts: set[int],
    chunk_size: int = 2**20,
) -> None:
    """Messages (time, kind, record) of ``gates.test`` in order into files, a new file after
    each index in ``cuts`` (a rotation), in chunks of about ``chunk_size`` bytes."""
    folder.mkdir(parents=True, exist_ok=True)
    writer = None
    for i, (t, kind, data) in enumerate(events):
        if writer is None:
            stream = open(folder / f"plotgate-{i:05d}.mcap", "wb")  # noqa: SIM115
            writer = Writer(stream, compression=CompressionType.LZ4, chunk_size=chunk_size)
            writer.start()
            channels = {}
            for k, schema, model in (
                ("request", request_schema, OPERATIONS[OP].request),
                ("response", response_schema, OPERATIONS[OP].response),
            ):
                sid = writer.register_schema(k, "jsonschema", json.dumps(schema(model)).encode())
                channels[k] = writer.register_channel(f"{OP}/{k}", "json", sid)
        writer.add_message(channels[kind], t, data, t)
        if i in cuts or i == len(events) - 1:
            writer.finish()
            stream.close()
            writer = None
