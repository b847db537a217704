"""The replication protocol as pure functions and messages, with no transport.

Six messages, each a msgpack array ``[version, kind, sender, *fields]`` with
exactly the fields listed in ``_FIELDS``, in that order (docs/replication.md,
"Wire format"). This is version 2: version 1 also sent, in SYNC_REPLY, the
replier's private index, and let ACK_REPLY leave ``on_disk`` out; a replica
refuses every message of another version.

``DELTA``         a replica's local writes of one loop tick: a merged CRDT
                  update and the volatile registers written, numbered by a
                  per-sender sequence number so a receiver sees any gap.
``HEARTBEAT``     a replica's last sequence number and CRDT state vector,
                  sent periodically for anti-entropy.
``SYNC_REQUEST``  "here is my state vector, send me what I lack".
``SYNC_REPLY``    the CRDT diff against that state vector, every volatile
                  register, and the replier's last sequence number.
``ACK_REQUEST``   "have you received my messages up to seq N?".
``ACK_REPLY``     the highest sequence number the replier has from the asker, and
                  the highest one it holds on disk (a durable member; -1 otherwise).

:func:`decode` checks every field's type, so malformed bytes raise
:class:`wm.errors.DecodeError` before anything touches the graph. The functions
at the end are the protocol's steps, written against :class:`wm.Graph` only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum
from typing import TYPE_CHECKING, Any

import msgpack
from pycrdt import merge_updates

from ..errors import DecodeError
from ..volatile import Record, check_records

if TYPE_CHECKING:
    from ..graph import Graph

VERSION = 2


class Kind(IntEnum):
    DELTA = 1
    HEARTBEAT = 2
    SYNC_REQUEST = 3
    SYNC_REPLY = 4
    ACK_REQUEST = 5
    ACK_REPLY = 6


@dataclass(frozen=True)
class Delta:
    sender: str
    seq: int
    update: bytes | None
    volatile: list[Record] = field(default_factory=list)


@dataclass(frozen=True)
class Heartbeat:
    sender: str
    seq: int
    state_vector: bytes


@dataclass(frozen=True)
class SyncRequest:
    sender: str
    state_vector: bytes


@dataclass(frozen=True)
class SyncReply:
    sender: str
    seq: int
    update: bytes
    volatile: list[Record] = field(default_factory=list)


@dataclass(frozen=True)
class AckRequest:
    sender: str
    seq: int


@dataclass(frozen=True)
class AckReply:
    sender: str
    acked: int
    on_disk: int  # -1: the replier keeps nothing on disk


Message = Delta | Heartbeat | SyncRequest | SyncReply | AckRequest | AckReply

_FIELDS: dict[Kind, tuple[type, tuple[tuple[str, tuple[type, ...]], ...]]] = {
    Kind.DELTA: (Delta, (("seq", (int,)), ("update", (bytes, type(None))), ("volatile", (list,)))),
    Kind.HEARTBEAT: (Heartbeat, (("seq", (int,)), ("state_vector", (bytes,)))),
    Kind.SYNC_REQUEST: (SyncRequest, (("state_vector", (bytes,)),)),
    Kind.SYNC_REPLY: (SyncReply, (("seq", (int,)), ("update", (bytes,)), ("volatile", (list,)))),
    Kind.ACK_REQUEST: (AckRequest, (("seq", (int,)),)),
    Kind.ACK_REPLY: (AckReply, (("acked", (int,)), ("on_disk", (int,)))),
}
_KIND_OF = {cls: kind for kind, (cls, _) in _FIELDS.items()}
_KIND_OF_CODE = {int(kind): kind for kind in Kind}  # a dict look-up costs less than Kind(code)


def encode(message: Message) -> bytes:
    kind = _KIND_OF[type(message)]
    fields = [getattr(message, name) for name, _ in _FIELDS[kind][1]]
    packed: bytes = msgpack.packb([VERSION, int(kind), message.sender, *fields], use_bin_type=True)
    return packed


def decode(data: bytes) -> Message:
    """Parse and type-check one message; anything else raises :class:`DecodeError`."""
    try:
        items = msgpack.unpackb(data, raw=False, use_list=True, strict_map_key=True)
    except Exception as exc:
        raise DecodeError(f"not a msgpack message: {exc}") from None
    if not isinstance(items, list) or len(items) < 3:
        raise DecodeError("a message is an array [version, kind, sender, ...]")
    version, kind_code, sender, *rest = items
    if version != VERSION:
        raise DecodeError(f"unsupported protocol version {version!r}")
    try:
        kind = _KIND_OF_CODE[kind_code]
    except (KeyError, TypeError):
        raise DecodeError(f"unknown message kind {kind_code!r}") from None
    if not isinstance(sender, str) or not sender:
        raise DecodeError("the sender must be a non-empty string")
    cls, fields = _FIELDS[kind]
    if len(rest) != len(fields):
        raise DecodeError(f"{kind.name} has {len(fields)} fields after the sender, got {len(rest)}")
    values: dict[str, Any] = {}
    for (name, types), value in zip(fields, rest, strict=False):
        if not isinstance(value, types) or (isinstance(value, bool) and int in types):
            raise DecodeError(f"{kind.name}.{name}: wrong type {type(value).__name__}")
        if name == "volatile":
            value = check_records(value)
        elif name == "state_vector" and isinstance(value, bytes):
            parse_state_vector(value)
        values[name] = value
    message: Message = cls(sender=sender, **values)
    return message


# -- state vectors -------------------------------------------------------------


def _read_varint(data: bytes, pos: int) -> tuple[int, int]:
    result = shift = 0
    while True:
        if pos >= len(data):
            raise DecodeError("truncated state vector")
        byte = data[pos]
        pos += 1
        result |= (byte & 0x7F) << shift
        if byte < 0x80:
            return result, pos
        shift += 7


def parse_state_vector(data: bytes) -> dict[int, int]:
    """A Yjs state vector (varuint count, then client/clock pairs) as a dict."""
    count, pos = _read_varint(data, 0)
    clocks = {}
    for _ in range(count):
        client, pos = _read_varint(data, pos)
        clock, pos = _read_varint(data, pos)
        clocks[client] = clock
    if pos != len(data):
        raise DecodeError("trailing bytes after the state vector")
    return clocks


def lacks(ours: bytes, theirs: bytes) -> bool:
    """Whether the replica with state vector ``theirs`` has CRDT changes we lack."""
    mine = parse_state_vector(ours)
    return any(clock > mine.get(client, 0) for client, clock in parse_state_vector(theirs).items())


# -- protocol steps --------------------------------------------------------------


def make_delta(sender: str, seq: int, updates: list[bytes], records: list[Record]) -> Delta | None:
    """One message for a tick's local writes (None when there were none)."""
    if not updates and not records:
        return None
    update = None if not updates else updates[0] if len(updates) == 1 else merge_updates(*updates)
    return Delta(sender, seq, update, records)


def apply_delta(graph: Graph, message: Delta | SyncReply) -> None:
    """Apply a delta or a sync reply; the sender is reported as the writer."""
    if isinstance(message, SyncReply) and graph.is_fresh():
        graph.load_fresh(message.update, message.sender)
    elif message.update:
        graph.apply_update(message.update, message.sender)
    if message.volatile:
        graph.merge_volatile(message.volatile, message.sender)


def answer_sync(graph: Graph, request: SyncRequest, seq: int) -> SyncReply:
    """Everything the asker lacks, and every volatile register."""
    return SyncReply(graph.replica_id, seq, graph.diff(request.state_vector), graph.volatile_records())


class SequenceTracker:
    """The highest sequence number seen from each sender, and whether a message shows a gap."""

    def __init__(self) -> None:
        self.last: dict[str, int] = {}

    def on_delta(self, sender: str, seq: int) -> bool:
        """Record a delta; True if one or more earlier messages of this sender were missed."""
        previous = self.last.get(sender)
        if previous is None or seq > previous:
            self.last[sender] = seq
        return previous is not None and seq > previous + 1

    def on_heartbeat(self, sender: str, seq: int) -> bool:
        """True if the sender has published messages we never received."""
        previous = self.last.get(sender)
        return previous is not None and seq > previous

    def on_sync(self, sender: str, seq: int) -> None:
        """A sync reply covers everything the sender had sent up to ``seq``."""
        if seq > self.last.get(sender, -1):
            self.last[sender] = seq

    def forget(self, sender: str) -> None:
        self.last.pop(sender, None)
