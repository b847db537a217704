"""Messages beside the graph: msgpack maps over Zenoh, published, subscribed, served and asked from asyncio.

A :class:`Messaging` holds one Zenoh session for an agent (the runtime makes one
per agent; ``Agent.subscribe`` and the rest delegate to it) or for a bridge. As
with rclpy's ``create_subscription`` and ``create_service``, its owner declares
subscriptions and services, and :meth:`Messaging.start` declares them to run
in the owner's task group (or, for an owner without one, a :class:`TaskSet`):

* a subscription's handler gets the decoded messages in order, one at a time;
  its backlog is bounded (the oldest message is dropped, and the drop logged);
* a service's handler runs in its own task for each query, and its return
  value is the reply; a request that cannot be decoded or handled gets an
  error reply ``{"error": type, "message": text}`` and the service carries on;
  a service declared with :meth:`Messaging.serve_progress` may also send
  replies on the way (progress), each at once, which an asker that wants them
  gets in order before the final reply;
* a handler that fails is logged through the owner's guard, never raised.

On the way out, the owner's task group cancels and awaits the handlers (a
sample or query that arrives meanwhile is dropped), then :meth:`Messaging.close`
undeclares everything, once nothing that publishes is running any more.

Every payload is a msgpack map (:func:`pack`, :func:`unpack`). A ``decode``
function turns the map into a typed message and raises on bad input: a sample
it refuses is logged and dropped, a request it refuses gets an error reply, and
a reply it refuses raises its error in :meth:`Messaging.ask`.

Zenoh has no asyncio API: its callbacks arrive on Zenoh's threads and are handed
to the event loop with ``call_soon_threadsafe``; ``session.get`` runs in a worker thread.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import Awaitable, Callable, Coroutine
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

import msgpack
import zenoh

log = logging.getLogger(__name__)
T = TypeVar("T")
#: Sends one progress reply to the query being answered, at once.
Progress = Callable[[Any], None]
#: The attachment that marks a reply as progress, with the final reply still to come.
PROGRESS = b"progress"
#: Awaits ``method(*args)`` on behalf of the handler named ``what``; logs a failure and returns False, never raises.
Guard = Callable[..., Awaitable[bool]]


class MessageError(Exception):
    """A payload could not be decoded, or a request got an error reply or none."""


class RemoteError(MessageError):
    """The service answered a request with an error."""


class NoReply(MessageError):
    """Nobody answered a request: nobody serves the key, or nobody answered in time."""


def pack(message: Any) -> bytes:
    """msgpack bytes of a message (tuples become lists)."""
    packed: bytes = msgpack.packb(message, use_bin_type=True)
    return packed


def unpack(payload: bytes) -> Any:
    """Decode msgpack bytes; raises :class:`MessageError` on garbage."""
    try:
        return msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except (ValueError, msgpack.UnpackException, TypeError) as exc:
        raise MessageError(f"payload is not valid msgpack: {exc}") from None


def plain(message: Any) -> Any:
    """The default decoder: the message as msgpack gave it."""
    return message


def logging_guard(logger: logging.Logger) -> Guard:
    """A guard for owners without their own (bridges): a failure is logged with its traceback."""

    async def guard(what: str, method: Callable[..., Awaitable[None]], *args: Any) -> bool:
        try:
            await method(*args)
            return True
        except Exception:
            logger.exception("%s failed", what)
            return False

    return guard


class Spawner(Protocol):
    """Where handlers run: an :class:`asyncio.TaskGroup` or a :class:`TaskSet`."""

    def create_task(self, coro: Coroutine[Any, Any, T], *, name: str | None = None) -> asyncio.Task[T]: ...


class TaskSet:
    """Tasks started outside a task group, each kept referenced until it is done."""

    def __init__(self) -> None:
        self._tasks: set[asyncio.Task[Any]] = set()

    def create_task(self, coro: Coroutine[Any, Any, T], *, name: str | None = None) -> asyncio.Task[T]:
        task = asyncio.get_running_loop().create_task(coro, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    async def aclose(self) -> None:
        """Cancel the tasks still running and wait until they are done."""
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)


class Publisher:
    """A declared publisher of msgpack messages on one key."""

    def __init__(self, publisher: zenoh.Publisher) -> None:
        self._publisher = publisher

    def put(self, message: Any) -> None:
        self._publisher.put(pack(message))


@dataclass
class _Inbox:
    """A subscription's bounded backlog: when full, the oldest message is dropped and counted."""

    maxsize: int
    items: deque[Any] = field(default_factory=deque)
    dropped: int = 0
    ready: asyncio.Event = field(default_factory=asyncio.Event)

    def put(self, item: Any) -> None:
        if len(self.items) >= self.maxsize:
            self.items.popleft()
            self.dropped += 1
        self.items.append(item)
        self.ready.set()

    async def get(self) -> Any:
        while not self.items:
            self.ready.clear()
            await self.ready.wait()
        return self.items.popleft()


@dataclass(frozen=True)
class _Subscription:
    key: str
    handler: Callable[[Any], Awaitable[None]]
    decode: Callable[[Any], Any]
    maxsize: int


@dataclass(frozen=True)
class _Service:
    key: str
    handler: Callable[[Any, Progress], Awaitable[Any]]
    decode: Callable[[Any], Any]


class Messaging:
    """Typed msgpack messaging over one Zenoh session; see the module documentation."""

    def __init__(self, session: zenoh.Session | None, guard: Guard | None = None) -> None:
        self.session = session
        self._guard = guard or logging_guard(log)
        self._subscriptions: list[_Subscription] = []
        self._services: list[_Service] = []
        self._inputs: list[zenoh.Subscriber[Any] | zenoh.Queryable[Any]] = []
        self._publishers: list[zenoh.Publisher] = []
        self._tasks: Spawner | None = None

    def _session(self) -> zenoh.Session:
        if self.session is None:
            raise RuntimeError("no Zenoh session: messages need a connected agent")
        return self.session

    # -- declaring ---------------------------------------------------------------------------------

    def publisher(self, key: str, *, express: bool = False) -> Publisher:
        """Declare a publisher on ``key`` (``express``: send each message at once, unbatched)."""
        publisher = self._session().declare_publisher(key, express=express)
        self._publishers.append(publisher)
        return Publisher(publisher)

    def subscribe(
        self,
        key: str,
        handler: Callable[[T], Awaitable[None]],
        *,
        decode: Callable[[Any], T] = plain,
        maxsize: int = 1024,
    ) -> None:
        """Run ``await handler(decode(message))`` for every message on ``key``, in order, one at a time."""
        self._session()
        sub = _Subscription(key, handler, decode, maxsize)
        self._subscriptions.append(sub)
        if self._tasks is not None:
            self._start_subscription(sub, self._tasks)

    def serve(self, key: str, handler: Callable[[T], Awaitable[Any]], *, decode: Callable[[Any], T] = plain) -> None:
        """Answer each query on ``key`` with ``await handler(decode(request))``; an exception is an error reply."""

        async def answer(request: T, _progress: Progress) -> Any:
            return await handler(request)

        self.serve_progress(key, answer, decode=decode)

    def serve_progress(
        self, key: str, handler: Callable[[T, Progress], Awaitable[Any]], *, decode: Callable[[Any], T] = plain
    ) -> None:
        """:meth:`serve`, the handler also given a function that sends a progress reply at once (see :meth:`ask`)."""
        self._session()
        service = _Service(key, handler, decode)
        self._services.append(service)
        if self._tasks is not None:
            self._start_service(service, self._tasks)

    # -- asking ------------------------------------------------------------------------------------

    async def ask(
        self,
        key: str,
        request: Any,
        *,
        decode: Callable[[Any], T] = plain,
        timeout: float = 5.0,
        progress: Callable[[T], None] | None = None,
    ) -> T:
        """Send one request and return ``decode`` of the first final reply; raises :class:`RemoteError` or
        :class:`NoReply`.

        Progress replies that come before it (see :meth:`serve_progress`) are decoded and handed to
        ``progress`` on the event loop, in order, before this returns; one ``decode`` refuses is logged and
        dropped. Without ``progress`` they are passed over.
        """
        session, payload = self._session(), pack(request)
        loop = asyncio.get_running_loop()

        def deliver(body: bytes) -> None:
            assert progress is not None
            try:
                message = decode(unpack(body))
            except Exception as exc:
                log.warning("dropped a progress reply on %s: %s", key, exc)
                return
            progress(message)

        def get() -> tuple[bool, bytes] | None:
            # Unconsolidated: each reply as it comes (consolidated, progress would wait for the final reply).
            replies = session.get(key, payload=payload, timeout=timeout, consolidation=zenoh.ConsolidationMode.NONE)
            for reply in replies:
                ok, err = reply.ok, reply.err
                if ok is not None and ok.attachment is not None and ok.attachment.to_bytes() == PROGRESS:
                    if progress is not None:
                        loop.call_soon_threadsafe(deliver, ok.payload.to_bytes())
                    continue
                if ok is not None:
                    return True, ok.payload.to_bytes()
                if err is not None:
                    return False, err.payload.to_bytes()
            return None

        sent = time.monotonic()
        result = await asyncio.to_thread(get)
        if result is None:
            waited = time.monotonic() - sent
            if waited < timeout / 2:  # the query ended long before its timeout: it found nobody to ask
                raise NoReply(f"nobody answers on {key} (no process serves it)")
            raise NoReply(f"no answer on {key} within {timeout:g} s")
        ok, body = result
        if not ok:
            raise RemoteError(_error_text(body))
        return decode(unpack(body))

    # -- running -----------------------------------------------------------------------------------

    def start(self, tasks: Spawner) -> None:
        """Declare the subscriptions and services (and those declared later) to run their handlers in ``tasks``."""
        self._tasks = tasks
        for sub in self._subscriptions:
            self._start_subscription(sub, tasks)
        for service in self._services:
            self._start_service(service, tasks)

    def close(self) -> None:
        """Undeclare everything; call it once the task group is done and nothing publishes any more."""
        self._tasks = None
        _undeclare(self._inputs)
        _undeclare(self._publishers)

    def _start_subscription(self, sub: _Subscription, tasks: Spawner) -> None:
        loop = asyncio.get_running_loop()
        inbox = _Inbox(sub.maxsize)

        def deliver(payload: bytes) -> None:
            try:
                message = sub.decode(unpack(payload))
            except Exception as exc:
                log.warning("dropped a sample on %s: %s", sub.key, exc)
                return
            inbox.put(message)

        tasks.create_task(self._consume(sub, inbox), name=f"subscription {sub.key}")
        self._inputs.append(
            self._session().declare_subscriber(
                sub.key, lambda sample: loop.call_soon_threadsafe(deliver, sample.payload.to_bytes())
            )
        )

    async def _consume(self, sub: _Subscription, inbox: _Inbox) -> None:
        name = getattr(sub.handler, "__name__", sub.key)
        reported = 0
        while True:
            message = await inbox.get()
            if inbox.dropped > reported:
                log.warning(
                    "messages dropped on %s: %d (handler %s, %d in total)",
                    sub.key,
                    inbox.dropped - reported,
                    name,
                    inbox.dropped,
                )
                reported = inbox.dropped
            await self._guard(name, sub.handler, message)

    def _start_service(self, service: _Service, tasks: Spawner) -> None:
        loop = asyncio.get_running_loop()

        def hand_off(query: zenoh.Query) -> None:
            answer = self._answer(service, query)
            try:
                tasks.create_task(answer, name=f"query {service.key}")
            except RuntimeError:  # the task group is shutting down: the query gets no answer
                answer.close()
                query.drop()  # type: ignore[no-untyped-call]  # zenoh's stub leaves drop() unannotated

        self._inputs.append(
            self._session().declare_queryable(service.key, lambda query: loop.call_soon_threadsafe(hand_off, query))
        )

    async def _answer(self, service: _Service, query: zenoh.Query) -> None:
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            key = str(query.key_expr)

            def send(message: Any) -> None:
                query.reply(key, pack(message), attachment=PROGRESS)

            reply = await service.handler(service.decode(unpack(payload)), send)
            query.reply(key, pack(reply))
        except Exception as exc:
            log.info("request refused on %s: %s: %s", service.key, type(exc).__name__, exc)
            query.reply_err(pack({"error": type(exc).__name__, "message": str(exc)}))
        finally:
            query.drop()  # type: ignore[no-untyped-call]  # zenoh's stub leaves drop() unannotated


def _undeclare(declared: list[Any]) -> None:
    while declared:
        declared.pop().undeclare()


def _error_text(body: bytes) -> str:
    try:
        err = unpack(body)
        return f"{err['error']}: {err['message']}"
    except (MessageError, KeyError, TypeError):
        return body.decode("utf-8", "replace")
