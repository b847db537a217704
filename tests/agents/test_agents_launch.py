"""``wm launch`` with ``wm serve`` and probe agents on loopback: membership, agent nodes, kill -9, stop."""

from __future__ import annotations

import os
import signal
from pathlib import Path

from launch_helpers import (
    agent_nodes,
    load_nodes,
    members,
    probe_stack,
    read_graph,
    start_launch,
)

from procs import endpoint, free_port, wait_until

GRAPH = "agents"
AGENTS = ("a1", "a2", "a3")


def described(graph: dict, agent: str) -> str:
    return str(agent_nodes(graph).get(agent, {}).get("description", ""))


def test_launch_serve_and_three_agents_kill_one_and_stop(spawner, tmp_path: Path) -> None:
    router = endpoint(free_port())
    file = tmp_path / "stack.toml"
    file.write_text(probe_stack(GRAPH, router, AGENTS, tmp_path / "data", tmp_path / "unused"))
    launch = start_launch(spawner, file, tmp_path / "logs")
    pids = {name: launch.pid(name) for name in ("serve", *AGENTS)}

    # every agent is a member and keeps an agent node with its pid, replica and load
    wait_until(lambda: set(agent_nodes(read_graph(GRAPH, router))) == set(AGENTS), 60, "three agent nodes")
    nodes = agent_nodes(read_graph(GRAPH, router))
    wait_until(
        lambda: sorted(members(GRAPH, router).values()) == sorted(["serve", *AGENTS]), 30, "wm members to list all"
    )
    listed = members(GRAPH, router)
    for agent in AGENTS:
        assert nodes[agent]["pid"] == pids[agent]
        assert listed[nodes[agent]["replica"]] == agent
        assert nodes[agent]["memory"] > 0 and "cpu" in nodes[agent]

    # the world node links every agent node
    load_nodes(tmp_path, GRAPH, router, ("world", "world"), ("object", "before-kill"))
    wait_until(
        lambda: (
            {e["dst"] for e in read_graph(GRAPH, router).get("edges", []) if e["type"] == "has"}
            == {n["id"] for n in read_graph(GRAPH, router)["nodes"] if n["type"] == "agent"}
        ),
        30,
        "a has edge from the world to each agent node",
    )

    # a handler that raises does not stop its agent
    load_nodes(tmp_path, GRAPH, router, ("object", "boom"))
    load_nodes(tmp_path, GRAPH, router, ("object", "after-boom"))
    wait_until(
        lambda: "after-boom" in described(read_graph(GRAPH, router), "a1"),
        30,
        "a1 to handle an object after the failure",
    )
    assert launch.pid("a1") == pids["a1"]
    assert "handler failed" in launch.log("a1") and 'error="RuntimeError: refusing boom"' in launch.log("a1")

    # kill -9: restarted, rejoins with a new replica, catches up; its old node is gone
    old_replica = nodes["a2"]["replica"]
    os.kill(pids["a2"], signal.SIGKILL)
    restarted = launch.wait("a2", lambda p: p["restarts"] == 1 and p["state"] == "up", "to be restarted")
    assert restarted["pid"] != pids["a2"] and restarted["failures"] == ["killed by SIGKILL"]

    def a2_reborn() -> bool:
        node = agent_nodes(read_graph(GRAPH, router)).get("a2", {})
        return node.get("pid") == restarted["pid"]

    wait_until(a2_reborn, 30, "the restarted a2's agent node")
    graph = read_graph(GRAPH, router)
    assert old_replica not in {n["replica"] for n in agent_nodes(graph).values()}
    assert "before-kill" in described(graph, "a2"), "the new a2 did not catch up"
    new_replica = agent_nodes(graph)["a2"]["replica"]
    wait_until(lambda: members(GRAPH, router).get(new_replica) == "a2", 30, "the new a2 to be a member")
    assert old_replica not in members(GRAPH, router)

    # SIGTERM: everything stops, last started first; a2's crash makes the exit status 1
    assert launch.finish() == 1
    stops = [line.split(":")[0].split("|")[1].strip() for line in launch.proc.lines if ": stopping, SIGTERM" in line]
    assert stops == ["a3", "a2", "a1", "serve"]
    assert "a2: killed by SIGKILL" in launch.proc.output()
    for name, pid in {**pids, "a2": restarted["pid"]}.items():
        assert not Path(f"/proc/{pid}").exists(), f"{name} (pid {pid}) still runs"
    for agent in AGENTS:
        assert "agent node deleted" in launch.log(agent)
