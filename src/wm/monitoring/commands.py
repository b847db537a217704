"""The monitoring commands of ``wm``: monitor, view, foxglove, record, replay and ``dump --from``.

:mod:`wm.cli` adds them with :func:`add_commands` and hands them to :func:`run`.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from ..ontology import Ontology

COMMANDS = ("monitor", "view", "foxglove", "record", "replay")
RUN_UNTIL_STOPPED = ("monitor", "view", "foxglove", "record")


def add_event_filters(parser: argparse.ArgumentParser, verb: str) -> None:
    """``--type``, ``--kind`` and ``--name``, as ``wm watch`` and ``wm monitor`` take them."""
    parser.add_argument("--type", action="append", help=f"{verb} only this node/edge type (repeatable)")
    parser.add_argument("--kind", action="append", help=f"{verb} only this event kind, e.g. node_added (repeatable)")
    parser.add_argument("--name", action="append", help=f"{verb} only events about this node name (repeatable)")


def add_commands(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], common: Callable[[argparse.ArgumentParser], None]
) -> None:
    """Add the monitoring subcommands to the ``wm`` parser."""
    p = commands.add_parser("monitor", help="live terminal view of a graph (read-only)")
    common(p)
    add_event_filters(p, "log")

    p = commands.add_parser("view", help="live browser view of a graph (read-only), on http://HOST:PORT/")
    common(p)
    p.add_argument("--port", type=int, default=8765, help="HTTP and websocket port, 0 for any (default: %(default)s)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default: %(default)s)")

    p = commands.add_parser("foxglove", help="live view of a graph for the Foxglove app (read-only), on ws://HOST:PORT")
    common(p)
    p.add_argument("--port", type=int, default=8765, help="Foxglove WebSocket port, 0 for any (default: %(default)s)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default: %(default)s)")
    p.add_argument("--logs", metavar="DIR", help="also send the agents' log lines, from wm launch's log directory")

    p = commands.add_parser("record", help="record a graph's changes into an MCAP file (read-only)")
    common(p)
    p.add_argument("file")
    p.add_argument("--duration", type=float, help="stop after this many seconds (default: until stopped)")
    p.add_argument("--logs", metavar="DIR", help="also record the agents' log lines, from wm launch's log directory")

    p = commands.add_parser("replay", help="republish a recording into a live graph")
    common(p)
    p.add_argument("file")
    p.add_argument("--speed", type=float, default=1.0, help="playback speed factor (default: %(default)s)")
    p.add_argument("--as", dest="as_graph", metavar="GRAPH", help="graph to replay into (default: --graph)")


def add_dump_source(dump: argparse.ArgumentParser) -> None:
    """``wm dump --from FILE [--at T]``: the graph of a recording instead of the network."""
    dump.add_argument("--from", dest="source", metavar="FILE", help="read a recording instead of the network")
    dump.add_argument(
        "--at", type=float, metavar="T", help="with --from: seconds after the recording's start (default: its end)"
    )


async def run(args: argparse.Namespace, ontology: Ontology | None) -> int:
    """Run one monitoring command (or ``dump --from``)."""
    endpoints = args.connect if hasattr(args, "connect") else []
    if args.command == "dump":
        from ..cli import print_graph
        from .recording_file import graph_at

        print_graph(graph_at(args.source, args.at, ontology), args.format)
    elif args.command == "monitor":
        from .monitor import monitor

        await monitor(
            args.graph,
            config=args.config,
            connect_to=endpoints,
            ontology=ontology,
            kinds=args.kind,
            types=args.type,
            names=args.name,
        )
    elif args.command == "view":
        from .view import view

        await view(
            args.graph, host=args.host, port=args.port, config=args.config, connect_to=endpoints, ontology=ontology
        )
    elif args.command == "foxglove":
        from .foxglove_live import serve_foxglove

        await serve_foxglove(
            args.graph,
            host=args.host,
            port=args.port,
            config=args.config,
            connect_to=endpoints,
            ontology=ontology,
            log_dir=args.logs,
        )
    elif args.command == "record":
        from .recorder import record

        count = await record(
            args.file,
            args.graph,
            config=args.config,
            connect_to=endpoints,
            ontology=ontology,
            duration=args.duration,
            log_dir=args.logs,
        )
        print(f"wm record: {count} updates in {args.file}")
    elif args.command == "replay":
        from .replay import replay

        target = args.as_graph or args.graph
        count = await replay(
            args.file, target, speed=args.speed, config=args.config, connect_to=endpoints, ontology=ontology
        )
        print(f"wm replay: {count} updates republished into {target!r}")
    return 0
