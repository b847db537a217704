"""The recording file: a graph's change stream in MCAP, readable without our code.

Three channels, each message stamped with the time the recorder applied it:

``/wm/updates``  message encoding ``msgpack``: ``[crdt_update_or_nil, volatile_records]``,
                 everything the recording replica applied (catch-up included).
                 Applying them in order rebuilds the graph at any time.
``/wm/changes``  message encoding ``json`` (schema ``wm.GraphChange``): one graph
                 event with the values of the attributes it changed.
``/wm/scene``    message encoding ``json`` (schema ``foxglove.SceneUpdate``): the
                 2D scene, for Foxglove's 3D panel.

The writer closes an uncompressed chunk at every :meth:`RecordingWriter.flush`
(the recorder flushes every 0.5 s by default), so a file cut off by ``kill -9``
holds every flushed chunk; :func:`iter_messages` reads up to the torn end.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, BinaryIO

import msgpack
from mcap.exceptions import McapError
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from . import foxglove
from ..graph import Graph
from ..ontology import Ontology
from ..volatile import Record, check_records

UPDATES = "/wm/updates"
CHANGES = "/wm/changes"
SCENE = "/wm/scene"
RECORDING_WRITER = "recording"
CHANGE_SCHEMA = {
    "title": "wm.GraphChange",
    "type": "object",
    "properties": {
        "kind": {"type": "string"},
        "type": {"type": "string"},
        "writer": {"type": "string"},
        "id": {"type": ["integer", "null"]},
        "name": {"type": ["string", "null"]},
        "src": {"type": ["integer", "null"]},
        "dst": {"type": ["integer", "null"]},
        "src_name": {"type": ["string", "null"]},
        "dst_name": {"type": ["string", "null"]},
        "attrs": {"type": "object"},
    },
}


class RecordingWriter:
    """Writes the three channels of one recording to ``path``."""

    def __init__(self, path: str | Path, graph_name: str) -> None:
        self._file: BinaryIO = open(path, "wb")  # noqa: SIM115 - open for the recording's life
        self._mcap = Writer(self._file, compression=CompressionType.NONE, chunk_size=256 * 1024)
        self._mcap.start(profile="", library="cortex-wm")
        self._mcap.add_metadata("wm", {"graph": graph_name})
        change_schema = self._mcap.register_schema("wm.GraphChange", "jsonschema", json.dumps(CHANGE_SCHEMA).encode())
        scene_schema = self._mcap.register_schema(foxglove.SCHEMA_NAME, "jsonschema", json.dumps(foxglove.SCHEMA).encode())
        self._channels = {
            UPDATES: self._mcap.register_channel(UPDATES, "msgpack", 0),
            CHANGES: self._mcap.register_channel(CHANGES, "json", change_schema),
            SCENE: self._mcap.register_channel(SCENE, "json", scene_schema),
        }
        self._sequence = 0

    def _add(self, topic: str, t_ns: int, data: bytes) -> None:
        self._sequence += 1
        self._mcap.add_message(self._channels[topic], log_time=t_ns, data=data, publish_time=t_ns, sequence=self._sequence)

    def update(self, t_ns: int, update: bytes | None, records: list[Record]) -> None:
        self._add(UPDATES, t_ns, msgpack.packb([update, records], use_bin_type=True))

    def change(self, t_ns: int, change: dict[str, Any]) -> None:
        self._add(CHANGES, t_ns, json.dumps(change).encode())

    def scene(self, t_ns: int, scene_update: dict[str, Any]) -> None:
        self._add(SCENE, t_ns, json.dumps(scene_update).encode())

    def flush(self) -> None:
        """Close the open chunk and hand it to the OS."""
        self._mcap.flush()

    def close(self) -> None:
        """Write the index and footer (a recording that never gets here is still readable)."""
        self._mcap.finish()
        self._file.close()


def iter_messages(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
    """(topic, log time in ns, data) of every message in file order, up to a torn end if any."""
    wanted = set(topics) if topics is not None else None
    channels: dict[int, str] = {}
    with open(path, "rb") as stream:
        records = StreamReader(stream, validate_crcs=True).records
        while True:
            try:
                record = next(records)
            except (StopIteration, McapError, EOFError, ValueError):
                return
            if isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Message):
                topic = channels.get(record.channel_id, "")
                if wanted is None or topic in wanted:
                    yield topic, record.log_time, record.data


def iter_updates(path: str | Path) -> Iterator[tuple[int, bytes | None, list[Record]]]:
    """(log time in ns, CRDT update or None, volatile records) of every ``/wm/updates`` message."""
    for _, t_ns, data in iter_messages(path, [UPDATES]):
        yield (t_ns, *_unpack_update(data))


def _unpack_update(data: bytes) -> tuple[bytes | None, list[Record]]:
    update, records = msgpack.unpackb(data, raw=False)
    return update, check_records(records)


def graph_at(path: str | Path, at: float | None = None, ontology: Ontology | None = None) -> Graph:
    """The graph as recorded ``at`` seconds after the recording's first message (None: the end)."""
    graph = Graph(ontology)
    first: int | None = None
    for topic, t_ns, data in iter_messages(path):
        first = t_ns if first is None else first
        if at is not None and t_ns - first > at * 1e9:
            break
        if topic == UPDATES:
            update, records = _unpack_update(data)
            if update:
                graph.apply_update(update, RECORDING_WRITER)
            if records:
                graph.merge_volatile(records, RECORDING_WRITER)
    return graph
