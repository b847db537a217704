"""Agents over mutual TLS with access control: ``wm serve`` is the ACL router (deploy/zenoh/acl/router.json5).

Writers (the probe agent, an in-process writer) have certificates whose CN is in
WRITERS; the monitor's CN is in MONITORS; other clients have no certificate,
or one signed by another CA.
"""

from __future__ import annotations

import asyncio
import subprocess
from pathlib import Path

import pytest
from launch_helpers import PROBE, PROBE_PATH

import wm
from procs import PYTHON, REPO, WM, endpoint, free_port
from wm.net.zenoh_config import load_with_environment

GRAPH = "secure"
TLS_CLIENT = str(REPO / "deploy" / "zenoh" / "tls" / "client.json5")
ACL_ROUTER = str(REPO / "deploy" / "zenoh" / "acl" / "router.json5")


def make_certs(outdir: Path, *agents: str) -> Path:
    subprocess.run(
        ["bash", str(REPO / "deploy" / "certs" / "make-test-certs.sh"), str(outdir), *agents],
        check=True,
        capture_output=True,
        timeout=60,
    )
    return outdir


@pytest.fixture
def secure_stack(spawner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> int:
    """The ACL router (wm serve) and one probe agent; WM_ZENOH_* point this process's clients at it. Its port."""
    pki = make_certs(tmp_path / "pki", "probe1", "writer", "monitor")
    port = free_port()
    common = {"WM_ZENOH_CERT_DIR": str(pki), "WM_ZENOH_ROUTER_PORT": str(port)}
    acl = {
        "WM_ZENOH_LISTEN_HOST": "127.0.0.1",
        "WM_ZENOH_WRITERS": '["probe1","writer"]',
        "WM_ZENOH_MONITORS": '["monitor"]',
        "WM_ZENOH_ROUTERS": '["router"]',
    }
    serve = spawner(
        [*WM, "serve", "--data", str(tmp_path / "data"), "--graph", GRAPH, "--config", ACL_ROUTER],
        name="serve",
        env={**common, **acl},
    )
    serve.wait_line("wm serve: ready", 30)
    spawner(
        [PYTHON, str(PROBE), "--graph", GRAPH, "--config", TLS_CLIENT, "--name", "probe1"],
        name="probe1",
        env={**common, "WM_ZENOH_AGENT": "probe1", "PYTHONPATH": PROBE_PATH},
    )
    for name, value in common.items():
        monkeypatch.setenv(name, value)
    return port


def joined(agent: str, monkeypatch: pytest.MonkeyPatch, **kwargs):
    """``wm.connect`` as the holder of certificate ``agent`` (the TLS client template, variables from WM_ZENOH_*)."""
    monkeypatch.setenv("WM_ZENOH_AGENT", agent)
    return wm.connect(GRAPH, load_with_environment(TLS_CLIENT), agent, **kwargs)


async def until(condition, what: str, timeout: float = 30.0) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    while not condition():
        if loop.time() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")
        await asyncio.sleep(0.05)


def description(g: wm.Graph, agent: str) -> str:
    node = g.find_node(agent)
    return str(node.get("description")) if node is not None else ""


async def test_a_monitor_reads_but_its_writes_are_refused(secure_stack: int, monkeypatch: pytest.MonkeyPatch) -> None:
    async with joined("writer", monkeypatch) as writer:
        await until(lambda: description(writer, "probe1").startswith("tag="), "the probe's agent node at the writer")
        async with joined("monitor", monkeypatch) as monitor:
            await until(lambda: monitor.find_node("probe1") is not None, "the monitor to read the graph")
            monitor.insert_node("object", "intruder")
            monitor.update_node("probe1", {"description": "defaced"})
            assert not await monitor.network.confirm(timeout=3.0), "a replica acknowledged the monitor's writes"
            writer.insert_node("object", "legit")
            assert await writer.network.confirm(timeout=10.0)
            # the probe handles 'legit' and reports every object it holds: the intruder never reached it
            await until(
                lambda: "objects=legit " in description(writer, "probe1"), "the probe to report the writer's object"
            )
            assert writer.find_node("intruder") is None
            assert "defaced" not in description(writer, "probe1")


@pytest.mark.parametrize("how", ["plain tcp", "no certificate", "another CA"])
async def test_a_client_without_a_valid_certificate_cannot_join(
    how: str, secure_stack: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    port = secure_stack
    if how == "plain tcp":
        attempt = wm.connect(GRAPH, name="intruder", connect=[endpoint(port)], mode="client")
    elif how == "no certificate":
        attempt = wm.connect(GRAPH, name="intruder", connect=[f"tls/localhost:{port}"], mode="client")
    else:
        monkeypatch.setenv("WM_ZENOH_CERT_DIR", str(make_certs(tmp_path / "other-pki", "probe1")))
        attempt = joined("probe1", monkeypatch)
    with pytest.raises(wm.ConnectError):
        async with attempt:
            pass
