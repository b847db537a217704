"""The graph on disk: a snapshot plus an append-only log, safe against ``kill -9``.

``<data>/<graph>/snapshot.bin``  :meth:`wm.Graph.encode_state` at the last compaction
``<data>/<graph>/log.bin``       records since then: ``<u32 length><u32 crc32><msgpack [update, volatile, writer]>``

:class:`Persister` appends every change the replica applies (its own and its
peers') every ``interval`` seconds (50 ms by default) and hands the bytes to
the OS at once, so a process killed at any moment loses at most the last
interval; ``fsync_interval`` bounds what a power cut can lose. Loading
replays the snapshot and then the log, and cuts off a torn last record. CRDT
updates are idempotent, so replaying a record twice is harmless, which is what
makes compaction (new snapshot, then empty log) crash-safe.

Each record names the replica that sent its update, so that ``wm check`` can
say who wrote what the view leaves out; a replayed update is attributed to
``disk:<writer>``. Whatever a record holds, loading goes on: an unreadable
record is logged and skipped, and content the view rules refuse stays out of
the view (docs/replication.md, "Trust and validation").
"""

from __future__ import annotations

import asyncio
import logging
import os
import struct
import time
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgpack
from pycrdt import merge_updates

from .graph import Graph
from .volatile import Record, check_records

log = logging.getLogger(__name__)
_HEADER = struct.Struct("<II")
DISK_WRITER = "disk"


def disk_writer(writer: Any) -> str:
    """The origin of an update replayed from disk, naming the replica that sent it when known."""
    return f"{DISK_WRITER}:{writer}" if isinstance(writer, str) and writer else DISK_WRITER


def is_from_disk(origin: Any) -> bool:
    return isinstance(origin, str) and (origin == DISK_WRITER or origin.startswith(DISK_WRITER + ":"))


class DiskLog:
    """The files of one graph under a data directory."""

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.snapshot_path = self.directory / "snapshot.bin"
        self.log_path = self.directory / "log.bin"
        self._log = open(self.log_path, "ab")
        self._last_fsync = time.monotonic()

    def load_into(self, graph: Graph) -> int:
        """Replay the snapshot and the log into ``graph``; returns the number of log records."""
        if self.snapshot_path.exists():
            graph.load_state(self.snapshot_path.read_bytes(), writer=DISK_WRITER)
        data = self.log_path.read_bytes() if self.log_path.exists() else b""
        position = count = 0
        while position + _HEADER.size <= len(data):
            length, crc = _HEADER.unpack_from(data, position)
            body = data[position + _HEADER.size : position + _HEADER.size + length]
            if len(body) < length or zlib.crc32(body) != crc:
                break
            try:
                update, records, *writer = msgpack.unpackb(body, raw=False)
                origin = disk_writer(writer[0] if writer else None)
                if update:
                    graph.apply_update(update, origin)
                if records:
                    graph.merge_volatile(check_records(records), origin)
            except Exception as exc:  # nothing on disk may stop a restart
                log.error("%s: skipping an unreadable record at byte %d: %s", self.log_path, position, exc)
            position += _HEADER.size + length
            count += 1
        if position < len(data):
            log.warning(
                "%s: cutting a torn record at byte %d (%d bytes)", self.log_path, position, len(data) - position
            )
            self._log.truncate(position)
        return count

    def append(self, update: bytes | None, records: list[Record], writer: str, fsync_interval: float) -> None:
        body = msgpack.packb([update, records, writer], use_bin_type=True)
        self._log.write(_HEADER.pack(len(body), zlib.crc32(body)) + body)
        self._log.flush()
        if time.monotonic() - self._last_fsync >= fsync_interval:
            os.fsync(self._log.fileno())
            self._last_fsync = time.monotonic()

    def log_size(self) -> int:
        return self._log.tell()

    def compact(self, graph: Graph) -> None:
        """Write a new snapshot atomically, then start an empty log."""
        tmp = self.snapshot_path.with_suffix(".tmp")
        with open(tmp, "wb") as out:
            out.write(graph.encode_state())
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, self.snapshot_path)
        self._log.truncate(0)
        self._log.seek(0)
        os.fsync(self._log.fileno())

    def close(self) -> None:
        self._log.flush()
        os.fsync(self._log.fileno())
        self._log.close()


class Persister:
    """Keeps a :class:`DiskLog` up to date with a live graph."""

    def __init__(
        self,
        graph: Graph,
        disk: DiskLog,
        *,
        interval: float = 0.05,
        fsync_interval: float = 1.0,
        compact_bytes: int = 64 * 1024 * 1024,
    ) -> None:
        self.graph = graph
        self.disk = disk
        self.interval = interval
        self.fsync_interval = fsync_interval
        self.compact_bytes = compact_bytes
        # what was received from whom, asked at each flush (see Replicator.received); afterwards it is on disk
        self.progress: Callable[[], dict[str, int]] | None = None
        self.persisted: dict[str, int] = {}
        self._updates: dict[str, list[bytes]] = {}  # writer -> its updates since the last flush
        graph.observe_updates(self._on_update)
        graph.track_volatile_changes()

    def _on_update(self, update: bytes, origin: Any) -> None:
        if not is_from_disk(origin):
            self._updates.setdefault(str(origin), []).append(update)

    def flush(self) -> None:
        """Append one record per writer of the updates since the last flush (volatile registers with the first)."""
        by_writer, self._updates = self._updates, {}
        records = self.graph.take_volatile_changes()
        received = self.progress() if self.progress is not None else {}
        if not by_writer and not records:
            self.persisted = received
            return
        for writer, updates in by_writer.items() or [(self.graph.replica_id, [])]:
            update = None if not updates else updates[0] if len(updates) == 1 else merge_updates(*updates)
            self.disk.append(update, records, writer, self.fsync_interval)
            records = []
        self.persisted = received
        if self.disk.log_size() > self.compact_bytes:
            self.disk.compact(self.graph)

    def on_disk(self, sender: str) -> int:
        """The last sequence number of ``sender`` whose writes are in the log (handed to the OS)."""
        return self.persisted.get(sender, 0)

    async def run(self) -> None:
        """Flush every ``interval`` until cancelled, then flush, compact and close."""
        try:
            while True:
                await asyncio.sleep(self.interval)
                self.flush()
        finally:
            self.flush()
            self.disk.compact(self.graph)
            self.disk.close()
