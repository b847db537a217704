"""What other installed packages add to ``wm``, found through Python entry points.

``wm`` itself carries no application code. An application adds to it by
declaring entry points in its ``pyproject.toml``:

``wm.commands``
    A ``wm`` subcommand. The entry point's name is the command's name; its
    object (usually a module) has ``add_command(commands)``, which adds a
    parser of that name to the ``wm`` subparsers, and ``main(args) -> int``,
    which runs it. Import heavy code inside ``main``, so that ``wm --help``
    stays fast.

``wm.ontologies``
    A packaged ontology, selected by the entry point's name like ``dsr``
    (``wm --ontology NAME``, :meth:`wm.Ontology.named`). Its object is the
    file: a path, or an :mod:`importlib.resources` traversable. The name
    ``default`` makes it the ontology of ``wm.Graph()`` and of every command
    that is given none; without such an entry point the default is ``base``.

A plugin that cannot be loaded raises :class:`~wm.errors.PluginError`, which
names it and says why; the other commands keep working.
"""

from __future__ import annotations

import argparse
import functools
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Protocol

from .errors import PluginError

COMMANDS = "wm.commands"
ONTOLOGIES = "wm.ontologies"


class CommandPlugin(Protocol):
    """The object a ``wm.commands`` entry point names."""

    def add_command(self, commands: Any) -> Any: ...

    def main(self, args: argparse.Namespace) -> int: ...


@dataclass(frozen=True)
class Command:
    """A loaded ``wm.commands`` plugin (or the error that kept it from loading)."""

    name: str
    value: str  # the entry point's object reference, e.g. "bridges.experiment.command"
    plugin: CommandPlugin | None = None
    error: PluginError | None = None


def entry_points(group: str) -> list[metadata.EntryPoint]:
    """The installed entry points of ``group``, by name (the first of a repeated name wins)."""
    found: dict[str, metadata.EntryPoint] = {}
    for entry in metadata.entry_points(group=group):
        found.setdefault(entry.name, entry)
    return [found[name] for name in sorted(found)]


def load(entry: metadata.EntryPoint) -> Any:
    """The object of an entry point, or :class:`PluginError` saying which plugin failed and why."""
    try:
        return entry.load()
    except Exception as exc:
        raise PluginError(
            f"plugin {entry.name!r} ({entry.group} = {entry.value}) cannot be loaded: {type(exc).__name__}: {exc}"
        ) from exc


def commands() -> list[Command]:
    """Every installed ``wm.commands`` plugin, loaded; a broken one carries its error instead."""
    found = []
    for entry in entry_points(COMMANDS):
        try:
            plugin = load(entry)
            for needed in ("add_command", "main"):
                if not callable(getattr(plugin, needed, None)):
                    raise PluginError(f"plugin {entry.name!r} ({COMMANDS} = {entry.value}) has no {needed}()")
        except PluginError as exc:
            found.append(Command(entry.name, entry.value, error=exc))
        else:
            found.append(Command(entry.name, entry.value, plugin=plugin))
    return found


def add_commands(subparsers: Any, reserved: set[str]) -> None:
    """Add every plugin command to the ``wm`` parser; a broken one becomes a command that reports its error.

    Each parser gets the default ``plugin_main``, the function ``wm`` calls to run it (and a broken one ``plugin_broken``,
    so that ``wm`` accepts any arguments for it and reports the plugin's error instead).
    """
    for command in commands():
        if command.name in reserved:
            continue  # wm's own commands cannot be replaced
        error = command.error
        if command.plugin is not None:
            try:
                command.plugin.add_command(subparsers)
                parser = subparsers.choices[command.name]
            except Exception as exc:
                subparsers.choices.pop(command.name, None)
                error = PluginError(
                    f"plugin {command.name!r} ({COMMANDS} = {command.value}) cannot add its command: "
                    f"{type(exc).__name__}: {exc}"
                )
            else:
                parser.set_defaults(plugin_main=command.plugin.main)
                continue
        assert error is not None
        parser = subparsers.add_parser(
            command.name, help=f"(unavailable: plugin {command.name!r} cannot be loaded)", description=str(error)
        )
        parser.set_defaults(plugin_main=functools.partial(_broken, error), plugin_broken=True)


def _broken(error: PluginError, args: argparse.Namespace) -> int:
    raise error


def ontology_files() -> dict[str, Callable[[], Any]]:
    """The ``wm.ontologies`` entry points: name -> a function that loads the entry point's file object."""
    return {entry.name: functools.partial(load, entry) for entry in entry_points(ONTOLOGIES)}
