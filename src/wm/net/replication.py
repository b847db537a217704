"""The Zenoh provider: keeps one :class:`wm.Graph` in step with its peers.

It moves the messages of :mod:`wm.net.sync_protocol` over one Zenoh session:

* the first local write of a loop tick leaves at once as a DELTA on
  ``wm/<g>/delta/<me>``; the writes after it in the same tick leave together,
  as one DELTA, at the end of the tick;
* remote DELTAs are applied on the loop thread (Zenoh callbacks only hand the
  bytes over with ``call_soon_threadsafe``), never echoed back;
* a gap in a sender's sequence numbers, or a HEARTBEAT showing state we lack,
  triggers an immediate SYNC_REQUEST to that sender's queryable;
* a joining replica catches up from any live member (the durable ``serve``
  member first, if there is one);
* membership comes from liveliness tokens ``wm/<g>/alive/<me>/<agent>``.

Malformed bytes are logged with the key they came on, counted in
:attr:`ReplicationStats.rejected`, and dropped; the replica is untouched.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import zenoh

from ..errors import DecodeError
from ..graph import Graph
from . import keys
from . import sync_protocol as proto

log = logging.getLogger(__name__)
DURABLE_AGENT = "serve"
RECONCILE_EVERY = 10  # heartbeats between full index-versus-document checks (Graph.reconcile)


@dataclass
class ReplicationStats:
    """Counters of one replica's traffic, for monitoring and tests."""

    published: int = 0
    applied: int = 0
    rejected: int = 0
    gaps: int = 0
    repairs: int = 0
    syncs_served: int = 0
    heartbeats: int = 0
    withheld: int = 0
    failed: int = 0  # messages whose application raised something unexpected (logged with a traceback)
    caught_up_from: str | None = None


@dataclass(frozen=True)
class Confirmation:
    """Which other replicas acknowledged every DELTA a replica had published, and which hold them on disk.

    True when it holds what was asked for: one acknowledgement, or with
    ``durable=True`` one durable member with the writes on disk.
    """

    acked: frozenset[str]
    on_disk: frozenset[str]
    durable: bool = False

    def __bool__(self) -> bool:
        return bool(self.on_disk if self.durable else self.acked)


class _Handoff:
    """Hands what Zenoh's callbacks receive over to the event loop, as calls of the replicator's methods.

    The callbacks hold this, not the replicator: Zenoh may keep a callback, and even call it, for a moment
    after it is undeclared (a read task can take it just before), so :meth:`cut` lets go of the replicator
    when it stops, and a late call does nothing. Nothing of a stopped replica then outlives it in Zenoh.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, replicator: Replicator) -> None:
        self._loop = loop
        self._replicator: Replicator | None = replicator

    def __call__(self, method: Callable[..., None], *args: Any) -> None:
        replicator = self._replicator
        if replicator is not None:
            self._loop.call_soon_threadsafe(method, replicator, *args)

    def cut(self) -> None:
        """Let go of the replicator: later calls are dropped."""
        self._replicator = None


class Replicator:
    """Replication of one graph over one (shared) Zenoh session."""

    def __init__(
        self,
        graph: Graph,
        session: zenoh.Session,
        graph_name: str,
        agent: str,
        *,
        heartbeat_period: float = 1.0,
        query_timeout: float = 2.0,
        read_only: bool = False,
    ) -> None:
        self.graph = graph
        self.read_only = read_only
        self.session = session
        self.name = keys.check_segment(graph_name, "graph name")
        self.agent = keys.check_segment(agent, "agent name")
        self.heartbeat_period = heartbeat_period
        self.query_timeout = query_timeout
        self.stats = ReplicationStats()
        self.seq = 0
        self.drop_outgoing = 0  # test hook: number of next DELTAs to lose on purpose
        self._tracker = proto.SequenceTracker()
        self._updates: list[bytes] = []
        self._flush_scheduled = False
        self._repairing: set[str] = set()
        self._tasks: set[asyncio.Task[Any]] = set()
        self._declared: list[Any] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._handoff: _Handoff | None = None  # what Zenoh's callbacks hold, while started
        self._publisher: zenoh.Publisher | None = None
        self._observing: Any = None  # the subscription to the graph's local updates, while started
        self.on_disk: Callable[[str], int] | None = None  # a durable member: sender -> last sequence number on disk

    # -- lifecycle -----------------------------------------------------------

    async def start(self, catch_up: bool = True, join_wait: float = 0.0) -> None:
        """Declare everything, then catch up from a live member (waiting up to ``join_wait`` s for one).

        A read-only replica (a monitor) declares no publisher, queryable or
        liveliness token and sends no heartbeat: it only subscribes and asks.
        """
        self._loop = loop = asyncio.get_running_loop()
        me = self.graph.replica_id
        session = self.session
        self._observing = self.graph.observe_updates(self._on_local_update)
        self.graph.add_write_listener(self._schedule_flush)
        remote = zenoh.Locality.REMOTE
        self._handoff = handoff = _Handoff(loop, self)
        if not self.read_only:
            self._publisher = session.declare_publisher(
                keys.delta(self.name, me), congestion_control=zenoh.CongestionControl.BLOCK, express=True
            )
            self._declared += [
                self._publisher,
                session.declare_queryable(
                    keys.sync(self.name, me), lambda q: handoff(Replicator._answer, q), allowed_origin=remote
                ),
                session.liveliness().declare_token(keys.alive(self.name, me, self.agent)),
            ]
        self._declared += [
            session.declare_subscriber(
                keys.delta(self.name),
                lambda s: handoff(Replicator._on_delta, str(s.key_expr), s.payload.to_bytes()),
                allowed_origin=remote,
            ),
            session.declare_subscriber(
                keys.heartbeat(self.name),
                lambda s: handoff(Replicator._on_heartbeat, str(s.key_expr), s.payload.to_bytes()),
                allowed_origin=remote,
            ),
            session.liveliness().declare_subscriber(
                keys.alive(self.name),
                lambda s: handoff(Replicator._on_liveliness, str(s.key_expr), s.kind),
                history=True,
            ),
        ]
        self.graph.note_member(me, self.agent, True)
        if catch_up:
            await self.catch_up(join_wait)
        self._spawn(self._heartbeat_loop())

    async def stop(self) -> None:
        """Send what is pending, leave, and undeclare (the session stays open)."""
        self._flush()
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except zenoh.ZError:
                pass
        self._declared.clear()
        if self._handoff is not None:
            self._handoff.cut()
            self._handoff = None
        self.graph.remove_write_listener(self._schedule_flush)
        if self._observing is not None:
            self.graph.unobserve_updates(self._observing)
            self._observing = None

    def _spawn(self, coro: Any) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- outgoing ------------------------------------------------------------

    def _on_local_update(self, update: bytes, origin: Any) -> None:
        if origin == self.graph.replica_id:
            self._updates.append(update)

    def _schedule_flush(self) -> None:
        """After a local write: the first of a tick leaves now, the others of the tick together at its end."""
        if not self._flush_scheduled and self._loop is not None:
            self._flush_scheduled = True
            self._publish()
            self._loop.call_soon(self._flush)

    def _flush(self) -> None:
        """Publish the local writes made since the last DELTA, as one DELTA, and start a new tick."""
        self._flush_scheduled = False
        self._publish()

    def _publish(self) -> None:
        updates, self._updates = self._updates, []
        message = proto.make_delta(self.graph.replica_id, self.seq + 1, updates, self.graph.take_volatile_outbox())
        if message is None:
            return
        if self._publisher is None:
            if self.read_only:
                self.stats.withheld += 1
                log.warning("read-only replica: a local write to graph %r stays local", self.name)
            return
        self.seq += 1
        if self.drop_outgoing > 0:
            self.drop_outgoing -= 1
            return
        self._publisher.put(proto.encode(message))
        self.stats.published += 1

    async def flush(self) -> None:
        """Publish pending writes now (they would leave at the end of this tick anyway)."""
        self._flush()

    # -- incoming ------------------------------------------------------------

    def _decode(self, key: str, payload: bytes, expected: type) -> Any:
        try:
            message = proto.decode(payload)
            if not isinstance(message, expected):
                raise DecodeError(f"expected {expected.__name__}, got {type(message).__name__}")
            if message.sender != keys.replica_of(key):
                raise DecodeError(f"sender {message.sender!r} does not match its key")
            return message
        except DecodeError as exc:
            self._reject(key, exc)
            return None

    def _reject(self, key: str, exc: Exception) -> None:
        self.stats.rejected += 1
        log.warning("rejected a message on %s (from replica %r): %s", key, keys.replica_of(key), exc)

    def _on_delta(self, key: str, payload: bytes) -> None:
        message = self._decode(key, payload, proto.Delta)
        if message is None or message.sender == self.graph.replica_id:
            return
        gap = self._tracker.on_delta(message.sender, message.seq)
        if not self._apply(key, message):
            return
        self.stats.applied += 1
        if gap:
            self.stats.gaps += 1
            self.repair(message.sender)

    def _apply(self, key: str, message: proto.Delta | proto.SyncReply) -> bool:
        """Apply a remote message; nothing it holds may stop replication, so every failure is caught and counted."""
        try:
            proto.apply_delta(self.graph, message)
            return True
        except DecodeError as exc:
            self._reject(key, exc)
        except Exception:
            self.stats.failed += 1
            log.exception("applying a message on %s (from replica %r) failed; replication goes on", key, message.sender)
        return False

    def _on_heartbeat(self, key: str, payload: bytes) -> None:
        message = self._decode(key, payload, proto.Heartbeat)
        if message is None or message.sender == self.graph.replica_id:
            return
        self.stats.heartbeats += 1
        try:
            behind = message.sender not in self._tracker.last or self._tracker.on_heartbeat(message.sender, message.seq)
            behind = behind or proto.lacks(self.graph.state_vector(), message.state_vector)
        except DecodeError as exc:
            self._reject(key, exc)
            return
        if behind:
            self.repair(message.sender)

    def _on_liveliness(self, key: str, kind: zenoh.SampleKind) -> None:
        try:
            replica, agent = keys.parse_alive(key)
        except Exception as exc:
            self._reject(key, exc)
            return
        joined = kind == zenoh.SampleKind.PUT
        if not joined:
            self._tracker.forget(replica)
        self.graph.note_member(replica, agent, joined)

    def _answer(self, query: zenoh.Query) -> None:
        key = keys.sync(self.name, self.graph.replica_id)
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            message = proto.decode(payload)
            if isinstance(message, proto.SyncRequest):
                reply: proto.Message = proto.answer_sync(self.graph, message, self.seq)
                self.stats.syncs_served += 1
            elif isinstance(message, proto.AckRequest):
                on_disk = self.on_disk(message.sender) if self.on_disk is not None else -1
                reply = proto.AckReply(self.graph.replica_id, self._tracker.last.get(message.sender, 0), on_disk)
            else:
                raise DecodeError(f"cannot answer a {type(message).__name__}")
            query.reply(key, proto.encode(reply))
        except DecodeError as exc:
            self._reject(str(query.key_expr), exc)
            query.reply_err(str(exc))
        except Exception as exc:
            self.stats.failed += 1
            log.exception("answering a query on %s failed", key)
            query.reply_err(f"cannot answer: {exc}")
        finally:
            query.drop()  # type: ignore[no-untyped-call]  # zenoh's stub leaves drop() unannotated

    # -- repair and catch-up -------------------------------------------------

    def repair(self, sender: str) -> None:
        """Fetch what ``sender`` has and we lack, at once (one request in flight per sender)."""
        if sender not in self._repairing:
            self._repairing.add(sender)
            self._spawn(self._repair(sender))

    async def _repair(self, sender: str) -> None:
        try:
            if await self.sync_from(sender):
                self.stats.repairs += 1
        finally:
            self._repairing.discard(sender)

    async def sync_from(self, replica: str) -> bool:
        """Ask one replica for everything we lack; True if it answered."""
        request = proto.encode(proto.SyncRequest(self.graph.replica_id, self.graph.state_vector()))
        for key, payload in await self._query(keys.sync(self.name, replica), request):
            reply = self._decode(key, payload, proto.SyncReply)
            if reply is None or not self._apply(key, reply):
                continue
            self._tracker.on_sync(reply.sender, reply.seq)
            return True
        return False

    async def catch_up(self, wait: float = 0.0) -> str | None:
        """Sync from one live member, the durable one first; returns its replica id.

        Right after a session opens, the network may not have told it of the
        other members yet: ``wait`` is how long to keep asking when none answer.
        """
        deadline = time.monotonic() + wait
        while True:
            members = await self.live_members()
            for replica in sorted(members, key=lambda r: members[r] != DURABLE_AGENT):
                if await self.sync_from(replica):
                    self.stats.caught_up_from = replica
                    return replica
            if time.monotonic() >= deadline:
                return None
            await asyncio.sleep(0.1)

    async def live_members(self) -> dict[str, str]:
        """Replica id -> agent name of the other live members, asked of the network now."""

        def ask() -> dict[str, str]:
            found = {}
            selector = keys.alive(self.name)
            for reply in _replies(
                lambda: self.session.liveliness().get(selector, timeout=self.query_timeout), selector
            ):
                if reply.ok is not None:
                    replica, agent = keys.parse_alive(str(reply.ok.key_expr))
                    found[replica] = agent
            return found

        members = await asyncio.to_thread(ask)
        members.pop(self.graph.replica_id, None)
        return members

    def received(self) -> dict[str, int]:
        """Sender -> the last sequence number received from it (what a durable member has once it is on disk)."""
        return dict(self._tracker.last)

    async def confirm(self, timeout: float = 2.0, durable: bool = False) -> Confirmation:
        """Wait until another replica acknowledges every DELTA we published; with ``durable``, a durable member on disk.

        Every live replica is asked, every round, until the first
        acknowledgement (or the first one on disk) or ``timeout``; the result
        lists all that acknowledged in that round. A silent replica delays
        nobody's confirmation beyond one round (0.5 s).
        """
        self._flush()
        request = proto.encode(proto.AckRequest(self.graph.replica_id, self.seq))
        deadline = time.monotonic() + timeout
        while True:
            acked, on_disk = set(), set()
            for key, payload in await self._query(keys.sync(self.name), request, timeout=0.5):
                reply = self._decode(key, payload, proto.AckReply)
                if reply is not None and reply.acked >= self.seq:
                    acked.add(reply.sender)
                if reply is not None and reply.on_disk >= self.seq:
                    on_disk.add(reply.sender)
            result = Confirmation(frozenset(acked), frozenset(on_disk), durable)
            if result or time.monotonic() >= deadline:
                return result
            await asyncio.sleep(0.05)

    async def _query(self, selector: str, payload: bytes, timeout: float | None = None) -> list[tuple[str, bytes]]:
        """A Zenoh get, run in a worker thread; returns (key, payload) of every good reply (none once the session closed)."""
        wait = self.query_timeout if timeout is None else timeout

        def ask() -> list[tuple[str, bytes]]:
            replies = _replies(
                lambda: self.session.get(
                    selector,
                    payload=payload,
                    timeout=wait,
                    target=zenoh.QueryTarget.ALL,
                    allowed_destination=zenoh.Locality.REMOTE,
                ),
                selector,
            )
            return [(str(r.ok.key_expr), r.ok.payload.to_bytes()) for r in replies if r.ok is not None]

        return await asyncio.to_thread(ask)

    # -- anti-entropy --------------------------------------------------------

    async def _heartbeat_loop(self) -> None:
        key = keys.heartbeat(self.name, self.graph.replica_id)
        beats = 0
        while True:
            await asyncio.sleep(self.heartbeat_period)
            self._flush()
            if not self.read_only:
                message = proto.Heartbeat(self.graph.replica_id, self.seq, self.graph.state_vector())
                self.session.put(key, proto.encode(message))
            self.graph.prune_volatile()
            beats += 1
            if beats % RECONCILE_EVERY == 0:
                self.graph.reconcile()


def _replies(get: Callable[[], Iterable[zenoh.Reply]], selector: str) -> list[zenoh.Reply]:
    """Every reply of a Zenoh get; none when the session closed under the replica (it is shutting down)."""
    try:
        return list(get())
    except zenoh.ZError as exc:
        log.debug("query on %s: %s", selector, exc)
        return []
