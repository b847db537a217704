"""Replication across real processes over real Zenoh on loopback (multicast scouting off)."""

from __future__ import annotations

from pathlib import Path

from procs import PYTHON, REPO, WM, Proc, endpoint, free_port, read_dump, wait_until

REPLICA = str(REPO / "tests" / "replica_proc.py")
GRAPH = "test"


def start_serve(spawner, data: Path, port: int, *extra: str, name: str = "serve") -> Proc:
    proc = spawner([*WM, "serve", "--data", str(data), "--graph", GRAPH, "--listen", endpoint(port), *extra], name=name)
    proc.wait_line("wm serve: ready", 20)
    return proc


def start_replica(spawner, tmp: Path, name: str, *args: str) -> tuple[Proc, Path]:
    dump = tmp / f"{name}.json"
    proc = spawner([PYTHON, REPLICA, "--graph", GRAPH, "--name", name, "--dump", str(dump), *args], name=name)
    proc.wait_line("ready", 20)
    return proc, dump


def graphs(*dumps: Path) -> list[dict | None]:
    return [(d or {}).get("graph") for d in map(read_dump, dumps)]


def node_names(graph: dict | None) -> set[str]:
    return {n["name"] for n in (graph or {}).get("nodes", [])}


def wait_converged(*dumps: Path, names: set[str], timeout: float = 30.0) -> dict:
    """Wait until every dump holds the same graph containing ``names``; returns it."""

    def converged() -> bool:
        current = graphs(*dumps)
        return (
            all(g is not None for g in current)
            and all(g == current[0] for g in current)
            and names <= node_names(current[0])
        )

    def state() -> str:
        return "; ".join(
            f"{d.name}: {len(node_names(g))} nodes, stats {(read_dump(d) or {}).get('stats')}"
            for d, g in zip(dumps, graphs(*dumps), strict=False)
        )

    try:
        wait_until(converged, timeout, f"{[d.name for d in dumps]} to converge on {len(names)} names")
    except BaseException as exc:
        raise AssertionError(f"{exc}; {state()}") from None
    return graphs(*dumps)[0]  # type: ignore[return-value]


def load_world(tmp: Path, port: int) -> None:
    scene = tmp / "world.json"
    scene.write_text(
        '{"format": "cortex-wm", "version": 1, "nodes": [{"id": 1, "type": "world", "name": "world", "attrs": {}}], "edges": []}'
    )
    run_wm("load", str(scene), "--connect", endpoint(port))


def run_wm(*args: str, check: bool = True):
    import subprocess

    result = subprocess.run([*WM, *args, "--graph", GRAPH], capture_output=True, text=True, timeout=60, cwd=REPO)
    if check:
        assert result.returncode == 0, result.stderr
    return result


def test_three_writers_converge_to_identical_graphs(spawner, tmp_path: Path) -> None:
    port = free_port()
    start_serve(spawner, tmp_path / "data", port)
    load_world(tmp_path, port)
    writers = [
        start_replica(
            spawner,
            tmp_path,
            f"w{i}",
            "--connect",
            endpoint(port),
            "--prefix",
            f"w{i}-",
            "--nodes",
            "60",
            "--updates",
            "20",
        )
        for i in range(3)
    ]
    expected = {"world"} | {f"w{i}-{k}" for i in range(3) for k in range(60)}
    final = wait_converged(*(dump for _, dump in writers), names=expected)
    assert len(final["nodes"]) == len(expected)
    assert len([e for e in final["edges"] if e["type"] == "RT"]) == 3 * 20
    served = run_wm("dump", "--format", "json", "--connect", endpoint(port)).stdout
    import json

    assert json.loads(served) == final
    world = next(n for n in final["nodes"] if n["name"] == "world")
    assert world["attrs"]["description"] in {f"w{i}-19" for i in range(3)}


def test_late_joiner_catches_up_after_the_first_replica_exits(spawner, tmp_path: Path) -> None:
    port_a, port_b = free_port(), free_port()
    a, dump_a = start_replica(spawner, tmp_path, "a", "--listen", endpoint(port_a), "--nodes", "100", "--volatile", "5")
    a.wait_line("wrote", 30)
    b, dump_b = start_replica(spawner, tmp_path, "b", "--listen", endpoint(port_b), "--connect", endpoint(port_a))
    reference = wait_converged(dump_a, dump_b, names={f"n{i}" for i in range(100)})
    a.stop()
    c, dump_c = start_replica(spawner, tmp_path, "c", "--connect", endpoint(port_b))
    assert wait_converged(dump_b, dump_c, names=node_names(reference)) == reference
    first = next(n for n in reference["nodes"] if n["name"] == "n0")
    assert first["attrs"]["last_seen"] == 4.0
    wait_until(
        lambda: (read_dump(dump_c) or {}).get("stats", {}).get("caught_up_from") == read_dump(dump_b)["replica"],
        10,
        "c to report b as its catch-up source",
    )


def test_killed_writer_loses_nothing_of_the_others_and_rejoins(spawner, tmp_path: Path) -> None:
    port = free_port()
    start_serve(spawner, tmp_path / "data", port)
    victim, _ = start_replica(
        spawner, tmp_path, "victim", "--connect", endpoint(port), "--prefix", "v", "--nodes", "400", "--pace", "0.01"
    )
    survivor, dump_s = start_replica(
        spawner, tmp_path, "survivor", "--connect", endpoint(port), "--prefix", "s", "--nodes", "150", "--pace", "0.01"
    )
    wait_until(
        lambda: len(node_names(graphs(dump_s)[0]) & {f"v{i}" for i in range(400)}) > 20,
        20,
        "the victim's writes to flow",
    )
    victim_replica = victim.lines[0].split()[1]
    victim.kill9()
    survivor.wait_line("wrote", 30)
    wait_until(
        lambda: victim_replica not in (read_dump(dump_s) or {}).get("members", {}),
        20,
        "the killed replica to leave the membership",
    )
    reborn, dump_r = start_replica(
        spawner, tmp_path, "reborn", "--connect", endpoint(port), "--prefix", "r", "--nodes", "10"
    )
    final = wait_converged(dump_s, dump_r, names={f"s{i}" for i in range(150)} | {f"r{i}" for i in range(10)})
    survivors_view = graphs(dump_s)[0]
    assert final == survivors_view
    assert read_dump(dump_r)["replica"] != victim_replica


def test_deltas_dropped_on_purpose_are_repaired(spawner, tmp_path: Path) -> None:
    port = free_port()
    _, dump_r = start_replica(spawner, tmp_path, "receiver", "--listen", endpoint(port))
    lossy, dump_l = start_replica(
        spawner, tmp_path, "lossy", "--connect", endpoint(port), "--nodes", "30", "--pace", "0.02", "--drop", "5"
    )
    wait_converged(dump_l, dump_r, names={f"n{i}" for i in range(30)})
    stats = read_dump(dump_r)["stats"]
    assert stats["gaps"] + stats["repairs"] >= 1, stats


def test_serve_restarts_from_disk_after_kill_9(spawner, tmp_path: Path) -> None:
    import json
    import time

    port = free_port()
    data = tmp_path / "data"
    serve = start_serve(spawner, data, port)
    load_world(tmp_path, port)
    writer, dump_w = start_replica(
        spawner,
        tmp_path,
        "writer",
        "--connect",
        endpoint(port),
        "--nodes",
        "200",
        "--updates",
        "10",
        "--volatile",
        "30",
    )
    assert writer.wait_line("wrote", 30) == "wrote True"
    time.sleep(0.3)  # the promise covers writes applied more than 100 ms before the kill
    reference = graphs(dump_w)[0]
    serve.kill9()
    writer.stop()
    start_serve(spawner, data, port, name="serve-again")
    restored = json.loads(run_wm("dump", "--format", "json", "--connect", endpoint(port)).stdout)
    assert restored == reference
    assert next(n for n in restored["nodes"] if n["name"] == "n0")["attrs"]["last_seen"] == 29.0


def test_cli_reports_one_line_when_nothing_answers(tmp_path: Path) -> None:
    port = free_port()
    for command in (["dump"], ["members"], ["set", "world", "pos_x=1"], ["rm", "world"]):
        result = run_wm(*command, "--connect", endpoint(port), "--timeout", "1", check=False)
        assert result.returncode == 1
        assert "Traceback" not in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_partition_with_writes_on_both_sides_heals_with_nothing_lost(spawner, tmp_path: Path) -> None:
    """Two routers (``wm serve``) linked through a TCP relay that the test cuts and heals.

    The partition is made by cutting the Zenoh link between the two routers; the
    writers are Zenoh clients of their own router, so no other path exists.
    """
    from tcp_relay import TcpRelay

    port_1, port_2 = free_port(), free_port()
    start_serve(spawner, tmp_path / "r1", port_1, name="router-1")
    relay = TcpRelay(port_1)
    try:
        start_serve(spawner, tmp_path / "r2", port_2, "--connect", endpoint(relay.port), name="router-2")
        left, dump_l = start_replica(
            spawner, tmp_path, "left", "--connect", endpoint(port_1), "--mode", "client", "--prefix", "before-"
        )
        right, dump_r = start_replica(
            spawner,
            tmp_path,
            "right",
            "--connect",
            endpoint(port_2),
            "--mode",
            "client",
            "--prefix",
            "r",
            "--nodes",
            "5",
        )
        wait_converged(dump_l, dump_r, names={f"r{i}" for i in range(5)})

        relay.cut()
        wait_until(
            lambda: len((read_dump(dump_l) or {}).get("members", {})) <= 2,
            30,
            "the partition to show in the membership",
        )
        left_during, dump_ld = start_replica(
            spawner,
            tmp_path,
            "left-during",
            "--connect",
            endpoint(port_1),
            "--mode",
            "client",
            "--prefix",
            "L",
            "--nodes",
            "20",
        )
        right_during, dump_rd = start_replica(
            spawner,
            tmp_path,
            "right-during",
            "--connect",
            endpoint(port_2),
            "--mode",
            "client",
            "--prefix",
            "R",
            "--nodes",
            "20",
        )
        left_during.wait_line("wrote", 30)
        right_during.wait_line("wrote", 30)
        assert not node_names(graphs(dump_l)[0]) & {f"R{i}" for i in range(20)}, "the partition leaked"

        relay.heal()
        everything = {f"r{i}" for i in range(5)} | {f"L{i}" for i in range(20)} | {f"R{i}" for i in range(20)}
        wait_converged(dump_l, dump_r, dump_ld, dump_rd, names=everything, timeout=60)
    finally:
        relay.close()
