"""``wm.connect``: a graph replica joined to the network, as an async context manager.

::

    async with wm.connect("home", connect=["tcp/127.0.0.1:7447"], name="perception") as g:
        g.insert_node("person", "alice")

The Zenoh session is opened in a worker thread (Zenoh has no asyncio API) and
is always closed on the way out: on normal exit, on an exception, and on
SIGTERM, which cancels the task that entered the context.
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import sys
import threading
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from pathlib import Path

import zenoh

from ..errors import WMError
from ..graph import Graph
from ..ontology import Ontology
from .replication import Replicator
from .zenoh_config import ConfigSource, Endpoints, Mode, ZenohConfigError, build_config

LOOPBACK_ANY_PORT = "tcp/127.0.0.1:0"
DEFAULT_JOIN_WAIT = 3.0


class ConnectError(WMError):
    """The Zenoh session could not be opened (bad config, or no router answering)."""


def default_agent_name() -> str:
    stem = Path(sys.argv[0]).stem if sys.argv and sys.argv[0] else "python"
    return re.sub(r"[^A-Za-z0-9_.\-]", "_", f"{stem}-{os.getpid()}")


async def open_session(
    config: ConfigSource | None = None,
    *,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    mode: Mode | None = None,
) -> zenoh.Session:
    """Open a Zenoh session (multicast scouting off unless the config file turns it on).

    A peer given neither a config file nor ``listen`` listens on
    ``tcp/127.0.0.1:0``: Zenoh's own default (every interface) advertises
    addresses that other peers on this host cannot use, and the mesh breaks.
    """
    if config is None and not listen and mode in (None, "peer"):
        listen = [LOOPBACK_ANY_PORT]
    try:
        zconfig = build_config(config, connect=connect, listen=listen, mode=mode)
    except ZenohConfigError as exc:
        raise ConnectError(str(exc)) from None
    try:
        return await asyncio.to_thread(zenoh.open, zconfig)
    except zenoh.ZError as exc:
        where = ", ".join([connect] if isinstance(connect, str) else list(connect or [])) or "the configured endpoints"
        raise ConnectError(f"cannot open a Zenoh session via {where}: {exc}") from None


async def close_session(session: zenoh.Session) -> None:
    await asyncio.to_thread(session.close)


@contextmanager
def sigterm_cancels_current_task() -> Iterator[None]:
    """While inside, SIGTERM cancels the current task so that ``finally`` blocks run."""
    loop = asyncio.get_running_loop()
    task = asyncio.current_task()
    usable = (
        threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
    )
    if usable and task is not None:
        loop.add_signal_handler(signal.SIGTERM, task.cancel)
    try:
        yield
    finally:
        if usable and task is not None:
            loop.remove_signal_handler(signal.SIGTERM)


@asynccontextmanager
async def connect(
    graph: str = "default",
    config: ConfigSource | None = None,
    name: str | None = None,
    *,
    connect: Endpoints | None = None,
    listen: Endpoints | None = None,
    mode: Mode | None = None,
    ontology: Ontology | None = None,
    replica: Graph | None = None,
    heartbeat_period: float = 1.0,
    catch_up: bool = True,
    join_wait: float | None = None,
    read_only: bool = False,
    session: zenoh.Session | None = None,
) -> AsyncIterator[Graph]:
    """Yield a :class:`wm.Graph` replica of graph ``graph``, kept in sync with every peer.

    ``config`` is a Zenoh config file, mapping or ``zenoh.Config`` (see
    :func:`wm.net.zenoh_config.build_config`); ``connect``/``listen`` add
    endpoints. ``name`` is the agent name shown in ``g.members()``. The
    replication layer is reachable as ``g.network`` (stats, ``confirm()``).
    ``read_only=True`` joins as a monitor: it receives everything and never
    publishes (local writes stay local and are counted in ``stats.withheld``).

    On entry the replica catches up from a live member. When it was told where
    to connect (``connect`` or a config file), it waits up to ``join_wait``
    seconds (default 3) for the network to show one; a replica that only
    listens is the first of its graph and does not wait.

    ``session``, when given, is an open Zenoh session (:func:`open_session`)
    to replicate over instead of opening one; the caller keeps it, uses it for
    its own messages beside the graph, and closes it.
    """
    if join_wait is None:
        join_wait = DEFAULT_JOIN_WAIT if (connect or config is not None) else 0.0
    g = replica if replica is not None else Graph(ontology)
    own_session = session is None
    if session is None:
        session = await open_session(config, connect=connect, listen=listen, mode=mode)
    replicator = Replicator(
        g, session, graph, name or default_agent_name(), heartbeat_period=heartbeat_period, read_only=read_only
    )
    g.network = replicator
    try:
        with sigterm_cancels_current_task():
            await replicator.start(catch_up=catch_up, join_wait=join_wait)
            yield g
    finally:
        try:
            await replicator.stop()
        finally:
            g.network = None
            if own_session:
                await close_session(session)
