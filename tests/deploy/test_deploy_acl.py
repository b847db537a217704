"""Access control on the router: writers write, monitors only read, strangers get nothing.

Subjects are identified by the CN of the client certificate (mTLS, acl/router.json5).
A second test shows the other identity that works in the Python build: the
username of user/password authentication.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import zenoh
from deploy_helpers import GRACE_S, ZENOH_DIR, Collector, free_port, wait_matching, wait_until

ACL_ROUTER = ZENOH_DIR / "acl/router.json5"
TLS_CLIENT = ZENOH_DIR / "tls/client.json5"
KEY = "wm/g/delta/x"


@pytest.fixture
def acl_router(spawn, pki: Path) -> int:
    port = free_port()
    router = spawn(
        "router",
        str(ACL_ROUTER),
        f"CERT_DIR={pki}",
        "LISTEN_HOST=127.0.0.1",
        f"ROUTER_PORT={port}",
        'WRITERS=["perception","intention"]',
        'MONITORS=["monitor"]',
        'ROUTERS=["router"]',
        name="acl-router",
    )
    router.wait_line("READY", 15)
    return port


@pytest.fixture
def client(acl_router: int, pki: Path, sessions):
    def _client(agent: str) -> zenoh.Session:
        return sessions(TLS_CLIENT, variables={"CERT_DIR": pki, "AGENT": agent, "ROUTER_PORT": acl_router})

    return _client


def test_writer_put_arrives_monitor_put_is_denied(client) -> None:
    writer, other_writer, monitor = client("perception"), client("intention"), client("monitor")
    at_writer, at_monitor = Collector(), Collector()
    other_writer.declare_subscriber("wm/g/delta/**", at_writer, allowed_origin=zenoh.Locality.REMOTE)
    # The monitor may still subscribe, and receives the writer's data.
    monitor.declare_subscriber("wm/g/delta/**", at_monitor, allowed_origin=zenoh.Locality.REMOTE)

    monitor_pub = monitor.declare_publisher(KEY)
    writer_pub = writer.declare_publisher(KEY)
    wait_matching(writer_pub, 10, "both subscribers to be routed to the writer")
    monitor_pub.put("from monitor")
    monitor.delete(KEY)
    writer_pub.put("from writer")
    at_writer.wait_for(lambda p: "from writer" in p, 5, "the writer's put at the other writer")
    at_monitor.wait_for(lambda p: "from writer" in p, 5, "the writer's put at the monitor")
    time.sleep(GRACE_S)
    assert at_writer.items == [(KEY, "from writer")], "the monitor's put or delete got through the ACL"
    assert at_monitor.payloads() == ["from writer"]


def test_monitor_can_query_but_not_serve(client) -> None:
    writer, monitor, other_writer = client("perception"), client("monitor"), client("intention")
    writer.declare_queryable("wm/g/sync/perception", lambda q: q.reply("wm/g/sync/perception", "writer state"))
    monitor.declare_queryable("wm/g/sync/monitor", lambda q: q.reply("wm/g/sync/monitor", "forged state"))

    def answers(session: zenoh.Session) -> list[str]:
        replies = session.get("wm/g/sync/**", timeout=2.0, allowed_destination=zenoh.Locality.REMOTE)
        return sorted(r.ok.payload.to_string() for r in replies if r.ok)

    wait_until(lambda: answers(monitor) == ["writer state"], 10, "the monitor's sync query to be answered")
    # The monitor's queryable was never declared beyond its router: nobody can ask it.
    wait_until(lambda: answers(other_writer) == ["writer state"], 10, "the other writer's sync query")


def test_monitor_liveliness_token_is_not_propagated(client) -> None:
    writer, monitor = client("perception"), client("monitor")
    observer = client("intention")
    tokens = [
        writer.liveliness().declare_token("wm/g/alive/perception"),
        monitor.liveliness().declare_token("wm/g/alive/monitor"),
    ]

    def alive(session: zenoh.Session) -> list[str]:
        return sorted(str(r.ok.key_expr) for r in session.liveliness().get("wm/g/alive/**", timeout=2.0) if r.ok)

    wait_until(lambda: alive(observer) == ["wm/g/alive/perception"], 10, "the writer's token at the observer")
    # The monitor may watch membership (it sees the writer; its own token is only local).
    assert "wm/g/alive/perception" in alive(monitor)
    time.sleep(GRACE_S)
    assert alive(observer) == ["wm/g/alive/perception"]
    for t in tokens:
        t.undeclare()


def test_unlisted_agent_with_valid_cert_can_neither_write_nor_read(client) -> None:
    writer, stranger, monitor = client("perception"), client("stranger"), client("monitor")
    at_stranger, at_monitor = Collector(), Collector()
    stranger.declare_subscriber("wm/**", at_stranger, allowed_origin=zenoh.Locality.REMOTE)
    monitor.declare_subscriber("wm/**", at_monitor, allowed_origin=zenoh.Locality.REMOTE)
    stranger.put(KEY, "from stranger")
    writer_pub = writer.declare_publisher(KEY)
    wait_matching(writer_pub, 10, "the monitor's subscriber")
    writer_pub.put("from writer")
    at_monitor.wait_for(lambda p: "from writer" in p, 5, "the writer's put at the monitor")
    time.sleep(GRACE_S)
    assert at_monitor.payloads() == ["from writer"]
    assert at_stranger.payloads() == []


def test_acl_by_username(sessions, tmp_path: Path) -> None:
    """user/password authentication gives the ACL a username to match (no TLS needed for identity)."""
    users = tmp_path / "users.txt"
    users.write_text("perception:writer-secret\nmonitor:monitor-secret\n")
    port = free_port()
    rules = [
        {"id": "rw", "permission": "allow", "messages": ["put", "declare_subscriber"], "key_exprs": ["wm/**"]},
        {
            "id": "sub-in",
            "permission": "allow",
            "flows": ["ingress"],
            "messages": ["declare_subscriber"],
            "key_exprs": ["wm/**"],
        },
        {"id": "put-out", "permission": "allow", "flows": ["egress"], "messages": ["put"], "key_exprs": ["wm/**"]},
    ]
    acl = {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{"id": "writers", "usernames": ["perception"]}, {"id": "monitors", "usernames": ["monitor"]}],
        "policies": [
            {"id": "w", "rules": ["rw"], "subjects": ["writers"]},
            {"id": "m", "rules": ["sub-in", "put-out"], "subjects": ["monitors"]},
        ],
    }
    sessions(
        mode="router",
        listen=[f"tcp/127.0.0.1:{port}"],
        overrides={"transport/auth/usrpwd": {"dictionary_file": str(users)}, "access_control": acl},
    )

    def user(name: str, password: str) -> zenoh.Session:
        return sessions(
            mode="client",
            connect=[f"tcp/127.0.0.1:{port}"],
            overrides={"transport/auth/usrpwd": {"user": name, "password": password}, "connect/timeout_ms": 1500},
        )

    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        user("perception", "wrong password")
    writer, monitor, observer = (
        user("perception", "writer-secret"),
        user("monitor", "monitor-secret"),
        user("perception", "writer-secret"),
    )
    at_observer, at_monitor = Collector(), Collector()
    observer.declare_subscriber("wm/**", at_observer, allowed_origin=zenoh.Locality.REMOTE)
    monitor.declare_subscriber("wm/**", at_monitor, allowed_origin=zenoh.Locality.REMOTE)
    monitor.put(KEY, "from monitor")
    pub = writer.declare_publisher(KEY)
    wait_matching(pub, 10, "subscribers at the writer")
    pub.put("from writer")
    at_observer.wait_for(lambda p: "from writer" in p, 5, "the writer's put at the observer")
    at_monitor.wait_for(lambda p: "from writer" in p, 5, "the writer's put at the monitor")
    time.sleep(GRACE_S)
    assert at_observer.payloads() == ["from writer"]
