"""The ``agent`` node each agent keeps in the working memory, as DSR agents do.

The node is named after the agent and holds ``pid``, ``host``, ``replica``,
``alive_since`` and, refreshed every ``period`` seconds as volatile attributes,
``cpu`` (percent of one core) and ``memory`` (resident MB). An edge ``has``
links it from the ``world`` node once there is one.

It is deleted when the agent exits cleanly. When the agent dies without
exiting (``kill -9``), the surviving members delete it on ``member_left``
(:mod:`wm.reaper`). A node deleted while its agent is alive (say, during
a network partition) is re-created at the next refresh.
"""

from __future__ import annotations

import os
import socket
import time

import psutil

from wm import Graph, NodeNotFoundError
from wm.reaper import AGENT_TYPE, reap, reap_absent

from .logs import AgentLogger

WORLD_TYPE = "world"
LINK_TYPE = "has"
MB = 1_000_000


class AgentNode:
    """Creates, refreshes, links and finally deletes one agent's ``agent`` node."""

    def __init__(self, g: Graph, agent: str, log: AgentLogger, period: float = 1.0) -> None:
        self.g = g
        self.agent = agent
        self.name = agent
        self.log = log
        self.period = period
        self.alive_since = time.time()
        self._process = psutil.Process(os.getpid())
        self._process.cpu_percent(None)  # the first reading only starts the measurement

    async def start(self) -> None:
        """Remove stale nodes of replicas no longer alive, then create ours."""
        if self.g.network is not None:
            live = set(await self.g.network.live_members()) | {self.g.replica_id}
            stale = reap_absent(self.g, live)
            if stale:
                self.log.info("deleted agent nodes of replicas no longer alive", nodes=",".join(stale))
        await self.ensure()

    async def ensure(self) -> None:
        """Create the node if it is missing, refresh its load, and link it from the world."""
        node = self.g.find_node(self.name)
        if node is None or node.type != AGENT_TYPE or node.get("replica") != self.g.replica_id:
            await self._create(node is not None)
        self.g.update_node(self.name, self._load())
        self.link()

    async def _create(self, name_taken: bool) -> None:
        if name_taken:
            await self._resolve_name_clash()
        static = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "replica": self.g.replica_id,
            "alive_since": self.alive_since,
        }
        self.g.insert_node(AGENT_TYPE, self.name, {**static, **self._load()})
        self.log.info("agent node created", node=self.name, replica=self.g.replica_id)

    async def _resolve_name_clash(self) -> None:
        """Our name is held by another node: a dead replica's node is deleted; otherwise we take a new name."""
        holder = self.g.get_node(self.name)
        owner = holder.get("replica")
        live = set(await self.g.network.live_members()) if self.g.network is not None else set()
        if holder.type == AGENT_TYPE and owner not in live:
            reap(self.g, str(owner))
            self.log.info("deleted the agent node of a replica no longer alive", node=self.name, replica=owner)
            return
        self.name = f"{self.agent}.{self.g.replica_id}"
        self.log.warning(
            "node name taken by a live replica; using another name", taken=self.agent, holder=owner, node=self.name
        )

    def _load(self) -> dict[str, float]:
        with self._process.oneshot():
            return {"cpu": self._process.cpu_percent(None), "memory": self._process.memory_info().rss / MB}

    def link(self) -> None:
        """Create the ``has`` edge from the world node, if both exist and it does not."""
        worlds = self.g.nodes(WORLD_TYPE)
        if not worlds or self.g.find_node(self.name) is None:
            return
        if self.g.find_edge(worlds[0].id, self.name, LINK_TYPE) is None:
            self.g.insert_or_assign_edge(worlds[0].id, self.name, LINK_TYPE, {"updated_at": time.time()})

    async def remove(self) -> None:
        """Delete our node and wait (briefly) until a peer has it."""
        try:
            self.g.delete_node(self.name)
        except NodeNotFoundError:
            return
        if self.g.network is not None:
            await self.g.network.confirm(timeout=1.0)
        self.log.info("agent node deleted", node=self.name)
