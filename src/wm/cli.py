"""The ``wm`` command line: serve, load, dump, watch, members, set, rm, check, the
monitoring commands of :mod:`wm.monitoring.commands` (monitor, view, foxglove, record, replay),
``launch`` (:mod:`wm.launch.command`), and the commands installed applications add as
plugins (:mod:`wm.plugins`, entry point group ``wm.commands``), such as ``experiment``.

Every command takes ``--graph``, ``--connect ENDPOINT`` (repeatable) and
``--config FILE`` (a Zenoh JSON5 file whose placeholders are filled from
``WM_ZENOH_<NAME>`` environment variables). Errors are one line on stderr and
exit status 1.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import sys
from collections.abc import Sequence
from typing import Any

from . import dsr_json, plugins
from .check import check
from .errors import NotFoundError, PluginError, UnknownAttributeError, WMError
from .graph import Graph
from .launch import command as launch_command
from .monitoring import commands as monitoring_commands
from .net.connection import connect
from .net.zenoh_config import load_with_environment
from .ontology import Ontology


class CommandError(WMError):
    """A command that cannot do its job (nothing answered, bad argument)."""


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--graph", default="default", help="graph name (default: %(default)s)")
    parser.add_argument(
        "--connect", action="append", default=[], metavar="ENDPOINT", help="Zenoh endpoint, e.g. tcp/127.0.0.1:7447"
    )
    parser.add_argument("--config", help="Zenoh config file (JSON5; placeholders from WM_ZENOH_<NAME>)")
    parser.add_argument(
        "--ontology",
        help="ontology file, or a packaged one by name: default, base, dsr, or one a plugin adds (default: %(default)s)",
        default="default",
    )
    parser.add_argument("--timeout", type=float, default=3.0, help="seconds to wait for a peer (default: %(default)s)")
    parser.add_argument("-v", "--verbose", action="store_true", help="log replication details")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="wm", description="cortex-wm: a distributed working memory for robots")
    commands = parser.add_subparsers(dest="command", required=True)

    p = commands.add_parser("serve", help="the durable member: keep graphs on disk, optionally be the Zenoh router")
    _common(p)
    p.add_argument("--data", required=True, help="directory for the graphs on disk")
    p.add_argument(
        "--listen", action="append", default=[], metavar="ENDPOINT", help="listen here (router mode unless --config)"
    )
    p.add_argument(
        "--also", action="append", default=[], metavar="GRAPH", help="serve another graph in the same process"
    )

    p = commands.add_parser("load", help="insert a JSON scene (ours or DSR's)")
    _common(p)
    p.add_argument("file")
    p.add_argument("--new-ids", action="store_true", help="give the scene's nodes fresh ids")

    p = commands.add_parser("dump", help="print the current graph, read from the network")
    _common(p)
    p.add_argument(
        "--format", choices=["text", "json", "dsr"], default="text", help="dsr: a DSR scene file, as DSR writes it"
    )
    monitoring_commands.add_dump_source(p)

    p = commands.add_parser("watch", help="print live events, one per line")
    _common(p)
    monitoring_commands.add_event_filters(p, "print")

    p = commands.add_parser("members", help="list the live replicas and their agent names")
    _common(p)

    p = commands.add_parser("set", help="write node attributes: wm set NODE ATTR=VALUE ...")
    _common(p)
    p.add_argument("node")
    p.add_argument("assignments", nargs="+", metavar="ATTR=VALUE")

    p = commands.add_parser("check", help="list what the view of a graph on disk leaves out, and who sent it")
    p.add_argument("--data", required=True, help="the data directory of `wm serve`")
    p.add_argument("--graph", default="default", help="graph name (default: %(default)s)")
    p.add_argument(
        "--ontology", default="default", help="ontology file, or a packaged one by name (default: %(default)s)"
    )
    p.add_argument(
        "--repair", action="store_true", help="delete what is left out and compact the files (stop `wm serve` first)"
    )
    p.add_argument("-v", "--verbose", action="store_true", help="log each record replayed")

    p = commands.add_parser("rm", help="delete a node and its edges")
    _common(p)
    p.add_argument("node")
    monitoring_commands.add_commands(commands, _common)
    launch_command.add_command(commands)
    plugins.add_commands(commands, reserved=set(commands.choices))
    return parser


def parse_value(ontology: Ontology, attr: str, text: str) -> Any:
    """Parse a command-line value according to the attribute's declared type."""
    spec = ontology.attributes.get(attr)
    if spec is None:
        raise UnknownAttributeError(f"unknown attribute {attr!r}")
    try:
        if spec.type == "bool":
            lowered = text.lower()
            if lowered not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return lowered in ("true", "1")
        if spec.type in ("int", "u64"):
            return int(text)
        if spec.type == "u64vec":
            return [int(x) for x in (json.loads(text) if text.strip().startswith("[") else text.split(","))]
        if spec.type == "float":
            return float(text)
        if spec.type == "vec":
            return [float(x) for x in (json.loads(text) if text.strip().startswith("[") else text.split(","))]
        if spec.type == "bytes":
            return text.encode("utf-8")
    except (ValueError, json.JSONDecodeError):
        raise CommandError(f"{attr}: cannot read {text!r} as {spec.describe()}") from None
    return text


async def _joined(g: Graph, graph_name: str, timeout: float) -> None:
    """Wait until a peer has answered a catch-up; a one-line error if none does."""
    assert g.network is not None
    if g.network.stats.caught_up_from:
        return
    deadline = asyncio.get_running_loop().time() + timeout
    while asyncio.get_running_loop().time() < deadline:
        if await g.network.catch_up():
            return
        await asyncio.sleep(0.1)
    raise CommandError(
        f"no replica of graph {graph_name!r} answered within {timeout:g} s (is `wm serve` or an agent running?)"
    )


async def _live_members(g: Graph, graph_name: str, timeout: float) -> dict[str, str]:
    """The other live members, asking again until one answers or ``timeout`` passes."""
    assert g.network is not None
    deadline = asyncio.get_running_loop().time() + timeout
    while not (members := await g.network.live_members()):
        if asyncio.get_running_loop().time() >= deadline:
            raise CommandError(f"no replica of graph {graph_name!r} answered within {timeout:g} s")
        await asyncio.sleep(0.1)
    return members


async def _confirmed(g: Graph, timeout: float) -> None:
    assert g.network is not None
    if not await g.network.confirm(timeout):
        raise CommandError(f"no replica acknowledged the write within {timeout:g} s")


def print_graph(g: Graph, output_format: str) -> None:
    """``wm dump``'s output: one line per node and edge, our JSON, or a DSR scene file."""
    if output_format == "json":
        print(g.to_json())
    elif output_format == "dsr":
        print(json.dumps(dsr_json.graph_to_dsr(g), indent=4))
    else:
        _print_text(g)


def _print_text(g: Graph) -> None:
    for node in g.nodes():
        attrs = " ".join(f"{k}={_short(v)}" for k, v in sorted(node.attrs.items()))
        print(f"node {node.id} {node.type} {node.name} {attrs}".rstrip())
    for edge in g.edges():
        attrs = " ".join(f"{k}={_short(v)}" for k, v in sorted(edge.attrs.items()))
        src, dst = g.get_node(edge.src).name, g.get_node(edge.dst).name
        print(f"edge {src} -[{edge.type}]-> {dst} {attrs}".rstrip())


def _short(value: Any) -> str:
    if isinstance(value, tuple):
        return "[" + ",".join(f"{x:.3g}" for x in value[:8]) + (",..." if len(value) > 8 else "") + "]"
    return repr(value) if isinstance(value, str) else str(value)


async def run(args: argparse.Namespace) -> int:
    ontology = Ontology.load(args.ontology)
    if hasattr(args, "config"):  # the file, built with its variables from WM_ZENOH_<NAME>
        args.config = load_with_environment(args.config)
    if args.command == "serve":
        from .net.serve import serve

        await serve(
            args.data,
            [args.graph, *args.also],
            config=args.config,
            connect=args.connect,
            listen=args.listen,
            ontology=ontology,
        )
        return 0
    if args.command == "check":
        return _check(args, ontology)
    if args.command in monitoring_commands.COMMANDS or getattr(args, "source", None):
        return await monitoring_commands.run(args, ontology)
    async with connect(
        args.graph, args.config, f"wm-{args.command}", connect=args.connect or None, ontology=ontology
    ) as g:
        if args.command == "members":
            members = await _live_members(g, args.graph, args.timeout)
            for replica, agent in sorted(members.items(), key=lambda m: (m[1], m[0])):
                print(f"{replica} {agent}")
            return 0
        await _joined(g, args.graph, args.timeout)
        if args.command == "dump":
            print_graph(g, args.format)
        elif args.command == "load":
            report = g.load_json(args.file, keep_ids=not args.new_ids)
            await _confirmed(g, args.timeout)
            print(f"loaded {report.nodes} nodes and {report.edges} edges into {args.graph!r}")
            for skipped in report.skipped:
                print(f"skipped unknown attribute {skipped}", file=sys.stderr)
        elif args.command == "set":
            values = {}
            for assignment in args.assignments:
                attr, sep, text = assignment.partition("=")
                if not sep:
                    raise CommandError(f"expected ATTR=VALUE, got {assignment!r}")
                values[attr] = parse_value(g.ontology, attr, text)
            g.update_node(_node_ref(args.node), values)
            await _confirmed(g, args.timeout)
        elif args.command == "rm":
            g.delete_node(_node_ref(args.node))
            await _confirmed(g, args.timeout)
        elif args.command == "watch":
            with g.events(kind=args.kind, type=args.type, name=args.name) as stream:
                print(f"watching graph {args.graph!r}; Ctrl-C to stop", file=sys.stderr, flush=True)
                async for event in stream:
                    print(event, flush=True)
    return 0


def _check(args: argparse.Namespace, ontology: Ontology | None) -> int:
    """Print what the view leaves out; exit status 2 if something is (and was not repaired)."""
    report = check(args.data, args.graph, ontology, repair=args.repair)
    print(
        f"graph {args.graph!r}: {report.nodes} nodes, {report.edges} edges, {report.records} log records replayed; "
        f"{len(report.left_out)} entries left out of the view"
    )
    for entry in report.left_out:
        print(f"  {entry}")
    for writer, count in sorted(report.by_writer().items()):
        print(f"  sent by {writer}: {count}")
    if report.repaired:
        print(f"deleted {len(report.left_out)} entries from the document and compacted {args.data}/{args.graph}")
    return 2 if report.left_out and not report.repaired else 0


def _node_ref(text: str) -> int | str:
    return int(text) if text.isdigit() else text


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown and not getattr(
        args, "plugin_broken", False
    ):  # a broken plugin's command says why, whatever it was given
        parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    if args.command == "launch":
        return launch_command.main(args)
    if (plugin_main := getattr(args, "plugin_main", None)) is not None:
        try:
            return int(plugin_main(args))
        except PluginError as exc:
            print(f"wm {args.command}: error: {exc}", file=sys.stderr)
            return 1
        except ModuleNotFoundError as exc:  # the plugin's own dependencies are not installed
            print(
                f"wm {args.command}: error: {exc} (a dependency of the plugin that adds this command)", file=sys.stderr
            )
            return 1
    logging.basicConfig(
        level=logging.INFO if args.verbose or args.command == "serve" else logging.WARNING,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        return asyncio.run(run(args))
    except (WMError, NotFoundError, ValueError) as exc:
        print(f"wm {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, asyncio.CancelledError):
        return 130 if args.command not in ("serve", "watch", *monitoring_commands.RUN_UNTIL_STOPPED) else 0


if __name__ == "__main__":
    sys.exit(main())
