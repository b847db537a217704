"""Shared helpers of the graph tests."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

import wm


class Recorder:
    """Records every event a graph publishes, and the CRDT updates it emits."""

    def __init__(self, graph: wm.Graph) -> None:
        self.graph = graph
        self.events: list[wm.Event] = []
        self.updates: list[bytes] = []
        graph.on(self.events.append)
        graph.observe_updates(lambda update, origin: self.updates.append(update))

    def clear(self) -> None:
        self.events.clear()
        self.updates.clear()

    def kinds(self) -> list[str]:
        return [e.kind.value for e in self.events]


def state_of(graph: wm.Graph) -> tuple[Any, ...]:
    """Everything a write could change."""
    return graph.to_dict(), graph.state_vector(), sorted(map(repr, graph.volatile_records()))


def assert_refused(
    graph: wm.Graph, recorder: Recorder, error: type[wm.WMError], write: Callable[[], object]
) -> wm.WMError:
    """``write`` raises ``error`` and changes nothing: no state, no update, no event."""
    before = state_of(graph)
    recorder.clear()
    with pytest.raises(error) as info:
        write()
    assert state_of(graph) == before
    assert recorder.events == []
    assert recorder.updates == []
    return info.value
