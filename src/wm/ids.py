"""Node ids that are unique per creator without any coordination.

An id is ``prefix << COUNTER_BITS | counter``: the prefix is a random 32-bit
number drawn by each replica at start, so two replicas never need to agree on
anything. Ids stay below 2**53 so that they survive a round trip through any
JSON or float64 consumer (DSR's tools, browsers).
"""

from __future__ import annotations

import secrets
from collections.abc import Callable

PREFIX_BITS = 32
COUNTER_BITS = 21


def new_prefix() -> int:
    """A random, non-zero creator prefix."""
    return secrets.randbits(PREFIX_BITS) or 1


class IdAllocator:
    """Hands out fresh node ids for one replica; draws a new prefix when a counter runs out."""

    def __init__(self, prefix: int | None = None) -> None:
        self.prefix = prefix if prefix is not None else new_prefix()
        self._counter = 0

    def next_id(self, is_taken: Callable[[int], bool]) -> int:
        """A new id, skipping any that ``is_taken`` (ids this replica knows to exist or to be deleted)."""
        while True:
            self._counter += 1
            if self._counter >= 1 << COUNTER_BITS:
                self.prefix, self._counter = new_prefix(), 1
            node_id = (self.prefix << COUNTER_BITS) | self._counter
            if not is_taken(node_id):
                return node_id
