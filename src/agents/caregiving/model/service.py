"""The simulator's "imagine" service as pure functions of a frozen scene: requests in, answers out.

A request is a msgpack map ``{"items": [ITEM, ...], "scene": SCENE?}``. An ITEM is

* ``{"kind": "person", "person", "target", "gaze", "known"?, "uncertainty"?}``: the
  person's walk alone (Algorithm 1, :func:`agents.caregiving.model.imagine.imagine_person`);
* ``{"kind": "joint", "walks": [{"person", "target", "gaze", "known"?}, ...],
  "move": MOVE | null, "current"?: MOVE, "delay"?: s, "uncertainty"?}``: the robot's
  move imagined in time with those walks (Algorithm 2, :func:`agents.caregiving.model.joint.imagine_joint`);
* ``{"kind": "search", "spec": SPEC, "uncertainty", "threshold", "max_moves", "idle_risk"?, "judging"?,
  "moves"?: [MOVE, ...]}``: Algorithm 2's whole move search
  (:func:`agents.caregiving.model.move_search.search`), each candidate (or each of ``moves``, when
  given) judged here with the joint items above, one at a time, up to the first safe one;
  ``SPEC`` is a :class:`~agents.caregiving.model.move_search.SearchSpec` in its wire form;

with ``uncertainty = {"size_error", "sigma": {name: metres}, "samples", "seed"}``.
Each item's answer is an :class:`~agents.caregiving.model.imagine_reply.Answer`
(the reply and its wire form are :mod:`agents.caregiving.model.imagine_reply`);
a joint answer's risk is the worst of its walks'.
"""

from __future__ import annotations

from typing import Any

from .errors import CaregivingError, RequestError
from .fields import Fields
from .imagine import imagine_person
from .imagine_reply import Answer
from .joint import JointImagination, imagine_joint, walk_from_fields
from .judge_ahead import JudgeAhead
from .move_search import SearchSpec, search
from .robot_moves import RobotMove
from .rollout import Rollout
from .scene import Scene
from .uncertainty import NO_RISK, Risk, Uncertainty, collision_risk
from .verdict import SearchResult

MAX_ITEMS = 512
#: Seconds a joint item may ask the robot to go on with its current move before the new one.
MAX_DELAY = 5.0
#: Candidate moves one search may judge at most.
MAX_MOVES = 256
KINDS = frozenset({"person", "joint", "search"})
#: The kinds that judge robot moves (Algorithm 2, where the reaction time is spent).
ROBOT_MOVE_KINDS = frozenset({"joint", "search"})


def uncertainty_from_fields(u: Fields) -> Uncertainty:
    """Parse an item's ``uncertainty`` map."""
    sigma = u.child("sigma", {})
    return Uncertainty(
        u.number("size_error", 0.0, non_negative=True, at_most=0.9),
        {k: sigma.number(k, non_negative=True) for k in sigma.keys()},
        int(u.number("samples", 64, positive=True, at_most=4096)),
        int(u.number("seed", 0)),
    )


def serve_item(scene: Scene, item: Any, rollout: Rollout | None = None, ahead: JudgeAhead | None = None) -> Answer:
    """Answer one item, with the sampled collision risk when it asks for one; a search may use the ``ahead`` helper."""
    f = Fields(item, "request", RequestError)
    kind = f.string("kind", choices=KINDS)
    u = f.optional_child("uncertainty")
    uncertainty = uncertainty_from_fields(u) if u is not None else None
    if kind == "search":
        return Answer(search=_search(scene, f, item, rollout, ahead))
    if kind == "person":
        walk = walk_from_fields(f)
        im = imagine_person(scene, walk.person, walk.target, walk.gaze, rollout, known=walk.known)
        return Answer(imagination=im, risk=collision_risk(scene, im, uncertainty) if uncertainty is not None else None)
    walks = tuple(walk_from_fields(w) for w in f.children("walks"))
    if not walks:
        raise f.fail("walks", "expected at least one walk")
    joint = imagine_joint(
        scene,
        walks,
        RobotMove.optional_from(f, "move"),
        delay=f.number("delay", 0.0, non_negative=True, at_most=MAX_DELAY),
        current=RobotMove.optional_from(f, "current"),
    )
    return Answer(joint=joint, risk=joint_risk(scene, joint, uncertainty) if uncertainty is not None else None)


def _search(scene: Scene, f: Fields, item: Any, rollout: Rollout | None, ahead: JudgeAhead | None) -> SearchResult:
    """Run a ``search`` item: every field is checked before the first candidate is imagined."""
    f.child("uncertainty")  # required here; serve_item has checked its fields
    return search(
        scene,
        SearchSpec.from_fields(f.child("spec"), MAX_DELAY),
        lambda joint: serve_one(scene, joint, rollout),
        item["uncertainty"],
        f.number("threshold", positive=True, at_most=1.0),
        int(f.number("max_moves", positive=True, at_most=MAX_MOVES)),
        f.number("idle_risk", 1.0, non_negative=True, at_most=1.0),
        f.number("judging", 0.0, non_negative=True, at_most=MAX_DELAY),
        [RobotMove.from_fields(m) for m in f.children("moves")] if f.has("moves") else None,
        ahead,
    )


def joint_risk(scene: Scene, joint: JointImagination, u: Uncertainty) -> Risk:
    """The likeliest collision over the sampled worlds, worst walk first.

    The walks are sampled as walked; the robot is left out, since it knows where it is and the
    nominal imagination already checks every step against it.
    """
    without_robot = scene.with_robot(None)
    risks = [collision_risk(without_robot, w.as_imagination(), u) for w in joint.walks]
    return max(risks, key=lambda r: r.probability, default=NO_RISK)


def judges_robot_moves(items: list[Any]) -> bool:
    """Whether a batch holds an item of a kind that judges robot moves, so it is served before the others."""
    return any(isinstance(i, dict) and i.get("kind") in ROBOT_MOVE_KINDS for i in items)


def serve_one(scene: Scene, item: Any, rollout: Rollout | None = None, ahead: JudgeAhead | None = None) -> Answer:
    """One item's answer; a malformed or unanswerable item gets an error answer."""
    try:
        return serve_item(scene, item, rollout, ahead)
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
