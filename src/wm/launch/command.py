"""``wm launch FILE``: the command line of :mod:`wm.launch.supervisor` (see :mod:`wm.launch.spec` for the format).

    wm launch deploy/launch/one-host.toml
    wm launch --check deploy/launch/caregiving.toml --set router=tcp/10.0.0.1:7447

Exit status: 0 when every process stopped cleanly, 1 when any failed or the
file is invalid (each problem is printed on its own line, naming its key).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from .spec import LaunchFileError, load


def add_command(commands: Any) -> None:
    """Add ``launch`` to the ``wm`` subcommands."""
    p = commands.add_parser(
        "launch", help="start wm serve and agents from a launch file (TOML), restart, stop in order"
    )
    p.add_argument("file", help="the launch file")
    p.add_argument("--check", action="store_true", help="validate the file and exit without starting anything")
    p.add_argument(
        "--set", action="append", default=[], metavar="NAME=VALUE", help="set a [vars] variable (repeatable)"
    )
    p.add_argument("--log-dir", help="directory for the per-process logs (default: the file's log_dir)")
    p.add_argument("--no-table", action="store_true", help="no live status table, even on a terminal")


def main(args: argparse.Namespace) -> int:
    overrides: dict[str, str] = {}
    for assignment in args.set:
        name, sep, value = assignment.partition("=")
        if not sep or not name:
            print(f"wm launch: error: --set expects NAME=VALUE, got {assignment!r}", file=sys.stderr)
            return 1
        overrides[name] = value
    try:
        spec = load(args.file, overrides)
    except LaunchFileError as exc:
        for problem in exc.problems:
            print(f"wm launch: error: {exc.path}: {problem}", file=sys.stderr)
        return 1
    if args.check:
        print(f"{spec.path}: ok, {len(spec.processes)} processes: {', '.join(p.name for p in spec.processes)}")
        return 0
    if args.log_dir:
        spec = replace(spec, log_dir=Path(args.log_dir))
    from .supervisor import Launcher  # rich is loaded only when something is launched

    return asyncio.run(Launcher(spec, live_table=not args.no_table).run())
