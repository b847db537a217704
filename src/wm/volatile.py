"""Last-writer-wins registers for volatile (high-rate) attributes.

Poses at 30 Hz cannot live as plain CRDT map overwrites: every overwrite
leaves a tombstone that is never compacted (see ``docs/architecture.md``). A
volatile attribute is instead one register per (owner, attribute) holding the
latest value, stamped with a Lamport clock and the writer's replica id. Merge
keeps the value with the greater ``(clock, writer)``, so replicas converge
whatever the order, loss or duplication of messages, and memory is bounded by
the number of live attributes, not by the number of writes.

An *owner* is ``"n:<node id>"`` or ``"e:<src>>dst>type"``. A value of ``None``
is a deleted attribute (kept so that an older write cannot bring it back).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

from .errors import DecodeError

# one register on the wire and on disk: (owner, attr, value, clock, writer)
Record = tuple[str, str, Any, int, str]


def node_owner(node_id: int) -> str:
    return f"n:{node_id}"


def edge_owner(key: str) -> str:
    return f"e:{key}"


class VolatileStore:
    """The registers of one replica, plus the outbox of local writes not yet sent."""

    def __init__(self, replica_id: str) -> None:
        self.replica_id = replica_id
        self.clock = 0
        # owner -> attr -> [value, clock, writer, monotonic time of last change]
        self._owners: dict[str, dict[str, list[Any]]] = {}
        self._outbox: dict[tuple[str, str], Record] = {}
        self._changed: set[tuple[str, str]] | None = None  # tracked only for persistence

    def write(self, owner: str, attr: str, value: Any) -> None:
        """A local write: it always wins over what this replica has seen."""
        self.clock += 1
        self._owners.setdefault(owner, {})[attr] = [value, self.clock, self.replica_id, time.monotonic()]
        self._outbox[(owner, attr)] = (owner, attr, value, self.clock, self.replica_id)
        if self._changed is not None:
            self._changed.add((owner, attr))

    def merge(self, records: Iterable[Record]) -> list[tuple[str, str]]:
        """Merge remote registers; returns the (owner, attr) pairs whose value changed."""
        changed = []
        now = time.monotonic()
        for owner, attr, value, clock, writer in records:
            if clock > self.clock:
                self.clock = clock
            attrs = self._owners.setdefault(owner, {})
            current = attrs.get(attr)
            if current is None or (clock, writer) > (current[1], current[2]):
                attrs[attr] = [value, clock, writer, now]
                changed.append((owner, attr))
        if self._changed is not None:
            self._changed.update(changed)
        return changed

    def values(self, owner: str) -> dict[str, Any]:
        """The live (non-deleted) values of one owner."""
        attrs = self._owners.get(owner)
        if not attrs:
            return {}
        return {attr: reg[0] for attr, reg in attrs.items() if reg[0] is not None}

    def has(self, owner: str, attr: str) -> bool:
        reg = self._owners.get(owner, {}).get(attr)
        return reg is not None and reg[0] is not None

    def drop_owner(self, owner: str) -> None:
        """Forget an owner that was deleted (the deletion itself is replicated by the CRDT)."""
        self._owners.pop(owner, None)

    def prune(self, is_alive: Callable[[str], bool], older_than: float) -> int:
        """Drop owners that do not exist and have not changed for ``older_than`` seconds."""
        limit = time.monotonic() - older_than
        dead = [
            owner
            for owner, attrs in self._owners.items()
            if not is_alive(owner) and all(reg[3] < limit for reg in attrs.values())
        ]
        for owner in dead:
            del self._owners[owner]
        return len(dead)

    def take_outbox(self) -> list[Record]:
        """The local writes since the last call, one per register (newer writes replace older)."""
        records = list(self._outbox.values())
        self._outbox.clear()
        return records

    def track_changes(self) -> None:
        """Start remembering which registers change, for :meth:`take_changes`."""
        if self._changed is None:
            self._changed = set()

    def take_changes(self) -> list[Record]:
        """The registers that changed since the last call (their current values)."""
        if not self._changed:
            return []
        records = []
        for owner, attr in self._changed:
            reg = self._owners.get(owner, {}).get(attr)
            if reg is not None:
                records.append((owner, attr, reg[0], reg[1], reg[2]))
        self._changed.clear()
        return records

    def records(self) -> list[Record]:
        """Every register, for a catch-up or a snapshot on disk."""
        return [
            (owner, attr, reg[0], reg[1], reg[2])
            for owner, attrs in self._owners.items()
            for attr, reg in attrs.items()
        ]

    def __len__(self) -> int:
        return sum(len(attrs) for attrs in self._owners.values())


def check_records(items: Any) -> list[Record]:
    """Records decoded from msgpack, checked field by field; raises :class:`wm.DecodeError` if malformed."""
    if not isinstance(items, list):
        raise DecodeError("volatile records must be a list")
    records = []
    for item in items:
        if (
            not isinstance(item, (list, tuple))
            or len(item) != 5
            or not isinstance(item[0], str)
            or item[0][:2] not in ("n:", "e:")
            or not isinstance(item[1], str)
            or not isinstance(item[3], int)
            or isinstance(item[3], bool)
            or not isinstance(item[4], str)
        ):
            raise DecodeError("a volatile record is [owner, attr, value, clock, writer]")
        value = tuple(item[2]) if isinstance(item[2], list) else item[2]
        records.append((item[0], item[1], value, item[3], item[4]))
    return records
