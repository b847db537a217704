"""Plugins: application commands and ontologies come from entry points, and a broken one breaks nothing else."""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

import pytest

import wm
from wm import cli, plugins
from wm.ontology import _packaged


def _fake_entry_points(monkeypatch: pytest.MonkeyPatch, group: str, entries: dict[str, str]) -> None:
    real = metadata.entry_points

    def entry_points(*, group: str = "", **kw: object) -> list[metadata.EntryPoint]:
        if group == wanted:
            return [metadata.EntryPoint(name, value, group) for name, value in entries.items()]
        return list(real(group=group))

    wanted = group
    monkeypatch.setattr(plugins.metadata, "entry_points", entry_points)
    _packaged.cache_clear()


@pytest.fixture(autouse=True)
def _fresh_ontology_cache() -> object:
    _packaged.cache_clear()
    yield
    _packaged.cache_clear()


def test_the_application_commands_are_installed_plugins() -> None:
    found = {command.name: command for command in plugins.commands()}
    assert {"experiment", "reactions"} <= set(found)
    assert all(command.error is None for command in found.values())
    parser = cli.build_parser()
    assert {"experiment", "reactions", "serve", "launch"} <= set(parser._subparsers._group_actions[0].choices)  # type: ignore[union-attr]


def test_a_broken_plugin_is_a_one_line_typed_error_and_other_commands_still_work(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    _fake_entry_points(
        monkeypatch, plugins.COMMANDS, {"broken": "no_such_module_for_wm", "nomain": "json", "serve": "json"}
    )
    found = {command.name: command for command in plugins.commands()}
    assert isinstance(found["broken"].error, wm.errors.PluginError)
    assert "no_such_module_for_wm" in str(found["broken"].error) and "ModuleNotFoundError" in str(found["broken"].error)
    assert isinstance(found["nomain"].error, wm.errors.PluginError) and "add_command" in str(found["nomain"].error)

    assert cli.main(["broken", "--whatever", "x"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("wm broken: error: plugin 'broken'"), err
    # a plugin may not replace wm's own commands, and the others keep working
    assert cli.main(["check", "--data", str(tmp_path), "--graph", "g"]) == 1
    assert capsys.readouterr().err.startswith("wm check: error: no graph 'g'")
    assert cli.build_parser().parse_args(["serve", "--data", str(tmp_path)]).command == "serve"


def test_ontologies_come_from_plugins_and_the_default_falls_back_to_the_neutral_base(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    caregiving = wm.Ontology.named("caregiving")
    assert {"person", "robot", "intention"} <= set(caregiving.node_types) and "has_intention" in caregiving.edge_types
    assert caregiving.node_type("person").show == ("fov", "speed", "velocity", "track_id", "fallen")
    base = wm.Ontology.named("base")
    assert {"world", "agent"} <= set(base.node_types) and "RT" in base.edge_types
    assert "fov" not in base.attributes and "has_intention" not in base.node_types
    assert set(wm.Ontology.default().node_types) == set(
        caregiving.node_types
    )  # the application names itself the default

    _fake_entry_points(monkeypatch, plugins.ONTOLOGIES, {})
    assert wm.Ontology.names() == ["base", "default", "dsr"]
    assert set(wm.Ontology.default().node_types) == set(base.node_types)
    assert "fov" not in wm.Graph().ontology.attributes

    _fake_entry_points(monkeypatch, plugins.ONTOLOGIES, {"broken": "no_such_module_for_wm:FILE"})
    with pytest.raises(wm.errors.PluginError, match="plugin 'broken'"):
        wm.Ontology.named("broken")
