"""``python -m bridges.world --graph G --scenario S [--rate R] [--connect EP ...]``."""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys

from agents.caregiving.model.errors import ScenarioError
from agents.caregiving.model.scenario import load_scenario
from wm.net.connection import ConnectError, close_session, open_session, sigterm_cancels_current_task
from wm.net.zenoh_config import ZenohConfigError, load_with_environment

from .bridge import WorldBridge


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m bridges.world", description=__doc__)
    p.add_argument("--graph", default="default", help="graph name (default: %(default)s)")
    p.add_argument("--scenario", required=True, help="scenario file or shipped scenario name")
    p.add_argument("--connect", action="append", default=[], metavar="ENDPOINT")
    p.add_argument("--listen", action="append", default=[], metavar="ENDPOINT")
    p.add_argument("--config", help="Zenoh config file (JSON5; placeholders from WM_ZENOH_<NAME>)")
    p.add_argument("--rate", type=float, default=1.0, help="simulated seconds per wall second (default: %(default)s)")
    p.add_argument("--max-time", type=float, default=30.0, help="simulated seconds before a trial is cut off")
    return p.parse_args(argv)


async def run(args: argparse.Namespace) -> None:
    scenario = load_scenario(args.scenario)
    session = await open_session(
        load_with_environment(args.config), connect=args.connect or None, listen=args.listen or None
    )
    try:
        with sigterm_cancels_current_task():
            bridge = WorldBridge(session, args.graph, scenario, rate=args.rate, max_time=args.max_time)
            await bridge.run(lambda: print(f"world: ready scenario={scenario.name} rate={args.rate:g}", flush=True))
    finally:
        await close_session(session)


def main() -> int:
    args = parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        asyncio.run(run(args))
    except (ScenarioError, ConnectError, ZenohConfigError) as exc:
        print(f"world: error: {exc}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, asyncio.CancelledError):
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
