"""``wm monitor``: a live terminal view of a graph, as a read-only replica.

It shows the members and agents with their health, node and edge counts by
type with update rates, a table of nodes per type with their key attributes
and world position, and a scrolling event log (filtered like ``wm watch``).
When no session can be opened, or nothing has been heard for a while, it says
so and keeps trying; Zenoh re-establishes a dropped link by itself and the
replica catches up from the next heartbeat.
"""

from __future__ import annotations

import asyncio
import time
from collections import Counter, deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from rich.console import Group, RenderableType
from rich.live import Live
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from ..events import Event, EventKind
from ..graph import Graph
from ..net.connection import ConnectError, connect
from ..net.zenoh_config import ConfigSource
from ..ontology import Ontology
from .scene2d import root_node, world_poses

RATE_WINDOW_S = 5.0
STALE_AFTER_S = 3.0


@dataclass
class MonitorState:
    """What the monitor has seen: recent events for rates and the filtered event log."""

    log_size: int = 12
    recent: deque[tuple[float, str]] = field(default_factory=deque)
    log: deque[str] = field(default_factory=deque)
    status: str = "starting"
    last_heard: float = 0.0

    def on_event(self, event: Event, now: float | None = None) -> None:
        """Count a graph event for the update rates (membership changes only count as news)."""
        now = time.monotonic() if now is None else now
        self.last_heard = now
        if event.kind in (EventKind.MEMBER_JOINED, EventKind.MEMBER_LEFT):
            return
        self.recent.append((now, event.type))
        while self.recent and self.recent[0][0] < now - RATE_WINDOW_S:
            self.recent.popleft()

    def on_logged(self, event: Event) -> None:
        """Add an event that passed the filters to the log."""
        self.log.append(f"{time.strftime('%H:%M:%S')} {event}")
        while len(self.log) > self.log_size:
            self.log.popleft()

    def rates(self, now: float | None = None) -> Counter[str]:
        """Events per second by element type over the last few seconds."""
        now = time.monotonic() if now is None else now
        counts = Counter(t for stamp, t in self.recent if stamp >= now - RATE_WINDOW_S)
        return Counter({t: c / RATE_WINDOW_S for t, c in counts.items()})


def _short(value: Any) -> str:
    if isinstance(value, tuple):
        return (
            "("
            + ", ".join(f"{x:.2f}" if isinstance(x, float) else str(x) for x in value[:4])
            + (", …)" if len(value) > 4 else ")")
        )
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def key_attrs(ontology: Ontology, node_type: str, attrs: dict[str, Any] | Any) -> list[str]:
    """The attributes shown for a node type: those its ontology entry lists under ``show``, else the first three."""
    element = ontology.node_types.get(node_type)
    names = (element.show if element is not None else ()) or tuple(
        sorted(a for a in attrs if not a.startswith("rt_"))[:3]
    )
    return list(names)


def members_table(g: Graph) -> Table:
    """Live members, and agent nodes with their health (alive when their replica is a member)."""
    table = Table(title="members and agents", expand=True, title_justify="left")
    for column in ("replica", "agent", "health", "cpu %", "mem MB"):
        table.add_column(column)
    members = g.members()
    agents = {n.get("replica"): n for n in g.nodes("agent")}
    for replica, agent in sorted(members.items(), key=lambda m: m[1]):
        node = agents.get(replica)
        table.add_row(
            replica,
            agent,
            Text("live", style="green"),
            _short(node.get("cpu", "")) if node else "",
            _short(node.get("memory", "")) if node else "",
        )
    for replica, node in agents.items():
        if replica not in members:
            table.add_row(
                str(replica),
                node.name,
                Text("gone", style="red"),
                _short(node.get("cpu", "")),
                _short(node.get("memory", "")),
            )
    return table


def counts_table(g: Graph, state: MonitorState) -> Table:
    table = Table(title="counts and update rates", expand=True, title_justify="left")
    for column in ("type", "nodes", "edges", "updates/s"):
        table.add_column(column, justify="right" if column != "type" else "left")
    nodes = Counter(n.type for n in g.nodes())
    edges = Counter(e.type for e in g.edges())
    rates = state.rates()
    for element_type in sorted(set(nodes) | set(edges) | set(rates)):
        table.add_row(
            element_type,
            str(nodes.get(element_type, "")),
            str(edges.get(element_type, "")),
            f"{rates.get(element_type, 0.0):.1f}",
        )
    return table


def node_tables(g: Graph, max_rows: int = 8) -> list[Table]:
    """One table per node type: name, id, world x/y when placed, and the key attributes."""
    root = root_node(g)
    poses = world_poses(g, root.id) if root is not None else {}
    tables = []
    by_type: dict[str, list[Any]] = {}
    for node in g.nodes():
        by_type.setdefault(node.type, []).append(node)
    for node_type, nodes in sorted(by_type.items()):
        columns = key_attrs(g.ontology, node_type, nodes[0].attrs)
        table = Table(title=f"{node_type} ({len(nodes)})", expand=True, title_justify="left")
        for column in ("name", "id", "x, y", *columns):
            table.add_column(column, overflow="fold")
        for node in nodes[:max_rows]:
            pose = poses.get(node.id)
            where = f"{pose[0]:.2f}, {pose[1]:.2f}" if pose else ""
            table.add_row(node.name, str(node.id), where, *(_short(node.get(c, "")) for c in columns))
        if len(nodes) > max_rows:
            table.add_row(f"… {len(nodes) - max_rows} more", "", "", *("" for _ in columns))
        tables.append(table)
    return tables


def render(g: Graph, state: MonitorState, graph_name: str) -> RenderableType:
    """The whole screen for the current graph and monitor state."""
    stats = g.network.stats if g.network is not None else None
    header = Text.assemble(
        (f"wm monitor · graph {graph_name} · ", "bold"),
        (state.status, "green" if state.status == "live" else "yellow"),
        f" · {g.node_count()} nodes, {len(g.edges())} edges",
        f" · applied {stats.applied}, repairs {stats.repairs}, heartbeats {stats.heartbeats}" if stats else "",
    )
    log = Panel(Text("\n".join(state.log) or "(no events yet)"), title="events", title_align="left")
    return Group(header, members_table(g), counts_table(g, state), log, *node_tables(g))


def _health(g: Graph, state: MonitorState, heartbeats_seen: int) -> str:
    stats = g.network.stats if g.network is not None else None
    if stats is not None and stats.heartbeats > heartbeats_seen:
        state.last_heard = time.monotonic()
    quiet = time.monotonic() - state.last_heard
    return "live" if quiet < STALE_AFTER_S else f"nothing heard for {quiet:.0f} s, waiting for the network"


async def monitor(
    graph_name: str,
    *,
    config: ConfigSource | None = None,
    connect_to: Sequence[str] = (),
    ontology: Ontology | None = None,
    kinds: Iterable[str] | None = None,
    types: Iterable[str] | None = None,
    names: Iterable[str] | None = None,
    refresh: float = 0.5,
) -> None:
    """Show the live view until cancelled, retrying when no session can be opened."""
    state = MonitorState()
    with Live(Text(f"wm monitor: connecting to graph {graph_name!r}…"), auto_refresh=False, screen=True) as live:
        while True:
            try:
                async with connect(
                    graph_name,
                    config,
                    "wm-monitor",
                    connect=list(connect_to) or None,
                    ontology=ontology,
                    read_only=True,
                ) as g:
                    state.last_heard = time.monotonic()
                    g.on(state.on_event)
                    g.on(state.on_logged, kind=kinds, type=types, name=names)
                    seen = 0
                    while True:
                        state.status = _health(g, state, seen)
                        seen = g.network.stats.heartbeats if g.network is not None else seen
                        live.update(render(g, state, graph_name), refresh=True)
                        await asyncio.sleep(refresh)
            except ConnectError as exc:
                state.status = "disconnected"
                live.update(Text(f"wm monitor: {exc}; retrying…", style="yellow"), refresh=True)
                await asyncio.sleep(1.0)
