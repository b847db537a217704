"""The robot's side of W for Algorithm 2: the dangers and the move under way it reads, the intention it writes.

Algorithm 1 leaves each person's guessed walks in W as ``has_intention`` edges
(risky ones with their path, collision point, object and time to collision);
the robot's own moves are ``intention`` nodes linked ``robot -has-> intention``.
These functions turn the first into the :class:`~agents.caregiving.model.search_spec.SearchSpec`
the search takes, and the search's choice back into an intention node, so that
the action agent is only the flow of Algorithm 2.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.guesses import DEFAULT_WALKING, Walking, unguessed_walks
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.scene import PersonState
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.verdict import Verdict
from agents.caregiving.model.visibility import GazeClass, first_of, gaze_classes
from agents.caregiving.model.world_model import Walk
from wm import Edge, Graph, Node

from .context import Context
from .names import HAS, HAS_INTENTION, INTENTION, KNOWS, MOVE_TO, STOP
from .person_intentions import seen_at

#: The statuses of a move under way (or about to be).
LIVE = ("proposed", "active")

#: Each endangered person's most urgent danger, with the ``has_intention`` edge it was read from.
Dangers = dict[str, tuple[Edge, Danger]]


def risky_first(classes: tuple[GazeClass, ...], risky: float) -> tuple[float, ...]:
    """The classes' gazes, the class holding the ``risky`` gaze first."""
    gazes = [c.gaze for c in classes]
    first = min(
        range(len(classes)),
        key=lambda k: 0.0 if classes[k].low <= risky <= classes[k].high else abs(classes[k].gaze - risky),
    )
    return first_of(gazes, first)


def dangers_in(ctx: Context, risky: list[Edge], failed: Mapping[int, float], retry: float) -> Dangers:
    """Each endangered person's most urgent danger that is not yet due, nor failed less than ``retry`` s ago
    (nobody fallen is endangered any more).

    ``failed`` holds, by person node id, the simulated time their last search found no move.
    """
    names = ctx.names
    out: Dangers = {}
    for edge in risky:
        person, target, obstacle = names.get(edge.src), names.get(edge.dst), names.get(edge.get("collision_object"))
        ttc = edge.get("time_to_collision", 0.0) - max(ctx.scene.time - edge.get("at_time", ctx.scene.time), 0.0)
        recent = ctx.scene.time - failed.get(edge.src, -math.inf) < retry
        if person is None or target is None or obstacle is None or ttc <= 0.0 or recent or person in ctx.fallen:
            continue
        flat = edge.get("path", ())
        p = ctx.scene.person(person)
        danger = Danger(
            person,
            target,
            tuple(zip(flat[0::2], flat[1::2], strict=True)),
            tuple(edge.get("collision_point", (p.x, p.y))),
            obstacle,
            ttc,
        )
        if person not in out or ttc < out[person][1].time_to_collision:
            out[person] = (edge, danger)
    return out


def bystander_walks(
    g: Graph, ctx: Context, person: PersonState, walking: Walking = DEFAULT_WALKING
) -> tuple[list[Walk], Edge | None]:
    """The walks a person not in danger may be on, likeliest first, and the guess of the likeliest (if guessed).

    Someone standing is imagined on their latest guessed walk. Someone walking on every walk Algorithm 1
    guesses for them (those their heading matches), the latest first; before it has guessed any, on
    :func:`~agents.caregiving.model.guesses.unguessed_walks`. A move is then never judged with a walking
    person imagined standing still. ``walking`` says who walks, and which targets lie plainly aside.
    Someone fallen walks nowhere: they lie where they are.
    """
    if person.name in ctx.fallen:
        return [], None
    guessed = sorted(
        (e for e in g.edges(type=HAS_INTENTION, src=ctx.ids[person.name]) if e.dst in ctx.names),
        key=lambda e: -e.get("updated_at", 0.0),
    )
    walks = ctx.walks(person.name, walking)
    if guessed:
        kept = guessed if walks else guessed[:1]
        return [Walk(person.name, ctx.names[e.dst], e.get("gaze", 0.0)) for e in kept], guessed[0]
    return list(unguessed_walks(person, ctx.scene.obstacles, walking.aside)) if walks else [], None


def search_spec(
    g: Graph, ctx: Context, dangers: Dangers, under_way: Node | None, walking: Walking = DEFAULT_WALKING
) -> SearchSpec:
    """What the search needs beside the scene: the dangers, each endangered person's gaze classes (the one
    found risky first), the walks the others may be on (:func:`bystander_walks`), and the move under way.
    Everyone is imagined knowing what their ``knows`` edges say, the robot where they remember it."""
    scene, names = ctx.scene, ctx.names
    knows = {p.name: [e for e in g.edges(type=KNOWS, src=ctx.ids[p.name]) if e.dst in names] for p in scene.people}
    known = {p: tuple(sorted(names[e.dst] for e in edges)) for p, edges in knows.items()}
    robot_at = {
        p: pose
        for p, edges in knows.items()
        for e in edges
        if names[e.dst] == scene.robot_name and (pose := seen_at(e)) is not None
    }
    gazes = {
        p: risky_first(gaze_classes(scene.person(p), scene.bodies_around(p)), edge.get("gaze", 0.0))
        for p, (edge, _) in dangers.items()
    }
    bystanders: list[Walk] = []
    falling: dict[str, str] = {}
    for p in scene.people:
        if p.name in dangers:
            continue
        walks, likeliest = bystander_walks(g, ctx, p, walking)
        bystanders += [replace(w, known=known[p.name], robot_at=robot_at.get(p.name)) for w in walks]
        if likeliest is not None and likeliest.get("risky") and likeliest.get("collision_object") in names:
            falling[p.name] = names[likeliest.get("collision_object")]  # a danger not searched now
    return SearchSpec(
        tuple(d for _, d in dangers.values()),
        gazes,
        {p: known[p] for p in dangers},
        tuple(bystanders),
        move_of(under_way, ctx) if under_way is not None else None,
        falling=falling,
        robot_at={p: pose for p, pose in robot_at.items() if p in dangers},
    )


def move_under_way(g: Graph) -> Node | None:
    """The robot's move under way (or about to be), if any."""
    live = [n for n in g.nodes(INTENTION) if n.get("status") in LIVE]
    return max(live, key=lambda n: n.get("created_at", 0.0), default=None)


def move_of(node: Node, ctx: Context) -> RobotMove | None:
    """The move an intention drives (its target named as in ``ctx``), ``None`` for a stop."""
    if node.get("action") == STOP:
        return None
    x, y, heading = node.get("final_pose")
    target = node.get("target")
    return RobotMove(ctx.names.get(target, str(target)), x, y, heading)


def clear_intentions(g: Graph) -> None:
    """Forget the robot's intentions (a new trial)."""
    with g.batch():
        for node in g.nodes(INTENTION):
            g.delete_node(node.id)


def write_intention(
    g: Graph,
    ctx: Context,
    chosen: Verdict,
    dangers: Dangers,
    under_way: Node | None,
    name: str,
    unsaved: str = "",
    head_start: bool = False,
) -> tuple[Edge, Danger] | None:
    """Write ``chosen`` as the robot's new intention (``move_to`` a pose, or ``stop``), superseding the one under way.

    Returns the most urgent danger it protects from, with its edge; ``None`` (nothing written) when that
    person has left W meanwhile. ``unsaved`` names the people no single move kept safe; ``head_start``
    marks a move sent while the search judges on (it does not remove the danger itself).
    """
    robot = ctx.scene.robot
    assert robot is not None
    edge, danger = min(dangers.values(), key=lambda x: x[1].time_to_collision)
    if g.find_node(edge.src) is None:
        return None
    move = chosen.move
    reason = f"{chosen.reason}; protects {', '.join(sorted(dangers))}"
    if head_start:
        what_for = "head start while the search judges on" if move is not None else "head start ends: no move found"
        reason = f"{what_for} ({chosen.reason}); for {', '.join(sorted(dangers))}"
    if unsaved:
        reason += f"; not saved: {unsaved} (no single move keeps everyone safe)"
    what = (
        {"action": MOVE_TO, "target": ctx.ids.get(move.target, 0), "final_pose": [move.x, move.y, move.heading]}
        if move is not None
        else {"action": STOP, "target": ctx.ids[robot.name]}
    )
    add_intention(
        g,
        ctx,
        name,
        {
            **what,
            "status": "proposed",
            "person": edge.src,
            "observed_at": edge.get("observed_at", 0.0),
            "risk_at": edge.get("updated_at", 0.0),
            "time_to_collision": danger.time_to_collision,
            "in_time": chosen.in_time(danger.time_to_collision),
            "head_start": head_start,
            "reason": reason,
        },
        under_way,
    )
    return edge, danger


def add_intention(g: Graph, ctx: Context, name: str, attrs: dict[str, Any], under_way: Node | None = None) -> int:
    """Insert a robot ``intention`` node (``attrs`` with its ``action`` and ``status``), linked ``robot -has->`` it,
    superseding ``under_way`` (the move under way, if it is one); its node id."""
    robot = ctx.scene.robot
    assert robot is not None
    now = time.time()
    with g.batch():
        if under_way is not None and g.find_node(under_way.id) is not None:
            g.update_node(under_way.id, {"status": "superseded"})
        node = g.insert_node(
            INTENTION,
            f"{attrs['action']}_{ctx.episode}_{name}",
            {**attrs, "created_at": now, "at_time": ctx.scene.time},
        )
        g.insert_or_assign_edge(ctx.ids[robot.name], node, HAS, {"status": attrs["status"], "updated_at": now})
    return node
