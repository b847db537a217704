"""``wm record FILE``: a read-only replica that writes everything it applies to MCAP.

The recorder observes its own replica: every CRDT update and volatile change
it applies (the catch-up first, then live deltas and repairs) becomes a
``/wm/updates`` message, every event a ``/wm/changes`` message with values,
and the RT tree and the 2D scene ``/wm/tf`` and ``/wm/scene`` messages at
most every ``scene_period`` seconds (see :mod:`wm.monitoring.recording_file`). The file is flushed every ``flush_period`` seconds (at most one), so
a recording killed with ``kill -9`` loses at most that much.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Sequence
from pathlib import Path

from pycrdt import merge_updates

from ..events import Event
from ..graph import Graph
from ..net.connection import connect
from ..net.zenoh_config import ConfigSource
from ..ontology import Ontology
from .recording_file import RecordingWriter


class Recorder:
    """Feeds a :class:`RecordingWriter` from one replica (attach before it joins, to keep the catch-up)."""

    def __init__(
        self, graph: Graph, writer: RecordingWriter, *, scene_period: float = 0.2, flush_period: float = 0.5
    ) -> None:
        self.graph = graph
        self.writer = writer
        self.scene_period = scene_period
        self.flush_period = flush_period
        self.messages = 0
        self._updates: list[bytes] = []
        self._scene_dirty = True
        graph.observe_updates(lambda update, _origin: self._updates.append(update))
        graph.track_volatile_changes()
        graph.on(self._on_event)

    def _on_event(self, event: Event) -> None:
        now = time.time_ns()
        self.capture(now)
        self.writer.channels.publish_change(self.graph, event, now)
        self._scene_dirty = True

    def capture(self, t_ns: int) -> None:
        """Write the updates and volatile changes applied since the last capture as one message."""
        updates, self._updates = self._updates, []
        records = self.graph.take_volatile_changes()
        if updates or records:
            self.writer.update(
                t_ns, merge_updates(*updates) if len(updates) > 1 else (updates[0] if updates else None), records
            )
            self.messages += 1

    def tick(self) -> None:
        """Capture, and write the scene if the graph changed since the last one."""
        now = time.time_ns()
        self.capture(now)
        self.writer.channels.publish_logs(now)
        if self._scene_dirty:
            self._scene_dirty = False
            self.writer.channels.publish_view(self.graph, now)

    async def run(self) -> None:
        """Tick every ``scene_period`` and flush every ``flush_period`` until cancelled; then flush."""
        last_flush = time.monotonic()
        try:
            while True:
                await asyncio.sleep(min(self.scene_period, self.flush_period))
                self.tick()
                if time.monotonic() - last_flush >= self.flush_period:
                    self.writer.flush()
                    last_flush = time.monotonic()
        finally:
            self.tick()
            self.writer.flush()


async def record(
    path: str | Path,
    graph_name: str,
    *,
    config: ConfigSource | None = None,
    connect_to: Sequence[str] = (),
    ontology: Ontology | None = None,
    duration: float | None = None,
    log_dir: str | Path | None = None,
) -> int:
    """Record ``graph_name`` into ``path`` until cancelled (or for ``duration`` s); returns the update count."""
    graph = Graph(ontology)
    writer = RecordingWriter(path, graph_name, log_dir)
    recorder = Recorder(graph, writer)
    try:
        async with connect(
            graph_name, config, "wm-record", connect=list(connect_to) or None, replica=graph, read_only=True
        ):
            print(f"wm record: recording graph {graph_name!r} into {path}", flush=True)
            task = asyncio.ensure_future(recorder.run())
            try:
                await asyncio.wait_for(asyncio.shield(task), duration)
            except (TimeoutError, asyncio.CancelledError):  # the duration is up, or SIGTERM/SIGINT: stop cleanly
                pass
            finally:
                task.cancel()
                await asyncio.gather(task, return_exceptions=True)
    finally:
        writer.close()
    return recorder.messages
