"""The simulator's "imagine" service as pure functions of a frozen scene: requests in, answers out.

A request is a msgpack map ``{"items": [ITEM, ...], "scene": SCENE?}``. An ITEM is

* ``{"kind": "person", "person", "target", "gaze", "known"?, "uncertainty"?}``: the
  person's walk alone (Algorithm 1, :func:`agents.caregiving.model.imagine.imagine_person`);
* ``{"kind": "joint", "walks": [{"person", "target", "gaze", "known"?}, ...],
  "move": MOVE | null, "current"?: MOVE, "delay"?: s, "lead"?: MOVE, "lead_for"?: s,
  "until_first_fall"?: bool, "falling"?: {person: object}, "uncertainty"?}``: the robot's
  move imagined in time with those walks (Algorithm 2, :func:`agents.caregiving.model.joint.imagine_joint`);
* ``{"kind": "search", "spec": SPEC, "uncertainty", "threshold", "max_moves", "idle_risk"?, "judging"?,
  "head_start"?: bool, "moves"?: [MOVE, ...]}``: Algorithm 2's whole move search
  (:func:`agents.caregiving.model.move_search.search`), each candidate (or each of ``moves``, when
  given) judged here with the joint items above, in order, up to the first safe one; a head start
  it finds on the way goes to the caller's ``head_start`` function at once;
  ``SPEC`` is a :class:`~agents.caregiving.model.search_spec.SearchSpec` in its wire form;

with ``uncertainty = {"size_error", "sigma": {name: metres}, "samples", "seed"}``. The
items are typed values in :mod:`agents.caregiving.model.imagine_request` (person and
joint) and :class:`~agents.caregiving.model.move_search.SearchItem`, which build these
forms and parse them back (:func:`item_from_wire`).
Each item's answer is an :class:`~agents.caregiving.model.imagine_reply.Answer`
(the reply and its wire form are :mod:`agents.caregiving.model.imagine_reply`);
a joint answer's risk is the worst of its walks', sampled only when every walk is clear
(a move whose nominal imagination fails is refused whatever the sampled risk).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

from .errors import CaregivingError, RequestError
from .fields import Fields
from .imagine import imagine_person
from .imagine_reply import Answer, joint_answer
from .imagine_request import JointItem, PersonItem
from .joint import imagine_joint
from .judge_ahead import JudgeAhead
from .move_search import SearchItem
from .rollout import Rollout
from .scene import Scene
from .uncertainty import collision_risk
from .verdict import Verdict

MAX_ITEMS = 512
#: An item of any kind, as the simulator serves it.
Item = PersonItem | JointItem | SearchItem
KINDS = {"person": PersonItem, "joint": JointItem, "search": SearchItem}
#: The kinds that judge robot moves (Algorithm 2, where the reaction time is spent).
ROBOT_MOVE_KINDS = frozenset({"joint", "search"})


def item_from_wire(data: object) -> Item:
    """Parse one item; raises :class:`RequestError` when malformed."""
    f = Fields(data, "request", RequestError)
    kind = f.string("kind", choices=frozenset(KINDS))
    item: Item = KINDS[kind].from_fields(f)
    return item


#: Takes a search's head start as soon as it is found (see :func:`agents.caregiving.model.move_search.search`).
HeadStart = Callable[[Verdict], None]


@dataclass(frozen=True)
class Serving:
    """What items are served with, beyond the scene: the rollout that walks people (Algorithm 1), the helper
    process a search may lend candidates to, and where a search sends its head start."""

    rollout: Rollout | None = None
    ahead: JudgeAhead | None = None
    head_start: HeadStart | None = None


#: Items served with nothing beyond the scene: the numpy rollout, no helper, no head start taken.
PLAIN = Serving()


def serve(scene: Scene, item: Item, serving: Serving = PLAIN) -> Answer:
    """Answer one item, with the sampled collision risk when it asks for one."""
    if isinstance(item, SearchItem):
        imagine = partial(serve_one, scene, serving=Serving(serving.rollout))
        return Answer(search=item.run(scene, imagine, serving.ahead, serving.head_start))
    if isinstance(item, PersonItem):
        w, u = item.walk, item.uncertainty
        im = imagine_person(scene, w.person, w.target, w.gaze, serving.rollout, known=w.known)
        return Answer(imagination=im, risk=collision_risk(scene, im, u) if u is not None else None)
    joint = imagine_joint(
        scene,
        item.walks,
        item.move,
        delay=item.delay,
        current=item.current,
        lead=item.lead,
        lead_for=item.lead_for,
        until_first_fall=item.until_first_fall,
        falling=item.falling,
        passing=item.passing,
    )
    return joint_answer(scene, joint, item.uncertainty, item.falling, item.anyway)


def serve_item(scene: Scene, item: object, serving: Serving = PLAIN) -> Answer:
    """Answer one item, typed or in its wire form; raises when it is malformed or unanswerable."""
    typed = item if isinstance(item, Item) else item_from_wire(item)
    return serve(scene, typed, serving)


def judges_robot_moves(items: list[Any]) -> bool:
    """Whether a batch holds an item of a kind that judges robot moves, so it is served before the others."""
    return any(isinstance(i, dict) and i.get("kind") in ROBOT_MOVE_KINDS for i in items)


def serve_one(scene: Scene, item: object, serving: Serving = PLAIN) -> Answer:
    """One item's answer (typed or in its wire form); a malformed or unanswerable item gets an error answer."""
    try:
        return serve_item(scene, item, serving)
    except (CaregivingError, ValueError, TypeError, KeyError) as exc:
        return Answer(error=f"{type(exc).__name__}: {exc}")


def batch_scene(request: Any, context: Scene | None) -> tuple[Scene, list[Any]]:
    """The frozen scene of a request and its items; raises :class:`RequestError` when malformed."""
    f = Fields(request, "request", RequestError)
    items = request.get("items") if isinstance(request, dict) else None
    if not isinstance(items, list) or not items:
        raise RequestError("request.items: expected a non-empty list")
    if len(items) > MAX_ITEMS:
        raise RequestError(f"request.items: at most {MAX_ITEMS} per batch, got {len(items)}")
    pinned = f.optional_child("scene")
    scene = Scene.from_wire(request["scene"]) if pinned is not None else context
    if scene is None:
        raise RequestError("no context yet: W holds no world and robot, and the request pins no scene")
    return scene, items
