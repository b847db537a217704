"""Reaping the ``agent`` nodes of replicas that have left the graph.

Every agent keeps an ``agent`` node whose ``replica`` attribute is its replica
id (see :mod:`agents.agent_node`). When a member leaves, cleanly or by
``kill -9`` (its Zenoh liveliness token disappears), every surviving member
that runs :func:`install_reaper` (agents and ``wm serve``) deletes the nodes
naming that replica. Deletes of one node by several replicas merge, so it does
not matter how many of them do it.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Collection

from .errors import NodeNotFoundError
from .events import Event, Subscription
from .graph import Graph

log = logging.getLogger(__name__)
AGENT_TYPE = "agent"


def agent_nodes_of(g: Graph, replica: str) -> list[str]:
    """Names of the ``agent`` nodes that belong to ``replica``."""
    return [node.name for node in g.nodes(AGENT_TYPE) if node.get("replica") == replica]


def reap(g: Graph, replica: str) -> list[str]:
    """Delete the ``agent`` nodes of ``replica``; returns the names deleted here."""
    deleted = []
    for name in agent_nodes_of(g, replica):
        try:
            g.delete_node(name)
        except NodeNotFoundError:
            continue
        deleted.append(name)
    return deleted


def reap_absent(g: Graph, live: Collection[str]) -> list[str]:
    """Delete the ``agent`` nodes whose replica is not in ``live``; returns their names."""
    deleted = []
    for replica in {node.get("replica") for node in g.nodes(AGENT_TYPE)} - set(live):
        if isinstance(replica, str):
            deleted += reap(g, replica)
    return deleted


def install_reaper(g: Graph) -> Subscription:
    """On every ``member_left``, delete that replica's ``agent`` nodes (on the next loop turn).

    Must be called on the asyncio loop thread that owns ``g``. Cancel the
    returned subscription to stop.
    """
    loop = asyncio.get_running_loop()

    def reap_later(event: Event) -> None:
        loop.call_soon(_reap_logged, g, event.writer, event.name)

    return g.on(reap_later, kind="member_left")


def _reap_logged(g: Graph, replica: str, agent: str | None) -> None:
    deleted = reap(g, replica)
    if deleted:
        log.info("member %s (%s) left; deleted agent node(s) %s", replica, agent, ", ".join(deleted))
