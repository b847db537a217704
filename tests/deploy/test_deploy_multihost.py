"""Several hosts (network namespaces), one router per host, agents as clients of their router."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from deploy_helpers import GRACE_S, PYTHON, ZENOH_DIR, ZPROC, Proc, make_certs

from netns import NetnsLab, netns_unavailable

_WHY_NOT = netns_unavailable()
pytestmark = pytest.mark.skipif(_WHY_NOT is not None, reason=f"no network namespaces: {_WHY_NOT}")

PORT = 7447  # every namespace has its own port space


@pytest.fixture
def lab_factory() -> Iterator[Callable[[int], NetnsLab]]:
    labs: list[NetnsLab] = []

    def _make(n: int) -> NetnsLab:
        lab = NetnsLab(n, prefix=f"wm{len(labs)}x{os.getpid() % 10000}").up()
        labs.append(lab)
        return lab

    yield _make
    for lab in labs:
        lab.down()


def zproc(spawn, lab: NetnsLab, host: int, *args: str, name: str) -> Proc:
    return spawn(argv=lab.cmd(host, PYTHON, str(ZPROC), *args), name=f"{name}@{lab.hosts[host]}")


def test_put_crosses_three_hosts_via_their_routers(spawn, lab_factory) -> None:
    lab = lab_factory(3)
    router, client = str(ZENOH_DIR / "router.json5"), str(ZENOH_DIR / "client.json5")
    routers = []
    for i in range(3):
        # host i connects to the routers of the hosts before it (one link per pair is enough)
        connect = [arg for j in range(i) for arg in ("--connect", f"tcp/{lab.addr(j)}:{PORT}")]
        routers.append(
            zproc(
                spawn, lab, i, "router", router, "LISTEN_HOST=0.0.0.0", f"ROUTER_PORT={PORT}", *connect, name="router"
            )
        )
    for r in routers:
        r.wait_line("READY", 15)
    subs = [
        zproc(spawn, lab, i, "sub", client, "wm/g/delta/**", f"ROUTER_PORT={PORT}", "--timeout", "20", name="sub")
        for i in (1, 2)
    ]
    for s in subs:
        s.wait_line("READY", 15)
    zproc(
        spawn,
        lab,
        0,
        "pub",
        client,
        "wm/g/delta/h0",
        "from-host-0",
        f"ROUTER_PORT={PORT}",
        "--timeout",
        "20",
        name="pub",
    )
    for s in subs:
        line = s.wait_line("SAMPLE", 20)
        assert line.startswith("SAMPLE wm/g/delta/h0 from-host-0 "), line


def test_mtls_and_acl_across_two_hosts(spawn, lab_factory, tmp_path: Path) -> None:
    lab = lab_factory(2)
    certs = tmp_path / "certs"
    for i in range(2):
        agents = ("perception", "intention") if i == 0 else ("planner", "monitor")
        make_certs(certs, "--router-name", f"router-h{i}", "--san", lab.addr(i), *agents)
    acl_router, tls_client = str(ZENOH_DIR / "acl/router.json5"), str(ZENOH_DIR / "tls/client.json5")
    acl_vars = [
        f"CERT_DIR={certs}",
        f"ROUTER_PORT={PORT}",
        'WRITERS=["perception","intention","planner"]',
        'MONITORS=["monitor"]',
        'ROUTERS=["router-h0","router-h1"]',
    ]
    r0 = zproc(spawn, lab, 0, "router", acl_router, "ROUTER_NAME=router-h0", *acl_vars, name="router")
    r1 = zproc(
        spawn,
        lab,
        1,
        "router",
        acl_router,
        "ROUTER_NAME=router-h1",
        *acl_vars,
        "--connect",
        f"tls/{lab.addr(0)}:{PORT}",
        name="router",
    )
    r0.wait_line("READY", 15)
    r1.wait_line("READY", 15)

    def client_args(agent: str) -> list[str]:
        return [f"CERT_DIR={certs}", f"AGENT={agent}", f"ROUTER_PORT={PORT}", "--timeout", "25"]

    at_h0 = zproc(
        spawn,
        lab,
        0,
        "sub",
        tls_client,
        "wm/g/delta/**",
        *client_args("intention"),
        "--count",
        "1000",
        name="intention",
    )
    at_h1 = zproc(
        spawn, lab, 1, "sub", tls_client, "wm/g/delta/**", *client_args("monitor"), "--count", "1000", name="monitor"
    )
    at_h0.wait_line("READY", 15)
    at_h1.wait_line("READY", 15)
    zproc(
        spawn,
        lab,
        1,
        "pub",
        tls_client,
        "wm/g/delta/monitor",
        "from-monitor",
        *client_args("monitor"),
        name="monitor-pub",
    )
    zproc(
        spawn,
        lab,
        0,
        "pub",
        tls_client,
        "wm/g/delta/perception",
        "from-perception",
        *client_args("perception"),
        name="perception",
    )
    zproc(
        spawn, lab, 1, "pub", tls_client, "wm/g/delta/planner", "from-planner", *client_args("planner"), name="planner"
    )

    # host 0 -> host 1, through both routers over mTLS, delivered to a monitor
    at_h1.wait_line("SAMPLE", 20, contains="from-perception")
    # host 1 -> host 0 for a writer ...
    at_h0.wait_line("SAMPLE", 20, contains="from-planner")
    at_h0.wait_line("SAMPLE", 20, contains="from-planner")  # a later one: the monitor's had as long
    time.sleep(GRACE_S)
    # ... but never for the monitor, which kept putting all along
    assert not [line for line in at_h0.lines if "from-monitor" in line], at_h0.lines
