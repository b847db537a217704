"""One host: peers on loopback, and clients through a router in another process."""

from __future__ import annotations

import zenoh
import zenohctl  # deploy/, put on sys.path by deploy_helpers
from deploy_helpers import DEPLOY, PYTHON, ZENOH_DIR, Collector, free_port, wait_matching, wait_until

from wm.net.zenoh_config import build_config

PEER = ZENOH_DIR / "peer-loopback.json5"
ROUTER = ZENOH_DIR / "router.json5"
CLIENT = ZENOH_DIR / "client.json5"


def test_two_peers_exchange_a_put(sessions) -> None:
    seed_port = free_port()
    a = sessions(PEER, variables={"PORT": seed_port, "SEED_PORT": seed_port})
    b = sessions(PEER, variables={"SEED_PORT": seed_port})
    got = Collector()
    b.declare_subscriber("wm/g/delta/a", got, allowed_origin=zenoh.Locality.REMOTE)
    pub = a.declare_publisher("wm/g/delta/a")
    wait_matching(pub, 10, "peer b's subscriber to be known to peer a")
    pub.put("hello from a")
    got.wait_for(lambda p: p == ["hello from a"], 5, "the put from peer a at peer b")


def test_peers_find_each_other_through_the_seed_by_gossip(sessions) -> None:
    seed_port = free_port()
    seed = sessions(PEER, variables={"PORT": seed_port, "SEED_PORT": seed_port})
    a = sessions(PEER, variables={"SEED_PORT": seed_port})
    b = sessions(PEER, variables={"SEED_PORT": seed_port})
    zid_a, zid_b = str(a.zid()), str(b.zid())
    wait_until(
        lambda: zid_b in {str(z) for z in a.info.peers_zid()},
        10,
        "gossip to connect the two non-seed peers directly",
    )
    # The mesh survives the seed: a and b are connected to each other directly.
    seed.close()
    got = Collector()
    b.declare_subscriber("wm/g/delta/**", got, allowed_origin=zenoh.Locality.REMOTE)
    pub = a.declare_publisher("wm/g/delta/a")
    wait_matching(pub, 10, "b's subscriber after the seed left")
    pub.put("still here")
    got.wait_for(lambda p: "still here" in p, 5, "a's put at b without the seed")
    assert zid_a in {str(z) for z in b.info.peers_zid()}


def test_client_reaches_client_through_router_process(spawn, sessions) -> None:
    port = free_port()
    router = spawn("router", str(ROUTER), "LISTEN_HOST=127.0.0.1", f"ROUTER_PORT={port}", name="router")
    router_zid = router.wait_line("READY", 15).split()[1]
    vars_ = {"ROUTER_PORT": port}
    sub_side = sessions(CLIENT, variables=vars_)
    pub_side = sessions(CLIENT, variables=vars_)
    assert [str(z) for z in sub_side.info.routers_zid()] == [router_zid]
    assert list(sub_side.info.peers_zid()) == []
    got = Collector()
    sub_side.declare_subscriber("wm/g/delta/*", got, allowed_origin=zenoh.Locality.REMOTE)
    pub = pub_side.declare_publisher("wm/g/delta/pub")
    wait_matching(pub, 10, "the subscriber's declaration to reach the publisher via the router")
    pub.put("via router")
    got.wait_for(lambda p: p == ["via router"], 5, "the put routed by the router process")
    # The router is a separate process: stopping it cuts the clients off.
    assert router.stop() == 0
    wait_until(lambda: list(sub_side.info.routers_zid()) == [], 15, "the clients to notice the router is gone")


def test_client_open_fails_without_router() -> None:
    config = build_config(CLIENT, variables={"ROUTER_PORT": free_port()}, overrides={"connect/timeout_ms": 500})
    try:
        session = zenoh.open(config)
    except zenoh.ZError as e:
        assert "Unable to connect" in str(e)
    else:
        session.close()
        raise AssertionError("a client session opened with no router listening")


def test_zenohctl_run_sub_put(spawn) -> None:
    """The command-line steps of docs/deploy.md: a router, a subscriber and a put, three processes."""
    tool = str(DEPLOY / "zenohctl.py")
    port = free_port()
    router = spawn(argv=[PYTHON, tool, "run", str(ROUTER), "LISTEN_HOST=127.0.0.1", f"ROUTER_PORT={port}"], name="run")
    router.wait_line("zenoh router", 15)
    sub = spawn(
        argv=[PYTHON, tool, "sub", str(CLIENT), "wm/demo/**", "--count", "1", "--timeout", "20", f"ROUTER_PORT={port}"],
        name="sub",
    )
    sub.wait_line("subscribed to wm/demo/**", 15)
    put = spawn(argv=[PYTHON, tool, "put", str(CLIENT), "wm/demo/hello", "world", f"ROUTER_PORT={port}"], name="put")
    put.wait_line("put wm/demo/hello world", 15)
    assert sub.wait_line("put ", 10) == "put wm/demo/hello world"
    assert sub.popen.wait(timeout=10) == 0
    assert put.popen.wait(timeout=10) == 0
    assert router.stop() == 0


def test_zenohctl_render_and_check(tmp_path, capsys) -> None:
    out = tmp_path / "client.json5"
    assert (
        zenohctl.main(
            ["render", str(ZENOH_DIR / "tls/client.json5"), "-o", str(out), "CERT_DIR=/certs", "AGENT=perception"]
        )
        == 0
    )
    assert '"/certs/perception.pem"' in out.read_text()
    assert zenohctl.main(["check", str(out)]) == 0
    assert 'connect/endpoints: ["tls/localhost:7447"]' in capsys.readouterr().out
    assert zenohctl.main(["check", str(ZENOH_DIR / "tls/client.json5")]) == 2
    assert "no value for template variable(s) AGENT, CERT_DIR" in capsys.readouterr().err
