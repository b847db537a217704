"""Which risky intentions Algorithm 2 searches next: those that just landed, and again those no move removed.

A risky ``has_intention`` edge (person, target) is searched when it lands or
changes in W. A search that finds no move leaves the danger *unsaved*: it is
searched again once ``retry`` simulated seconds have passed, at the first
update of W after that, from the context then (perception's estimates sharpen,
and the person's own replies to the robot change the scene), for as long as it
stays risky. A danger with no candidate in reach is not retried: with less time
left, none will be in reach later; it waits for its next update instead. Within
``retry`` of a failed search, a danger is not searched at all, so that the edge's
own rewrites do not repeat the search that just failed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: A risky intention: (person node id, target node id).
Key = tuple[int, int]


@dataclass
class SearchQueue:
    """The risky intentions to search, and when each last failed (simulated seconds)."""

    retry: float
    landed: set[Key] = field(default_factory=set)
    unsaved: set[Key] = field(default_factory=set)
    failed_at: dict[Key, float] = field(default_factory=dict)

    @property
    def waiting(self) -> bool:
        """Whether anything may be due for a search."""
        return bool(self.landed or self.unsaved)

    def land(self, key: Key) -> None:
        """The intention ``key`` landed or changed in W."""
        self.landed.add(key)

    def take(self) -> set[Key]:
        """The intentions to look at now: those that landed since the last call, and the unsaved ones."""
        keys, self.landed = self.landed | self.unsaved, set()
        return keys

    def still_risky(self, risky: set[Key]) -> None:
        """Forget the unsaved dangers that W no longer holds as risky."""
        self.unsaved &= risky

    def due(self, key: Key, now: float) -> bool:
        """Whether ``key`` may be searched at ``now``: it has not failed within ``retry``."""
        return now - self.failed_at.get(key, -float("inf")) >= self.retry

    def saved(self, key: Key) -> None:
        """A move keeps the danger ``key`` away."""
        self.unsaved.discard(key)

    def failed(self, key: Key, now: float, candidates: bool) -> None:
        """No move removed ``key`` at ``now``; it is searched again after ``retry`` if ``candidates`` were judged."""
        self.failed_at[key] = now
        if candidates:
            self.unsaved.add(key)
        else:
            self.unsaved.discard(key)

    def clear(self) -> None:
        """A new trial: forget everything."""
        self.landed.clear()
        self.unsaved.clear()
        self.failed_at.clear()
