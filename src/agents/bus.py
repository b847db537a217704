"""Small msgpack-over-Zenoh helpers: publish, subscribe, serve and ask, from asyncio.

Zenoh has no asyncio API: callbacks arrive on Zenoh's threads and are handed to
the event loop with ``call_soon_threadsafe``; ``session.get`` runs in a worker
thread. A request that cannot be decoded or handled gets an error reply carrying
a one-line message, and the serving process carries on.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

import msgpack
import zenoh

log = logging.getLogger(__name__)


class BusError(Exception):
    """A message could not be decoded, or a request got an error reply or none."""


class RemoteError(BusError):
    """The service answered a request with an error."""


class NoReply(BusError):
    """Nobody answered a request in time."""


def pack(message: Any) -> bytes:
    """msgpack bytes of a message (tuples become lists)."""
    return msgpack.packb(message, use_bin_type=True)


def unpack(payload: bytes) -> Any:
    """Decode msgpack bytes; raises :class:`BusError` on garbage."""
    try:
        return msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except (ValueError, msgpack.UnpackException, TypeError) as exc:
        raise BusError(f"payload is not valid msgpack: {exc}") from None


def subscribe(session: zenoh.Session, key: str, callback: Callable[[Any], None]) -> zenoh.Subscriber:
    """Call ``callback(message)`` on the running loop for every decodable sample on ``key``."""
    loop = asyncio.get_running_loop()

    def deliver(payload: bytes) -> None:
        try:
            message = unpack(payload)
        except BusError as exc:
            log.warning("dropped a sample on %s: %s", key, exc)
            return
        callback(message)

    return session.declare_subscriber(key, lambda s: loop.call_soon_threadsafe(deliver, s.payload.to_bytes()))


def serve(session: zenoh.Session, key: str, handler: Callable[[Any], Awaitable[Any]]) -> zenoh.Queryable:
    """Answer queries on ``key`` with ``await handler(request)``; any exception becomes an error reply."""
    loop = asyncio.get_running_loop()

    async def answer(query: zenoh.Query) -> None:
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            reply = await handler(unpack(payload))
            query.reply(str(query.key_expr), pack(reply))
        except Exception as exc:  # noqa: BLE001 - a bad request must never stop the service
            query.reply_err(pack({"error": type(exc).__name__, "message": str(exc)}))
        finally:
            query.drop()

    return session.declare_queryable(key, lambda q: loop.call_soon_threadsafe(loop.create_task, answer(q)))


async def ask(session: zenoh.Session, key: str, request: Any, timeout: float = 5.0) -> Any:
    """Send one request and return the first reply; raises :class:`RemoteError` or :class:`NoReply`."""
    payload = pack(request)

    def get() -> tuple[bool, bytes] | None:
        for reply in session.get(key, payload=payload, timeout=timeout):
            if reply.ok is not None:
                return True, reply.ok.payload.to_bytes()
            return False, reply.err.payload.to_bytes()
        return None

    result = await asyncio.to_thread(get)
    if result is None:
        raise NoReply(f"no answer on {key} within {timeout:g} s")
    ok, body = result
    if not ok:
        raise RemoteError(_error_text(body))
    return unpack(body)


def _error_text(body: bytes) -> str:
    try:
        err = unpack(body)
        return f"{err['error']}: {err['message']}"
    except (BusError, KeyError, TypeError):
        return body.decode("utf-8", "replace")
