"""Typed change events and their delivery to callbacks and async streams.

Every change to the graph, local or remote, becomes one :class:`Event`. They
are delivered after the change is complete, on the thread that made or applied
it (the asyncio loop thread in a connected process).

Slow consumers never block writers: an :class:`EventStream` holds at most
``maxsize`` events and, when full, **drops the oldest** and counts it in
:attr:`EventStream.dropped`. A callback that raises is logged and counted in
:attr:`EventHub.callback_errors`; the write that caused the event stands.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import Enum

log = logging.getLogger(__name__)


class EventKind(str, Enum):
    NODE_ADDED = "node_added"
    NODE_UPDATED = "node_updated"
    NODE_REMOVED = "node_removed"
    EDGE_ADDED = "edge_added"
    EDGE_UPDATED = "edge_updated"
    EDGE_REMOVED = "edge_removed"
    MEMBER_JOINED = "member_joined"
    MEMBER_LEFT = "member_left"

    def __str__(self) -> str:
        return self.value


@dataclass(frozen=True, init=False)
class Event:
    """One change. Node events set ``id``/``name``; edge events set ``src``/``dst`` and their names.

    ``attrs`` names the attributes that changed (all of them on *added*).
    ``writer`` is the replica id that made the change, or, for changes that
    arrive in a catch-up, the replica that served them. Member events carry the
    member's replica id in ``writer`` and its agent name in ``name``.
    """

    kind: EventKind
    type: str
    writer: str
    local: bool
    attrs: frozenset[str] = frozenset()
    id: int | None = None
    name: str | None = None
    src: int | None = None
    dst: int | None = None
    src_name: str | None = None
    dst_name: str | None = None

    def __init__(
        self,
        kind: EventKind,
        type: str,
        writer: str,
        local: bool,
        attrs: frozenset[str] = frozenset(),
        id: int | None = None,
        name: str | None = None,
        src: int | None = None,
        dst: int | None = None,
        src_name: str | None = None,
        dst_name: str | None = None,
    ) -> None:
        # one dict update instead of the frozen dataclass's object.__setattr__ per field (a third of the cost)
        self.__dict__.update(
            kind=kind,
            type=type,
            writer=writer,
            local=local,
            attrs=attrs,
            id=id,
            name=name,
            src=src,
            dst=dst,
            src_name=src_name,
            dst_name=dst_name,
        )

    def __str__(self) -> str:
        where = "local" if self.local else f"remote:{self.writer}"
        if self.src is not None:
            subject = f"{self.src_name or self.src}-[{self.type}]->{self.dst_name or self.dst}"
        else:
            subject = f"{self.type} {self.name or self.id}"
        changed = f" {sorted(self.attrs)}" if self.attrs else ""
        return f"{self.kind.value} {subject}{changed} ({where})"


def _as_set(value: str | Iterable[str] | None) -> frozenset[str] | None:
    if value is None:
        return None
    if isinstance(value, str):
        return frozenset([value])
    return frozenset(str(v) for v in value)


@dataclass(frozen=True)
class EventFilter:
    """Which events a consumer wants: by kind, by node/edge type, by node name (either end, for edges)."""

    kinds: frozenset[str] | None = None
    types: frozenset[str] | None = None
    names: frozenset[str] | None = None

    @classmethod
    def of(
        cls,
        kind: str | Iterable[str] | None = None,
        type: str | Iterable[str] | None = None,
        name: str | Iterable[str] | None = None,
    ) -> EventFilter:
        kinds = _as_set(kind)
        if kinds is not None:
            known = {k.value for k in EventKind}
            unknown = kinds - known
            if unknown:
                raise ValueError(f"unknown event kind {sorted(unknown)[0]!r}; expected one of {sorted(known)}")
        return cls(kinds, _as_set(type), _as_set(name))

    def matches(self, event: Event) -> bool:
        if self.kinds is not None and event.kind.value not in self.kinds:
            return False
        if self.types is not None and event.type not in self.types:
            return False
        if self.names is not None and not ({event.name, event.src_name, event.dst_name} & self.names):
            return False
        return True


class EventStream:
    """A bounded async iterator of events; when full it drops the oldest and counts it."""

    def __init__(self, hub: EventHub, event_filter: EventFilter, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError("maxsize must be at least 1")
        self._hub = hub
        self.filter = event_filter
        self._queue: deque[Event] = deque()
        self._maxsize = maxsize
        self._waiter: asyncio.Future[None] | None = None
        self.dropped = 0
        self.closed = False

    def push(self, event: Event) -> None:
        if len(self._queue) >= self._maxsize:
            self._queue.popleft()
            self.dropped += 1
        self._queue.append(event)
        if self._waiter is not None and not self._waiter.done():
            self._waiter.set_result(None)

    def get_nowait(self) -> Event | None:
        """The oldest pending event, or None."""
        return self._queue.popleft() if self._queue else None

    def __len__(self) -> int:
        return len(self._queue)

    def __aiter__(self) -> EventStream:
        return self

    async def __anext__(self) -> Event:
        while not self._queue:
            if self.closed:
                raise StopAsyncIteration
            self._waiter = asyncio.get_running_loop().create_future()
            await self._waiter
        return self._queue.popleft()

    async def next(self, timeout: float | None = None) -> Event:
        """The next event, waiting at most ``timeout`` seconds (raises TimeoutError)."""
        return await asyncio.wait_for(self.__anext__(), timeout)

    def close(self) -> None:
        self.closed = True
        self._hub.remove_stream(self)
        if self._waiter is not None and not self._waiter.done():
            self._waiter.set_result(None)

    def __enter__(self) -> EventStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Subscription:
    """A registered callback; :meth:`cancel` stops deliveries."""

    def __init__(self, hub: EventHub, callback: Callable[[Event], object], event_filter: EventFilter) -> None:
        self._hub = hub
        self.callback = callback
        self.filter = event_filter

    def cancel(self) -> None:
        self._hub.remove_callback(self)


class EventHub:
    """Fans events out to callbacks and streams."""

    def __init__(self) -> None:
        self._callbacks: list[Subscription] = []
        self._streams: list[EventStream] = []
        self._wanted: dict[tuple[EventKind, str], bool] = {}  # (kind, type) -> whether a filter may match
        self.callback_errors = 0

    @property
    def has_consumers(self) -> bool:
        return bool(self._callbacks or self._streams)

    def wants(self, kind: EventKind, type_name: str) -> bool:
        """Whether some consumer's kind and type filters let such an event through (names are not looked at)."""
        wanted = self._wanted.get((kind, type_name))
        if wanted is None:
            filters = [c.filter for c in self._callbacks] + [s.filter for s in self._streams]
            wanted = self._wanted[(kind, type_name)] = any(
                (f.kinds is None or kind.value in f.kinds) and (f.types is None or type_name in f.types)
                for f in filters
            )
        return wanted

    def subscribe(self, callback: Callable[[Event], object], event_filter: EventFilter) -> Subscription:
        sub = Subscription(self, callback, event_filter)
        self._callbacks.append(sub)
        self._wanted.clear()
        return sub

    def stream(self, event_filter: EventFilter, maxsize: int) -> EventStream:
        stream = EventStream(self, event_filter, maxsize)
        self._streams.append(stream)
        self._wanted.clear()
        return stream

    def remove_callback(self, sub: Subscription) -> None:
        if sub in self._callbacks:
            self._callbacks.remove(sub)
            self._wanted.clear()

    def remove_stream(self, stream: EventStream) -> None:
        if stream in self._streams:
            self._streams.remove(stream)
            self._wanted.clear()

    def publish(self, events: Iterable[Event]) -> None:
        for event in events:
            for stream in self._streams:
                if stream.filter.matches(event):
                    stream.push(event)
            for sub in list(self._callbacks):
                if sub.filter.matches(event):
                    try:
                        sub.callback(event)
                    except Exception:
                        self.callback_errors += 1
                        log.exception("event callback %r failed on %s", sub.callback, event)
