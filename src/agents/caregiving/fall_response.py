"""The robot's side of W when someone has fallen: the alert it raises about them, and its move to go to them.

Both are robot ``intention`` nodes, linked ``robot -has-> intention`` as its moves are, with ``target``
and ``person`` the node id of the person who has fallen:

* ``alert``: ``reason`` says who fell and when; ``status`` ``raised`` while they lie there, ``ended``
  once perception sees them standing again. It is no move: the executor leaves it alone, and it is
  never the move under way.
* ``go_to``: a ``final_pose`` beside them. The executor drives it as it drives ``move_to``; the action
  agent judges it as the move under way when a new danger lands, and replaces it to prevent a fall.
"""

from __future__ import annotations

from dataclasses import replace

from agents.caregiving.model.guesses import DEFAULT_WALKING, Walking, unguessed_walks
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.search_spec import SearchSpec
from wm import Graph, Node

from .context import Context
from .names import ALERT, GO_TO, HAS_INTENTION, INTENTION, PERSON
from .robot_intentions import add_intention, search_spec

RAISED, ENDED = "raised", "ended"
#: The statuses of a ``go_to`` on its way or arrived: the robot is seeing to that person.
SEEING_TO = ("proposed", "active", "done")


def fallen(g: Graph) -> list[Node]:
    """The person nodes perception marks fallen, the earliest fall first."""
    return sorted((n for n in g.nodes(PERSON) if n.get("fallen")), key=lambda n: n.get("fallen_at", 0.0))


def alerts(g: Graph) -> dict[int, Node]:
    """The alerts raised and not ended, by the node id of the person each is about."""
    return {n.get("person"): n for n in g.nodes(INTENTION) if n.get("action") == ALERT and n.get("status") == RAISED}


def seen_to(g: Graph) -> set[int]:
    """The people (node ids) the robot is going to, or has reached."""
    return {n.get("person") for n in g.nodes(INTENTION) if n.get("action") == GO_TO and n.get("status") in SEEING_TO}


def someone_in_danger(g: Graph) -> bool:
    """Whether Algorithm 1 holds a risky walk of someone not fallen: the robot is needed there first."""
    down = {n.id for n in fallen(g)}
    return any(e.get("risky") and e.src not in down for e in g.edges(type=HAS_INTENTION))


def going_spec(g: Graph, ctx: Context, walking: Walking = DEFAULT_WALKING) -> SearchSpec:
    """The spec a move to someone fallen is judged with: no danger, and everyone not fallen on the walks they may
    be on (:func:`~agents.caregiving.robot_intentions.bystander_walks`). Someone with none (standing, or tracked
    too briefly to tell) is imagined setting off on the walks ahead of them: a move made for no danger does not
    take their stillness for granted."""
    spec = search_spec(g, ctx, {}, None, walking)
    imagined = {w.person for w in spec.bystanders}
    unknown = [p for p in ctx.scene.people if p.name not in imagined and p.name not in ctx.fallen]
    more = tuple(w for p in unknown for w in unguessed_walks(p, ctx.scene.obstacles, walking.aside))
    return replace(spec, bystanders=spec.bystanders + more)


def raise_alert(g: Graph, ctx: Context, person: Node, name: str) -> int:
    """Raise the alert about ``person``, who has fallen; its node id."""
    at = person.get("fallen_at", ctx.scene.time)
    return add_intention(
        g,
        ctx,
        name,
        {
            "action": ALERT,
            "target": person.id,
            "person": person.id,
            "status": RAISED,
            "reason": f"{person.name} has fallen (seen lying at {at:.2f} s)",
        },
    )


def end_alert(g: Graph, alert: Node) -> None:
    """The person the alert is about is up again."""
    g.update_node(alert.id, {"status": ENDED, "reason": f"{alert.get('reason')}; seen standing again"})


def write_go_to(g: Graph, ctx: Context, person: str, move: RobotMove, reason: str, name: str) -> int:
    """Send the robot to ``move``'s pose beside ``person``, who has fallen; the intention's node id."""
    return add_intention(
        g,
        ctx,
        name,
        {
            "action": GO_TO,
            "target": ctx.ids[person],
            "person": ctx.ids[person],
            "final_pose": [move.x, move.y, move.heading],
            "status": "proposed",
            "reason": f"goes to {person}, who has fallen ({reason})",
        },
    )
