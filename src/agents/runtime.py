"""The agent runtime: an :class:`Agent` subclass declares what it reacts to; :func:`main` runs it.

::

    from agents.runtime import Agent, every, main, on

    class Perception(Agent):
        name = "perception"

        @classmethod
        def add_arguments(cls, parser):
            parser.add_argument("--rate", type=float, default=15.0)

        async def setup(self):
            self.log.info("starting", people=len(self.g.nodes("person")))
            self.subscribe(f"sensors/{self.args.graph}/frame", self.on_frame)

        @on(kind="node_updated", type="person")
        async def person_moved(self, event):
            ...

        @on(type="person", coalesce=True)
        async def evaluate(self, events):
            ...

        async def on_frame(self, message):
            ...

        @every(1.0)
        async def tick(self):
            ...

    if __name__ == "__main__":
        main(Perception)

Each ``@on`` handler reads its own bounded event stream of the graph: it gets
its events in order, one at a time, and a slow handler never blocks a writer
(when its stream is full the oldest event is dropped, and the drop is logged).
With ``coalesce=True`` it works on the latest state instead: it gets every
event pending as one list, so a burst of events runs it once, and the events
that come while it runs make it run once more. The stream is opened before
:meth:`Agent.setup`, so an agent that reads the graph in ``setup`` misses no
change made after that read.

Beside the graph, an agent talks over Zenoh through the runtime's
:class:`~agents.messaging.Messaging` on the same session (``self.zenoh``):
in ``setup`` it declares ``self.subscribe(key, handler)`` and
``self.serve(key, handler)``, and ``self.publisher(key)``; ``await
self.ask(key, request)`` works anywhere. The runtime runs the subscriptions and
services in its task group and undeclares them on the way out.

A handler or periodic task that raises is logged with its context and the
agent carries on; one that fails ``crash_loop_failures`` times within
``crash_loop_window`` seconds is logged as a ``crash loop``. Everything runs in
one ``asyncio.TaskGroup`` inside ``wm.connect``; SIGINT and SIGTERM stop the
agent cleanly (its ``agent`` node is deleted, ``teardown`` runs, the session is
closed).
"""

from __future__ import annotations

import argparse
import asyncio
import inspect
import signal
import sys
import time
from collections import deque
from collections.abc import Awaitable, Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, NoReturn, TypeVar

import zenoh

import wm
from wm import Event, EventStream, Graph
from wm.events import EventFilter
from wm.net.connection import close_session, open_session
from wm.net.zenoh_config import load_with_environment
from wm.reaper import install_reaper

from . import logs
from .agent_node import AgentNode
from .messaging import Messaging, Progress, Publisher, plain

F = TypeVar("F", bound=Callable[..., Any])
T = TypeVar("T")
ON_ATTR = "_agent_on"
EVERY_ATTR = "_agent_every"


@dataclass(frozen=True)
class EventSpec:
    """What one ``@on`` handler wants: an event filter, the size of its stream, and whether it coalesces."""

    kind: str | tuple[str, ...] | None
    type: str | tuple[str, ...] | None
    name: str | tuple[str, ...] | None
    maxsize: int
    coalesce: bool


def _tuple(value: str | Iterable[str] | None) -> str | tuple[str, ...] | None:
    return value if value is None or isinstance(value, str) else tuple(value)


def on(
    kind: str | Iterable[str] | None = None,
    type: str | Iterable[str] | None = None,
    name: str | Iterable[str] | None = None,
    *,
    maxsize: int = 1024,
    coalesce: bool = False,
) -> Callable[[F], F]:
    """Declare an async method ``handler(self, event)`` for the matching graph events.

    The filter is that of ``Graph.events``: event kinds (``node_added``,
    ``edge_updated``, ``member_left``, ...), node/edge types and node names; each
    takes one value or several. ``maxsize`` bounds the handler's backlog.
    With ``coalesce=True`` the handler is ``handler(self, events)`` and gets
    every pending event at once: one run for a burst, never two at a time.
    """
    EventFilter.of(kind, type, name)  # an unknown kind fails at class definition

    def mark(method: F) -> F:
        if not inspect.iscoroutinefunction(method):
            raise TypeError(f"@on handler {method.__qualname__} must be an async def")
        if hasattr(method, ON_ATTR):
            raise TypeError(f"{method.__qualname__} has two @on; give one @on several kinds/types/names instead")
        setattr(method, ON_ATTR, EventSpec(_tuple(kind), _tuple(type), _tuple(name), maxsize, coalesce))
        return method

    return mark


def every(seconds: float) -> Callable[[F], F]:
    """Declare an async method ``task(self)`` run every ``seconds`` (missed periods are skipped, not queued)."""
    if not seconds > 0:
        raise ValueError(f"@every needs a positive period, got {seconds!r}")

    def mark(method: F) -> F:
        if not inspect.iscoroutinefunction(method):
            raise TypeError(f"@every task {method.__qualname__} must be an async def")
        setattr(method, EVERY_ATTR, float(seconds))
        return method

    return mark


@dataclass
class TaskStats:
    """Counters of one handler or periodic task."""

    runs: int = 0
    failures: int = 0
    dropped: int = 0
    recent_failures: deque[float] = field(default_factory=deque, repr=False)


class Agent:
    """Base class of agents; see the module documentation.

    Class attributes: ``name`` (the default ``--name``), ``status_period``
    (seconds between refreshes of the ``agent`` node), ``crash_loop_failures``
    and ``crash_loop_window``. While running, ``self.g`` is the replicated
    graph, ``self.zenoh`` the Zenoh session it replicates over (None on a local
    graph), ``self.log`` the structured logger, ``self.args`` the parsed command
    line and ``self.stats`` the counters of every handler and periodic task.
    """

    name: str = "agent"
    status_period: ClassVar[float] = 1.0
    crash_loop_failures: ClassVar[int] = 5
    crash_loop_window: ClassVar[float] = 10.0

    def __init__(self, args: argparse.Namespace | None = None, name: str | None = None) -> None:
        self.args = args if args is not None else argparse.Namespace()
        self.name = name or getattr(self.args, "name", None) or type(self).name
        self.log = logs.AgentLogger(self.name)
        self.g: Graph = None  # type: ignore[assignment]  # set by run()
        self.zenoh: zenoh.Session | None = None
        self.messaging = Messaging(None, self._guarded)
        self.stats: dict[str, TaskStats] = {}

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        """Add the agent's own command-line options (override; the default adds none)."""

    async def setup(self) -> None:
        """Called once the graph has caught up and the ``agent`` node exists (override)."""

    async def teardown(self) -> None:
        """Called on the way out, while still connected (override)."""

    # -- messages beside the graph --------------------------------------------

    def subscribe(
        self,
        key: str,
        handler: Callable[[T], Awaitable[None]],
        *,
        decode: Callable[[Any], T] = plain,
        maxsize: int = 1024,
    ) -> None:
        """Run ``await handler(decode(message))`` for every message on ``key`` (see :meth:`Messaging.subscribe`)."""
        self.messaging.subscribe(key, handler, decode=decode, maxsize=maxsize)

    def serve(self, key: str, handler: Callable[[T], Awaitable[Any]], *, decode: Callable[[Any], T] = plain) -> None:
        """Answer each query on ``key`` with ``await handler(decode(request))`` (see :meth:`Messaging.serve`)."""
        self.messaging.serve(key, handler, decode=decode)

    def publisher(self, key: str, *, express: bool = False) -> Publisher:
        """A publisher on ``key``, undeclared by the runtime on the way out."""
        return self.messaging.publisher(key, express=express)

    def serve_progress(
        self, key: str, handler: Callable[[T, Progress], Awaitable[Any]], *, decode: Callable[[Any], T] = plain
    ) -> None:
        """:meth:`serve`, the handler also given a function that sends progress replies (see
        :meth:`Messaging.serve_progress`)."""
        self.messaging.serve_progress(key, handler, decode=decode)

    async def ask(
        self,
        key: str,
        request: Any,
        *,
        decode: Callable[[Any], T] = plain,
        timeout: float = 5.0,
        progress: Callable[[T], None] | None = None,
    ) -> T:
        """Send one request and return ``decode`` of the reply, progress replies to ``progress`` (see
        :meth:`Messaging.ask`)."""
        return await self.messaging.ask(key, request, decode=decode, timeout=timeout, progress=progress)

    # -- declared handlers ----------------------------------------------------

    @classmethod
    def handlers(cls) -> dict[str, EventSpec]:
        return {n: getattr(m, ON_ATTR) for n, m in inspect.getmembers(cls, inspect.isfunction) if hasattr(m, ON_ATTR)}

    @classmethod
    def periodic_tasks(cls) -> dict[str, float]:
        return {
            n: getattr(m, EVERY_ATTR) for n, m in inspect.getmembers(cls, inspect.isfunction) if hasattr(m, EVERY_ATTR)
        }

    # -- running --------------------------------------------------------------

    async def run(self, g: Graph, session: zenoh.Session | None = None) -> None:
        """Run on a graph that is already connected (``wm.connect`` over ``session``), until cancelled."""
        self.g = g
        self.zenoh = self.messaging.session = session
        reaper = install_reaper(g)
        specs = self.handlers()
        streams = {
            handler: g.events(spec.kind, spec.type, spec.name, maxsize=spec.maxsize) for handler, spec in specs.items()
        }
        node = AgentNode(g, self.name, self.log, self.status_period)
        try:
            await node.start()
            await self.setup()
            self.log.info(
                "running",
                replica=g.replica_id,
                handlers=",".join(streams) or "-",
                periodic=",".join(self.periodic_tasks()) or "-",
            )
            async with asyncio.TaskGroup() as tasks:
                self.messaging.start(tasks)
                for handler, stream in streams.items():
                    tasks.create_task(self._consume(handler, stream, specs[handler].coalesce), name=handler)
                for task, period in self.periodic_tasks().items():
                    tasks.create_task(self._repeat(task, period), name=task)
                tasks.create_task(self._repeat_refresh(node), name="agent-node")
        finally:
            reaper.cancel()
            for stream in streams.values():
                stream.close()
            try:
                await self._guarded("teardown", self.teardown)
            finally:
                self.messaging.close()
                await node.remove()

    async def _consume(self, handler: str, stream: EventStream, coalesce: bool) -> None:
        method = getattr(self, handler)
        stats = self.stats.setdefault(handler, TaskStats())
        async for event in stream:
            if stream.dropped > stats.dropped:
                self.log.warning(
                    "events dropped",
                    handler=handler,
                    dropped=stream.dropped - stats.dropped,
                    total=stream.dropped,
                    backlog=len(stream),
                )
                stats.dropped = stream.dropped
            if coalesce:
                burst = [event]
                while (more := stream.get_nowait()) is not None:
                    burst.append(more)
                await self._guarded(handler, method, burst)
            else:
                await self._guarded(handler, method, event)

    async def _repeat(self, task: str, period: float) -> None:
        method = getattr(self, task)
        loop = asyncio.get_running_loop()
        next_run = loop.time()
        while True:
            await self._guarded(task, method)
            next_run += period
            now = loop.time()
            if next_run < now:  # overran: skip the missed periods
                next_run += period * ((now - next_run) // period + 1)
            await asyncio.sleep(next_run - now)

    async def _repeat_refresh(self, node: AgentNode) -> None:
        while True:
            await asyncio.sleep(node.period)
            await self._guarded("agent-node", node.ensure)

    async def _guarded(self, what: str, method: Callable[..., Awaitable[None]], *args: Any) -> bool:
        """Await ``method(*args)``; a failure is logged and counted, never raised."""
        stats = self.stats.setdefault(what, TaskStats())
        stats.runs += 1
        try:
            await method(*args)
            return True
        except Exception as exc:
            self._failed(what, stats, exc, args[0] if args else None)
            return False

    def _failed(self, what: str, stats: TaskStats, exc: Exception, argument: object) -> None:
        stats.failures += 1
        context: dict[str, Any] = {"handler": what, "failures": stats.failures}
        if isinstance(argument, Event):
            context["event"] = str(argument)
        elif isinstance(argument, list):  # a coalesced burst
            context["events"] = len(argument)
        self.log.error("handler failed", exc=exc, **context)
        now = time.monotonic()
        recent = stats.recent_failures
        recent.append(now)
        while recent and recent[0] < now - self.crash_loop_window:
            recent.popleft()
        if len(recent) >= self.crash_loop_failures:
            self.log.error(
                "crash loop",
                handler=what,
                failures=len(recent),
                window=f"{self.crash_loop_window:g}s",
                total=stats.failures,
            )
            recent.clear()


# -- command line -------------------------------------------------------------


def build_parser(agent_class: type[Agent]) -> argparse.ArgumentParser:
    """The command line every agent shares, plus the agent's own options."""
    doc = inspect.getdoc(agent_class) or f"the {agent_class.name} agent"
    parser = argparse.ArgumentParser(prog=_program(agent_class), description=doc)
    parser.add_argument("--graph", default="default", help="graph name (default: %(default)s)")
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable)",
    )
    parser.add_argument(
        "--listen", action="append", default=[], metavar="ENDPOINT", help="Zenoh endpoint to listen on (repeatable)"
    )
    parser.add_argument("--mode", choices=["peer", "client"], help="Zenoh mode (default: the config's, else peer)")
    parser.add_argument(
        "--config", help="Zenoh config file (JSON5, see deploy/zenoh/; placeholders from WM_ZENOH_<NAME>)"
    )
    parser.add_argument(
        "--name", default=agent_class.name, help="agent name, also its node's name (default: %(default)s)"
    )
    parser.add_argument("--ontology", help="ontology file (default: the packaged one)")
    parser.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    agent_class.add_arguments(parser)
    return parser


def _program(agent_class: type[Agent]) -> str | None:
    """``python -m agents.x`` when run as a module, else argparse's default."""
    module: str | None = agent_class.__module__
    if module == "__main__":
        spec = getattr(sys.modules["__main__"], "__spec__", None)
        module = spec.name if spec is not None else None
    return f"python -m {module}" if module else None


async def run_agent(agent: Agent) -> None:
    """Connect as ``agent.args`` says and run ``agent`` until SIGINT/SIGTERM."""
    args = agent.args
    loop = asyncio.get_running_loop()
    task = asyncio.current_task()
    assert task is not None
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, task.cancel)
    ontology = wm.Ontology.load(args.ontology) if getattr(args, "ontology", None) else None
    try:
        config = load_with_environment(args.config)
        session = await open_session(config, connect=args.connect or None, listen=args.listen or None, mode=args.mode)
        try:
            async with wm.connect(
                args.graph,
                config,
                agent.name,
                connect=args.connect or None,
                ontology=ontology,
                session=session,
            ) as g:
                await agent.run(g, session)
        finally:
            await close_session(session)
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def main(agent_class: type[Agent], argv: Sequence[str] | None = None) -> NoReturn:
    """Parse the command line, run the agent until SIGINT/SIGTERM, and exit the process.

    Exit status: 0 after a clean stop, 1 when the agent cannot start (bad
    config, nothing to connect to, a failing ``setup``).
    """
    args = build_parser(agent_class).parse_args(argv)
    logs.configure(args.name, args.log_level)
    agent = agent_class(args)
    try:
        asyncio.run(run_agent(agent))
    except (asyncio.CancelledError, KeyboardInterrupt):
        pass
    except (wm.WMError, OSError, ValueError) as exc:
        agent.log.error("cannot run", exc=exc)
        sys.exit(1)
    except Exception as exc:
        agent.log.error("stopped by an error", exc=exc)
        sys.exit(1)
    agent.log.info("stopped")
    sys.exit(0)
