"""wm.net.zenoh_config: building configs from files, mappings and endpoints; placeholders; errors.
The deploy templates, and the NAME=VALUE variables of deploy/zenohctl.py."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import zenoh
from deploy_helpers import ZENOH_DIR
from zenohctl import main as zenohctl
from zenohctl import parse_variables

from wm.errors import WMError
from wm.net.zenoh_config import (
    ZenohConfigError,
    build_config,
    environment_variables,
    load_with_environment,
    read_config,
)

TEMPLATES = sorted(p.relative_to(ZENOH_DIR).as_posix() for p in ZENOH_DIR.rglob("*.json5"))
ALL_VARS = {
    "CERT_DIR": "/etc/cortex-wm/certs",
    "AGENT": "perception",
    "WRITERS": ["perception", "intention"],
    "MONITORS": ["monitor"],
    "ROUTERS": ["router"],
}


def get(config: zenoh.Config, key: str) -> object:
    return json.loads(config.get_json(key))


def test_templates_exist() -> None:
    assert set(TEMPLATES) == {
        "peer-loopback.json5",
        "router.json5",
        "client.json5",
        "tls/router.json5",
        "tls/client.json5",
        "acl/router.json5",
    }


@pytest.mark.parametrize("name", TEMPLATES)
def test_every_template_renders_to_a_valid_config(name: str, tmp_path: Path) -> None:
    out = tmp_path / "out.json5"
    assigned = [f"{k}={json.dumps(v) if isinstance(v, list) else v}" for k, v in ALL_VARS.items()]
    assert zenohctl(["render", str(ZENOH_DIR / name), "-o", str(out), *assigned]) == 0
    assert "${" not in out.read_text()
    config = build_config(out)
    assert get(config, "scouting/multicast/enabled") is False
    assert get(config, "mode") in ("peer", "client", "router")


def test_missing_variable_is_named(tmp_path: Path) -> None:
    with pytest.raises(ZenohConfigError, match=r"AGENT.*CERT_DIR|CERT_DIR.*AGENT"):
        build_config(ZENOH_DIR / "tls/client.json5")


def test_defaults_and_whole_string_values(tmp_path: Path) -> None:
    path = tmp_path / "t.json5"
    path.write_text('{a: "tcp/${H:-127.0.0.1}:${P}", b: "${L}", c: "${N}", d: "${B}", e: "on=${B}"} // ${NOT_A_VAR}')
    out = read_config(path, {"P": 7447, "L": ["x", "y"], "N": 3, "B": True})
    assert out == {"a": "tcp/127.0.0.1:7447", "b": ["x", "y"], "c": 3, "d": True, "e": "on=true"}
    with pytest.raises(ZenohConfigError, match="L is a list"):
        read_config({"a": "x${L}"}, {"L": ["x"]})


def test_missing_file() -> None:
    with pytest.raises(ZenohConfigError, match="not found: /nonexistent/zenoh.json5"):
        build_config("/nonexistent/zenoh.json5")


def test_invalid_json5(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: 'peer', listen: ")
    with pytest.raises(ZenohConfigError, match=r"invalid Zenoh JSON5 config in .*bad\.json5"):
        build_config(bad)


def test_unknown_key_is_reported(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json5"
    bad.write_text("{ transport: { link: { tls: { client_auth: true } } } }")
    with pytest.raises(ZenohConfigError, match="unknown field `client_auth`"):
        build_config(bad)


def test_not_a_json5_object(tmp_path: Path) -> None:
    bad = tmp_path / "list.json5"
    bad.write_text("[1, 2]")
    with pytest.raises(ZenohConfigError, match="expected an object, not list"):
        build_config(bad)


def test_zenoh_config_error_is_a_value_error_and_a_wm_error() -> None:
    assert issubclass(ZenohConfigError, ValueError)
    assert issubclass(ZenohConfigError, WMError)


def test_multicast_off_unless_file_says_otherwise(tmp_path: Path) -> None:
    plain = tmp_path / "plain.json5"
    plain.write_text("{ mode: 'peer' }")
    assert get(build_config(plain), "scouting/multicast/enabled") is False
    on = tmp_path / "on.json5"
    on.write_text("{ mode: 'peer', scouting: { multicast: { enabled: true } } }")
    assert get(build_config(on), "scouting/multicast/enabled") is True
    assert get(build_config({"mode": "peer"}), "scouting/multicast/enabled") is False
    assert get(build_config(), "scouting/multicast/enabled") is False
    assert get(build_config(), "mode") == "peer"


def test_endpoints_and_mode_override_file() -> None:
    config = build_config(
        ZENOH_DIR / "router.json5",
        variables={"ROUTER_PORT": 7500},
        connect=["tcp/10.213.77.2:7500"],
    )
    assert get(config, "mode") == "router"
    assert get(config, "listen/endpoints") == ["tcp/127.0.0.1:7500"], (
        "the plain TCP router listens on loopback unless told otherwise"
    )
    assert get(config, "connect/endpoints") == ["tcp/10.213.77.2:7500"]
    config = build_config(mode="client", connect="tcp/127.0.0.1:7447")
    assert get(config, "mode") == "client"
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:7447"]


def test_dict_with_overrides() -> None:
    config = build_config(
        {"mode": "peer", "listen": {"endpoints": ["tcp/127.0.0.1:0"]}},
        overrides={"transport/link/tls/enable_mtls": True},
    )
    assert get(config, "transport/link/tls/enable_mtls") is True


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"mode": "server"}, "bad Zenoh mode 'server'"),
        ({"connect": ["127.0.0.1:7447"]}, "bad connect endpoint '127.0.0.1:7447'"),
        ({"listen": ["tcp/ 1"]}, "bad listen endpoint"),
        ({"overrides": {"scouting/nonsense": 1}}, "cannot set 'scouting/nonsense'"),
    ],
)
def test_bad_arguments(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ZenohConfigError, match=match):
        build_config(**kwargs)  # type: ignore[arg-type]


def test_bad_sources() -> None:
    with pytest.raises(ZenohConfigError, match="path or a mapping"):
        build_config(42)  # type: ignore[arg-type]
    with pytest.raises(ZenohConfigError, match="without a config file or mapping"):
        build_config(variables={"A": 1})
    with pytest.raises(ZenohConfigError, match="not JSON-serialisable"):
        build_config({"mode": object()})


def test_a_zenoh_config_is_copied_not_changed() -> None:
    base = build_config({"mode": "client"})
    config = build_config(base, connect=["tcp/127.0.0.1:7447"])
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:7447"]
    assert get(base, "connect/endpoints") == []
    assert get(config, "mode") == "client"


def test_parse_variables() -> None:
    assert parse_variables(["P=7447", 'L=["a","b"]', "D=/tmp/x", "H=localhost"]) == {
        "P": 7447,
        "L": ["a", "b"],
        "D": "/tmp/x",
        "H": "localhost",
    }
    with pytest.raises(ZenohConfigError, match="NAME=VALUE"):
        parse_variables(["nope"])


def test_environment_is_read_only_when_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("WM_ZENOH_CERT_DIR", "/env/certs")
    monkeypatch.setenv("WM_ZENOH_AGENT", "perception")
    monkeypatch.setenv("WM_ZENOH_ROUTER_PORT", "7500")
    with pytest.raises(ZenohConfigError, match="AGENT, CERT_DIR"):
        build_config(ZENOH_DIR / "tls/client.json5")
    config = build_config(ZENOH_DIR / "tls/client.json5", variables={**environment_variables(), "AGENT": "monitor"})
    assert get(config, "transport/link/tls/connect_certificate") == "/env/certs/monitor.pem"
    assert get(config, "connect/endpoints") == ["tls/localhost:7500"]
    monkeypatch.setenv("WM_ZENOH_WRITERS", '["perception"]')
    monkeypatch.setenv("WM_ZENOH_MONITORS", '["monitor"]')
    monkeypatch.setenv("WM_ZENOH_ROUTERS", '["router"]')
    config = load_with_environment(ZENOH_DIR / "acl/router.json5")
    assert config is not None
    assert get(config, "access_control/subjects")[0]["cert_common_names"] == ["perception"]
    assert load_with_environment(None) is None


def test_environment_variables() -> None:
    environ = {
        "WM_ZENOH_PORT": "7447",
        "WM_ZENOH_L": '["a"]',
        "WM_ZENOH_H": "localhost",
        "WM_ZENOH_": "x",
        "HOME": "/root",
    }
    assert environment_variables(environ) == {"PORT": 7447, "L": ["a"], "H": "localhost"}
