"""An agent for the tests: it reports what it has seen on its own ``agent`` node.

Its ``description`` reads ``tag=<--tag> objects=<names, sorted> handled=<n>``,
rewritten on setup and on every ``object`` node added. An object whose name
starts with ``boom`` makes the handler raise after counting it.
"""

from __future__ import annotations

import argparse

from agents.runtime import Agent, every, main, on
from wm import Event


class Probe(Agent):
    """Reports the object nodes it has seen on its agent node."""

    name = "probe"
    status_period = 0.2
    crash_loop_failures = 3

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--tag", default="-", help="a word copied into the report")

    async def setup(self) -> None:
        self.handled = 0
        self.ticks = 0
        self.report()

    @on(kind="node_added", type="object")
    async def object_added(self, event: Event) -> None:
        self.handled += 1
        if (event.name or "").startswith("boom"):
            raise RuntimeError(f"refusing {event.name}")
        self.report()

    @every(0.1)
    async def tick(self) -> None:
        self.ticks += 1

    def report(self) -> None:
        objects = ",".join(sorted(n.name for n in self.g.nodes("object")))
        mine = [n for n in self.g.nodes("agent") if n.get("replica") == self.g.replica_id]
        if mine:
            self.g.update_node(
                mine[0].id, {"description": f"tag={self.args.tag} objects={objects} handled={self.handled}"}
            )


if __name__ == "__main__":
    main(Probe)
