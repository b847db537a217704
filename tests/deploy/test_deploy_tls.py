"""mTLS: only clients with a certificate from the deployment's CA get in."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import zenoh
from deploy_helpers import ZENOH_DIR, Collector, free_port, wait_matching

from wm.net.zenoh_config import build_config

TLS_ROUTER = ZENOH_DIR / "tls/router.json5"
TLS_CLIENT = ZENOH_DIR / "tls/client.json5"
OPEN_TIMEOUT_MS = 1500


@pytest.fixture
def tls_router(spawn, pki: Path) -> int:
    port = free_port()
    router = spawn(
        "router", str(TLS_ROUTER), f"CERT_DIR={pki}", "LISTEN_HOST=127.0.0.1", f"ROUTER_PORT={port}", name="tls-router"
    )
    router.wait_line("READY", 15)
    return port


def assert_cannot_open(config: zenoh.Config) -> str:
    """The session open must fail, within the connect timeout plus a margin."""
    started = time.monotonic()
    try:
        session = zenoh.open(config)
    except zenoh.ZError as e:
        elapsed = time.monotonic() - started
        assert elapsed < OPEN_TIMEOUT_MS / 1000 + 10, f"open took {elapsed:.1f} s to fail"
        return str(e)
    session.close()
    pytest.fail("the session opened although the router must refuse it")


def test_client_with_valid_cert_exchanges_data(tls_router: int, pki: Path, sessions) -> None:
    vars_ = {"CERT_DIR": pki, "ROUTER_PORT": tls_router}
    sub_side = sessions(TLS_CLIENT, variables={**vars_, "AGENT": "monitor"})
    pub_side = sessions(TLS_CLIENT, variables={**vars_, "AGENT": "perception"})
    got = Collector()
    sub_side.declare_subscriber("wm/g/delta/**", got, allowed_origin=zenoh.Locality.REMOTE)
    pub = pub_side.declare_publisher("wm/g/delta/perception")
    wait_matching(pub, 10, "the subscriber to be routed over TLS")
    pub.put("over mTLS")
    got.wait_for(lambda p: p == ["over mTLS"], 5, "the put over the mTLS router")
    link = next(iter(pub_side.info.links()))
    assert str(link.src).startswith("tls/") or str(link.dst).startswith("tls/"), link


def test_client_without_cert_is_refused(tls_router: int, pki: Path) -> None:
    # Trusts the CA (so it could verify the router), but presents no certificate.
    config = build_config(
        {
            "mode": "client",
            "connect": {"endpoints": [f"tls/localhost:{tls_router}"], "timeout_ms": OPEN_TIMEOUT_MS},
            "transport": {"link": {"tls": {"root_ca_certificate": str(pki / "ca.pem")}}},
        }
    )
    assert "Unable to connect" in assert_cannot_open(config)


def wrong_ca_client(tls_router: int, pki: Path, other_pki: Path) -> zenoh.Config:
    """A client that trusts our CA but presents a certificate signed by another one."""
    return build_config(
        TLS_CLIENT,
        variables={"CERT_DIR": pki, "AGENT": "perception", "ROUTER_PORT": tls_router},
        overrides={
            "transport/link/tls/connect_certificate": str(other_pki / "perception.pem"),
            "transport/link/tls/connect_private_key": str(other_pki / "perception.key"),
            "connect/timeout_ms": OPEN_TIMEOUT_MS,
        },
    )


def test_client_with_cert_from_another_ca_is_refused(tls_router: int, pki: Path, other_pki: Path) -> None:
    # A certificate with a legitimate-looking CN, signed by the wrong CA. The client
    # trusts our CA, so only the router's check of the client certificate can stop it.
    config = wrong_ca_client(tls_router, pki, other_pki)
    assert "Unable to connect" in assert_cannot_open(config)


def test_client_that_does_not_trust_the_router_is_refused(tls_router: int, other_pki: Path) -> None:
    config = build_config(
        TLS_CLIENT,
        variables={"CERT_DIR": other_pki, "AGENT": "perception", "ROUTER_PORT": tls_router},
        overrides={"connect/timeout_ms": OPEN_TIMEOUT_MS},
    )
    assert "Unable to connect" in assert_cannot_open(config)


def test_plain_tcp_client_is_refused(tls_router: int) -> None:
    config = build_config(
        ZENOH_DIR / "client.json5",
        variables={"ROUTER_PORT": tls_router},
        overrides={"connect/timeout_ms": OPEN_TIMEOUT_MS},
    )
    assert "Unable to connect" in assert_cannot_open(config)


def test_refused_client_put_never_arrives(tls_router: int, pki: Path, other_pki: Path, sessions) -> None:
    """Even if the rogue process goes on (no session), nothing of it reaches legitimate subscribers."""
    sub_side = sessions(TLS_CLIENT, variables={"CERT_DIR": pki, "AGENT": "monitor", "ROUTER_PORT": tls_router})
    got = Collector()
    sub_side.declare_subscriber("wm/**", got, allowed_origin=zenoh.Locality.REMOTE)
    rogue_config = wrong_ca_client(tls_router, pki, other_pki)
    assert_cannot_open(rogue_config)
    legit = sessions(TLS_CLIENT, variables={"CERT_DIR": pki, "AGENT": "perception", "ROUTER_PORT": tls_router})
    pub = legit.declare_publisher("wm/g/delta/perception")
    wait_matching(pub, 10, "the monitor's subscriber")
    pub.put("legit")
    got.wait_for(lambda p: p == ["legit"], 5, "the legitimate put")
    assert got.payloads() == ["legit"]
