"""A CORTEX agent written against pydsr, in the shape robocomp generates, running on cortex-wm.

Its only change from a pydsr agent is the import line. It follows people:
every period it reads the robot and each person, sets the robot's reference
speeds towards the nearest one, and keeps a ``target`` node placed (with an
RT edge) where that person stands. It reacts to signals: a person moved (an
RT edge changed) or a node's attributes changed.

Run it beside any cortex-wm graph, e.g. one holding a DSR scene::

    WM_CONNECT=tcp/127.0.0.1:7447 python examples/dsr_follower.py --agent-id 7 --robot viriato
"""

from __future__ import annotations

import argparse
import math
import signal
import threading

from wm.dsr import *  # noqa: F403 - the one line that changed: it was `from pydsr import *`

TARGET = "follow_target"


class SpecificWorker:
    """The robocomp worker: a graph, signal handlers, and a compute step run by a timer."""

    def __init__(self, agent_id: int, robot: str) -> None:
        self.agent_id = agent_id
        self.robot = robot
        self.g = DSRGraph(0, "follower", agent_id)  # noqa: F405
        self.rt = rt_api(self.g)  # noqa: F405
        self.inner = inner_api(self.g)  # noqa: F405
        signals.connect(self.g, signals.UPDATE_EDGE, self.update_edge)  # noqa: F405
        signals.connect(self.g, signals.UPDATE_NODE_ATTR, self.update_node_att)  # noqa: F405
        print(f"follower {agent_id}: joined, robot {robot}", flush=True)

    def compute(self) -> None:
        robot = self.g.get_node(self.robot)
        root = self.g.get_node_root()
        people = self.g.get_nodes_by_type("person")
        if robot is None or root is None or not people:
            return
        ahead = [(p, self.inner.transform(self.robot, p.name)) for p in people]
        ahead = [(p, where) for p, where in ahead if where is not None]
        if not ahead:
            return
        person, where = min(ahead, key=lambda pair: math.hypot(pair[1][0], pair[1][1]))
        robot.attrs["robot_ref_adv_speed"] = Attribute(float(min(500.0, math.hypot(where[0], where[1]))), self.agent_id)  # noqa: F405
        robot.attrs["robot_ref_rot_speed"] = Attribute(float(math.atan2(where[1], where[0])), self.agent_id)  # noqa: F405
        self.g.update_node(robot)
        self.place_target(root, person.name)

    def place_target(self, root: Node, person: str) -> None:  # noqa: F405
        at = self.inner.transform(root.name, person)
        target = self.g.get_node(TARGET)
        if target is None:
            target = Node(self.agent_id, "target", TARGET)  # noqa: F405
            target.attrs["person_name"] = Attribute(person, self.agent_id)  # noqa: F405
            if self.g.insert_node(target) is None:
                return
        elif target.attrs["person_name"].value != person:
            target.attrs["person_name"] = Attribute(person, self.agent_id)  # noqa: F405
            self.g.update_node(target)
        self.rt.insert_or_assign_edge_RT(root, target.id, [float(at[0]), float(at[1]), 0.0], [0.0, 0.0, 0.0])

    def update_edge(self, frm: int, to: int, edge_type: str) -> None:
        if edge_type == "RT" and (node := self.g.get_node(to)) is not None and node.type == "person":
            print(f"follower: person {node.name} moved", flush=True)

    def update_node_att(self, node_id: int, attribute_names: list[str]) -> None:
        if "person_name" in attribute_names or "person_role" in attribute_names:
            print(f"follower: node {node_id} changed {','.join(attribute_names)}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent-id", type=int, default=7)
    parser.add_argument("--robot", default="robot", help="name of the robot node")
    parser.add_argument("--period", type=float, default=0.1, help="seconds between compute steps")
    args = parser.parse_args()
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    worker = SpecificWorker(args.agent_id, args.robot)
    while not stop.wait(args.period):
        worker.compute()
    worker.g.close()
    print("follower: stopped", flush=True)


if __name__ == "__main__":
    main()
