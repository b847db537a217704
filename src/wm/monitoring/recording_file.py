"""The recording file: a graph's change stream in MCAP, readable without our code.

It is written with ``foxglove-sdk``'s MCAP writer and holds the channels of a
live ``wm foxglove`` view (:class:`wm.monitoring.foxglove.GraphChannels`:
``/wm/tf``, ``/wm/scene``, ``/wm/changes``, ``/wm/log``), so a recording and a live session
look alike in Foxglove, plus the one replay needs:

``/wm/updates``  message encoding ``msgpack`` (schema ``wm.Update``): ``[crdt_update_or_nil, volatile_records]``,
                 everything the recording replica applied (catch-up included).
                 Applying them in order rebuilds the graph at any time.

Each message is stamped with the time the recorder applied it. The writer
closes an uncompressed chunk at every :meth:`RecordingWriter.flush` (the
recorder flushes every 0.5 s by default), so a file cut off by ``kill -9``
holds every flushed chunk; :func:`iter_messages` reads up to the torn end.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from pathlib import Path

import foxglove
import msgpack
from foxglove.mcap import MCAPWriteOptions
from mcap.exceptions import McapError
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader

from ..graph import Graph
from ..ontology import Ontology
from ..volatile import Record, check_records
from .foxglove import CHANGES, LOG, SCENE, TF, GraphChannels

__all__ = ["CHANGES", "LOG", "SCENE", "TF", "UPDATES", "RecordingWriter", "graph_at", "iter_messages", "iter_updates"]

UPDATES = "/wm/updates"
RECORDING_WRITER = "recording"
CHUNK_SIZE = 256 * 1024
# the SDK gives every non-JSON channel a schema; this one says, in words, what the msgpack holds
UPDATE_SCHEMA = foxglove.Schema(
    name="wm.Update", encoding="text", data=b"msgpack array: [crdt_update_or_nil, volatile_records]"
)


class RecordingWriter:
    """Writes the channels of one recording to ``path`` (replacing any file there)."""

    def __init__(self, path: str | Path, graph_name: str, log_dir: str | Path | None = None) -> None:
        self._context = context = foxglove.Context()  # the channels live as long as their context
        options = MCAPWriteOptions(compression=None, chunk_size=CHUNK_SIZE, profile="")
        self._mcap = foxglove.open_mcap(path, allow_overwrite=True, context=context, writer_options=options)
        self._mcap.write_metadata("wm", {"graph": graph_name})
        self.channels = GraphChannels(context, log_dir)
        self._updates = foxglove.Channel(UPDATES, message_encoding="msgpack", schema=UPDATE_SCHEMA, context=context)

    def update(self, t_ns: int, update: bytes | None, records: list[Record]) -> None:
        self._updates.log(msgpack.packb([update, records], use_bin_type=True), log_time=t_ns)

    def flush(self) -> None:
        """Close the open chunk and hand it to the OS."""
        self._mcap.flush()

    def close(self) -> None:
        """Write the index and footer (a recording that never gets here is still readable)."""
        self._mcap.close()


def iter_messages(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
    """(topic, log time in ns, data) of every message in file order, up to a torn end if any.

    Raises ``ValueError`` when the file does not even start as an MCAP recording.
    """
    wanted = set(topics) if topics is not None else None
    channels: dict[int, str] = {}
    with open(path, "rb") as stream:
        records = StreamReader(stream, validate_crcs=True).records
        first = True
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except (McapError, EOFError, ValueError, struct.error) as exc:
                if first:
                    raise ValueError(f"{path} is not an MCAP recording") from exc
                return
            first = False
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
