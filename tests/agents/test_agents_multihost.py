"""Agents on three hosts (network namespaces): ``wm serve`` as the router of one, probe agents on the others."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from launch_helpers import (
    agent_nodes,
    load_nodes,
    members,
    probe_stack,
    read_graph,
    start_launch,
)

from netns import NetnsLab, netns_unavailable
from procs import wait_until

_WHY_NOT = netns_unavailable()
pytestmark = pytest.mark.skipif(_WHY_NOT is not None, reason=f"no network namespaces: {_WHY_NOT}")

GRAPH = "hosts"
PORT = 7447  # every namespace has its own port space


@pytest.fixture
def lab():
    with NetnsLab(3, subnet="10.213.78", prefix=f"wma{os.getpid() % 10000}") as lab:
        yield lab


def test_agents_on_two_hosts_converge_through_the_router_host(spawner, lab: NetnsLab, tmp_path: Path) -> None:
    router = f"tcp/{lab.addr(0)}:{PORT}"
    launches = []
    for host, agents in enumerate([(), ("a1",), ("a2",)]):
        file = tmp_path / f"host{host}.toml"
        data = tmp_path / "data" if host == 0 else None
        file.write_text(probe_stack(GRAPH, router, agents, data, tmp_path / f"logs{host}"))
        launches.append(start_launch(spawner, file, tmp_path / f"logs{host}", argv=lab.cmd(host)))
        if host == 0:
            launches[0].proc.wait_line("serve  | wm serve: ready", 30)

    def view(host: int) -> dict:
        return read_graph(GRAPH, router, argv=lab.cmd(host))

    wait_until(lambda: set(agent_nodes(view(2))) == {"a1", "a2"}, 60, "both agent nodes, seen from host 2")
    wait_until(
        lambda: sorted(members(GRAPH, router, lab.cmd(1)).values()) == ["a1", "a2", "serve"],
        30,
        "wm members on host 1 to list serve, a1 and a2",
    )

    load_nodes(tmp_path, GRAPH, router, ("object", "from-host-1"), argv=lab.cmd(1))
    wait_until(
        lambda: all("from-host-1" in str(node.get("description")) for node in agent_nodes(view(2)).values()),
        60,
        "both agents to see the object written on host 1",
    )
    names = [{(n["type"], n["name"]) for n in view(host)["nodes"]} for host in (1, 2)]
    assert names[0] == names[1] == {("object", "from-host-1"), ("agent", "a1"), ("agent", "a2")}
    for launch in reversed(launches):
        assert launch.finish() == 0, launch.proc.output()
