"""``plotgate view``: recordings as one MCAP that Foxglove opens as a scene.

The output holds, for every exchange the filters take (read with
:class:`~plotgate.clients.recordings.Reader`, so damage, rotations, records written twice
and unfinished files are read exactly as ``inspect`` and ``cat`` read them):

- the original records on their channels ``<operation>/request`` and
  ``<operation>/response``, byte for byte, with this build's JSON schemas of them (the
  request at its recorded time; the response at that time plus its recorded duration: the
  reader pairs records and keeps the request's time);
- the scene messages of the exchange, built by the scene builder it is handed
  (:class:`plotgate.service.scenes.Encoded`; this module never imports the service, so the
  layers keep their one direction), stamped with the request's time, and the radar frame's
  transform at the first exchange and then once a second of recording time.

The file is written through :func:`plotgate.files.atomic_write`: beside ``out`` under a
hidden temporary name, moved into place when complete, so a killed or interrupted run never
leaves a half-written file under the name asked for; when no file read is a recording,
nothing is written. ``out`` may not be one of the recordings read, nor an existing link,
FIFO, device or folder (refused before anything is read).
"""

import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, Protocol

from plotgate.clients.recordings import Exchange, Filters, Reader
from plotgate.clients.scene_file import SceneFile
from plotgate.files import atomic_write, check_target
from plotgate.service.schemas import request_schema, response_schema
from plotgate.service.table import ENDPOINTS

__all__ = ["Scenes", "ViewReport", "view"]

CHUNK_BYTES = 4 * 2**20
BATCH = 64
"""Exchanges handed to the scene builder at once (it draws those of an operation together)."""
TRANSFORM_EVERY_NS = 1_000_000_000


class Scenes(Protocol):
    """What ``view`` needs of the scene builder."""

    def schemas(self) -> dict[str, tuple[str, bytes]]: ...

    def exchange(
        self,
        operation: str,
        request: dict[str, Any] | None,
        response: dict[str, Any] | None,
        log_time: int,
    ) -> list[tuple[str, str, bytes]]: ...

    def exchanges(self, batch: list[Exchange]) -> list[list[tuple[str, str, bytes]]]: ...

    def transform(self, log_time: int) -> list[tuple[str, str, bytes]]: ...


@dataclass
class ViewReport:
    """What was written, and what of the input was not a recording."""

    out: Path
    exchanges: int = 0
    scene_messages: int = 0
    reader: Reader | None = None
    written: bool = False
    """False when no file read was a recording: nothing is written then."""
    topics: set[str] = field(default_factory=set)

    def text(self) -> str:
        return (
            f"{self.out}: {self.exchanges} exchanges, {self.scene_messages} scene messages "
            f"on {len(self.topics)} topics"
        )


class _Channels:
    """The output's schemas and channels, registered as first met."""

    def __init__(self, writer: SceneFile, scene_schemas: dict[str, tuple[str, bytes]]) -> None:
        self.writer = writer
        self.scene_schemas = scene_schemas
        self.schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        self.originals: dict[tuple[str, str], int] = {}

    def original(self, operation: str, kind: str) -> int:
        """The channel of ``<operation>/<kind>`` records (no schema for an operation this
        build does not know)."""
        channel = self.originals.get((operation, kind))
        if channel is None:
            channel = self.originals[operation, kind] = self._original(operation, kind)
        return channel

    def _original(self, operation: str, kind: str) -> int:
        topic = f"{operation}/{kind}"
        if topic not in self.channels:
            endpoint = ENDPOINTS.get(operation)
            schema_id = 0
            if endpoint is not None:
                schema = (
                    request_schema(endpoint.request)
                    if kind == "request"
                    else response_schema(endpoint.response)
                )
                schema_id = self.writer.schema(
                    f"plotgate.{operation}.{kind}", "jsonschema", json.dumps(schema).encode()
                )
            self.channels[topic] = self.writer.channel(topic, "json", schema_id)
        return self.channels[topic]

    def scene(self, topic: str, schema_name: str) -> int:
        """The channel of a scene topic (protobuf messages of the SDK's schema)."""
        if topic not in self.channels:
            if schema_name not in self.schemas:
                encoding, data = self.scene_schemas[schema_name]
                self.schemas[schema_name] = self.writer.schema(schema_name, encoding, data)
            self.channels[topic] = self.writer.channel(
                topic, "protobuf", self.schemas[schema_name]
            )
        return self.channels[topic]


def _check_out(out: Path, inputs: list[Path]) -> None:
    """Refuse an ``out`` that is one of the recordings read (it would be overwritten)."""
    resolved = out.resolve()
    if any(p.resolve() == resolved for p in inputs):
        raise ValueError(f"{out} is one of the recordings read: give another output file")


def view(
    paths: Path | str | Iterable[Path | str],
    out: Path | str,
    scenes: Scenes,
    filters: Filters | None = None,
) -> ViewReport:
    """Write the scene MCAP of the recordings at ``paths`` to ``out``.

    Raises ``FileNotFoundError`` or :class:`~plotgate.clients.mcap_reader.NotRegular` for paths
    that are not recordings (as every reader does), ``ValueError`` for an ``out`` among
    them, ``OSError`` naming ``out`` when it cannot be written
    (:class:`~plotgate.files.NotRegularTarget` when it is not a regular file)."""
    out = Path(out)
    check_target(out)
    reader = Reader(paths, filters)
    _check_out(out, reader.paths)
    report = ViewReport(out, reader=reader)
    try:
        with atomic_write(out) as stream:
            _write(stream, reader, scenes, report)
            if not reader.recordings:
                raise _NothingToWrite
        report.written = True
    except _NothingToWrite:
        pass
    return report


class _NothingToWrite(Exception):
    """No file read was a recording: the temporary is dropped, ``out`` left as it was."""


def _write(stream: BinaryIO, reader: Reader, scenes: Scenes, report: ViewReport) -> None:
    writer = SceneFile(stream, "plotgate view", CHUNK_BYTES)
    out = _Out(writer, _Channels(writer, scenes.schemas()), scenes, report)
    batch: list[Exchange] = []
    for ex in reader:
        batch.append(ex)
        if len(batch) == BATCH:
            out.write(batch)
            batch = []
    out.write(batch)
    writer.finish()


@dataclass
class _Out:
    """Batches of exchanges written in the order read, each batch drawn together
    (``scenes.exchanges``); the radar frame's transform before the first exchange and
    then once a second of recording time."""

    writer: SceneFile
    channels: _Channels
    scenes: Scenes
    report: ViewReport
    last_transform: int | None = None

    def write(self, batch: list[Exchange]) -> None:
        writer, channels, report = self.writer, self.channels, self.report
        for ex, messages in zip(batch, self.scenes.exchanges(batch), strict=True):
            t = ex.log_time
            if self.last_transform is None or abs(t - self.last_transform) >= TRANSFORM_EVERY_NS:
                for topic, schema, data in self.scenes.transform(t):
                    writer.message(channels.scene(topic, schema), t, data)
                self.last_transform = t
            _copy(writer, channels, ex)
            for topic, schema, data in messages:
                writer.message(channels.scene(topic, schema), t, data)
                report.topics.add(topic)
            report.scene_messages += len(messages)
            report.exchanges += 1


def _copy(writer: SceneFile, channels: _Channels, ex: Exchange) -> None:
    """The exchange's original records, as they were recorded."""
    t = ex.log_time
    if ex.request_bytes is not None:
        writer.message(channels.original(ex.operation, "request"), t, ex.request_bytes)
    if ex.response_bytes is not None:
        answered = t + int((ex.duration_s or 0.0) * 1e9)
        channel = channels.original(ex.operation, "response")
        writer.message(channel, answered, ex.response_bytes)
