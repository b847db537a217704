"""The CRDT store's observers when pycrdt cannot list an event's keys."""

from __future__ import annotations

from typing import Any

import pytest

from wm.crdt_store import CrdtStore


class PanicException(BaseException):
    """Stands in for pyo3's PanicException (a Rust panic raised into Python), which cannot be imported."""


class _KeysPanic:
    path: list[Any] = []

    @property
    def keys(self) -> dict[str, Any]:
        raise PanicException("called `Option::unwrap()` on a `None` value")


def test_a_panic_listing_an_events_keys_marks_the_change_unreliable() -> None:
    store = CrdtStore()
    store.recorder.on_edges(_KeysPanic())
    store.recorder.on_edge_attrs(_KeysPanic())
    store.recorder.on_nodes([_KeysPanic()])
    changes = store.take_changes()
    assert changes.unreliable and not changes.edges_added and not changes.edge_attrs


def test_other_errors_in_an_observer_are_not_swallowed() -> None:
    class Broken:
        path: list[Any] = []

        @property
        def keys(self) -> dict[str, Any]:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        CrdtStore().recorder.on_edges(Broken())
