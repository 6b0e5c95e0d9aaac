"""``plotgate view``'s writer before issue 40, kept as the reference its output is held to:
mcap's ``Writer`` (zstd chunks), each exchange drawn alone from its values
(:meth:`plotgate.service.scenes.Encoded.exchange`), the originals copied record by record.

``reference(paths, out)`` writes that file; :func:`content` gives what a viewer reads of a
scene file (every message with its channel's topic, encodings and schema, in file order),
so the two writers' files compare equal whatever their chunks."""

import json
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from plotgate.clients.recordings import Filters, Reader
from plotgate.clients.view import CHUNK_BYTES, TRANSFORM_EVERY_NS
from plotgate.service.scenes import Encoded
from plotgate.service.schemas import request_schema, response_schema
from plotgate.service.table import ENDPOINTS


def reference(paths: Any, out: Path, filters: Filters | None = None) -> None:
    """The scene file of the recordings at ``paths``, written as ``plotgate view`` wrote it."""
    scenes = Encoded()
    scene_schemas = scenes.schemas()
    with open(out, "wb") as stream:
        writer = Writer(stream, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        writer.start(profile="", library="plotgate view")
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}

        def original(operation: str, kind: str) -> int:
            topic = f"{operation}/{kind}"
            if topic not in channels:
                endpoint = ENDPOINTS.get(operation)
                schema_id = 0
                if endpoint is not None:
                    schema = (
                        request_schema(endpoint.request)
                        if kind == "request"
                        else response_schema(endpoint.response)
                    )
                    schema_id = writer.register_schema(
                        f"plotgate.{operation}.{kind}", "jsonschema", json.dumps(schema).encode()
                    )
                channels[topic] = writer.register_channel(topic, "json", schema_id)
            return channels[topic]

        def scene(topic: str, name: str) -> int:
            if topic not in channels:
                if name not in schemas:
                    schemas[name] = writer.register_schema(name, *scene_schemas[name])
                channels[topic] = writer.register_channel(topic, "protobuf", schemas[name])
            return channels[topic]

        last: int | None = None
        for ex in Reader(paths, filters):
            t = ex.log_time
            if last is None or abs(t - last) >= TRANSFORM_EVERY_NS:
                for topic, name, data in scenes.transform(t):
                    writer.add_message(scene(topic, name), t, data, t)
                last = t
            if ex.request_bytes is not None:
                writer.add_message(original(ex.operation, "request"), t, ex.request_bytes, t)
            if ex.response_bytes is not None:
                answered = t + int((ex.duration_s or 0.0) * 1e9)
                channel = original(ex.operation, "response")
                writer.add_message(channel, answered, ex.response_bytes, answered)
            for topic, name, data in scenes.exchange(ex.operation, ex.request, ex.response, t):
                writer.add_message(scene(topic, name), t, data, t)
        writer.finish()


def content(path: Path) -> tuple[list[tuple[Any, ...]], Any]:
    """Every message of the scene file at ``path`` in file order (topic, encodings, schema,
    times, sequence, bytes), and its summary's statistics."""
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        messages = [
            (
                channel.topic,
                channel.message_encoding,
                channel.metadata,
                schema.name if schema else None,
                schema.encoding if schema else None,
                bytes(schema.data) if schema else None,
                message.log_time,
                message.publish_time,
                message.sequence,
                bytes(message.data),
            )
            for schema, channel, message in reader.iter_messages(log_time_order=False)
        ]
        summary = reader.get_summary()
    assert summary is not None
    return messages, summary.statistics
