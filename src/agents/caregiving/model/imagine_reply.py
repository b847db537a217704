"""The simulator's reply to an imagine request, as a typed message with one encoder and one decoder.

A reply is a msgpack map ::

    {"episode": int | null, "stamp": s, "written_at": s | null, "compute_ms": ms, "results": [ANSWER, ...]}

``episode`` and ``written_at`` are those of the context the batch was imagined
on (null when the request pinned its own scene), ``stamp`` its simulated time.
There is one ANSWER per item of the request, in order::

    {"ok": true, "kind": "person", "result": IMAGINATION, "risk"?: RISK}
    {"ok": true, "kind": "joint", "result": JOINT, "risk"?: RISK}
    {"ok": true, "kind": "search", "result": SEARCH}
    {"ok": false, "error": "..."}

with ``RISK = {"probability", "time", "point", "object", "person"?}``, present when the
item asked for its uncertainty to be sampled, and ``SEARCH`` a move search's
verdicts and chosen move (:class:`~agents.caregiving.model.verdict.SearchResult`). :func:`decode` checks every field
and raises :class:`~agents.caregiving.model.errors.ReplyError` on anything else.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import ReplyError
from .fields import Fields
from .imagine import Imagination
from .joint import JointImagination, walk_risks, worst_risk
from .scene import Scene
from .uncertainty import Risk, Uncertainty
from .verdict import SearchResult

KINDS = frozenset({"person", "joint", "search"})
_REPLY_KEYS = frozenset({"episode", "stamp", "written_at", "compute_ms", "results"})
_ANSWER_KEYS = frozenset({"ok", "kind", "result", "risk"})
_ERROR_KEYS = frozenset({"ok", "error"})


@dataclass(frozen=True)
class Answer:
    """One item's answer: a person's imagined walk, a joint imagination or a move search; its sampled risk; or the error."""

    imagination: Imagination | None = None  # a "person" item's walk
    joint: JointImagination | None = None  # a "joint" item's robot move and walks
    search: SearchResult | None = None  # a "search" item's verdicts and chosen move
    risk: Risk | None = None  # when the item asked for its uncertainty to be sampled
    error: str | None = None  # why the item was not imagined
    #: A sampled joint item's risk of each person's walk, by person, with its worlds (see :attr:`Risk.worlds`);
    #: not on the wire.
    risks: Mapping[str, Risk] | None = field(default=None, compare=False)


def joint_answer(
    scene: Scene,
    joint: JointImagination,
    uncertainty: Uncertainty | None,
    falling: Mapping[str, str],
    anyway: Mapping[str, float] | None = None,
) -> Answer:
    """A joint item's answer: the imagination, and the risk sampled round it when the item asks for one.

    A move whose nominal imagination already fails (for a fall ``falling`` does not name) is refused whatever
    the sampled risk: none is sampled. ``anyway`` holds bystanders' sampled risks with the robot as it is,
    which the risk leaves out where the move does not raise them (see :func:`~agents.caregiving.model.joint.worst_risk`).
    """
    if uncertainty is None or not joint.safe_given(falling):
        return Answer(joint=joint)
    risks = walk_risks(scene, joint, uncertainty, falling)
    return Answer(joint=joint, risk=worst_risk(risks, anyway), risks=risks)


@dataclass(frozen=True)
class ImagineReply:
    """The answers to one batch, and the context they were imagined on."""

    episode: int | None
    stamp: float
    written_at: float | None
    compute_ms: float
    results: tuple[Answer, ...]

    @property
    def search(self) -> SearchResult | None:
        """The search of a reply to one search item; None for any other reply (or a search refused)."""
        return self.results[0].search if len(self.results) == 1 else None


def encode_risk(r: Risk) -> dict[str, Any]:
    """A msgpack-friendly risk."""
    return {
        "probability": r.probability,
        "time": r.time,
        "point": list(r.point) if r.point else None,
        "object": r.obstacle,
        **({"person": r.person} if r.person is not None else {}),
    }


def encode_answer(a: Answer) -> dict[str, Any]:
    """One entry of a reply's ``results``."""
    if a.error is not None:
        return {"ok": False, "error": a.error}
    if a.imagination is not None:
        out: dict[str, Any] = {"ok": True, "kind": "person", "result": a.imagination.to_wire()}
    elif a.joint is not None:
        out = {"ok": True, "kind": "joint", "result": a.joint.to_wire()}
    elif a.search is not None:
        out = {"ok": True, "kind": "search", "result": a.search.to_wire()}
    else:
        raise ValueError("an answer holds an imagination, a joint imagination, a search or an error")
    if a.risk is not None:
        out["risk"] = encode_risk(a.risk)
    return out


def encode(reply: ImagineReply) -> dict[str, Any]:
    """The msgpack map of a reply."""
    return {
        "episode": reply.episode,
        "stamp": reply.stamp,
        "written_at": reply.written_at,
        "compute_ms": reply.compute_ms,
        "results": [encode_answer(a) for a in reply.results],
    }


def decode_risk(f: Fields) -> Risk:
    """Parse :func:`encode_risk` output."""
    point = f.numbers("point", 2) if f.has("point") else None
    return Risk(
        f.number("probability", non_negative=True, at_most=1.0),
        f.optional_number("time"),
        (point[0], point[1]) if point else None,
        f.string("object") if f.has("object") else None,
        f.string("person") if f.has("person") else None,
    )


def decode_answer(f: Fields) -> Answer:
    """Parse :func:`encode_answer` output."""
    if not f.boolean("ok"):
        f.reject_unknown(_ERROR_KEYS)
        return Answer(error=f.string("error"))
    f.reject_unknown(_ANSWER_KEYS)
    kind = f.string("kind", choices=KINDS)
    risk = f.optional_child("risk")
    sampled = decode_risk(risk) if risk is not None else None
    if kind == "person":
        return Answer(imagination=Imagination.from_fields(f.child("result")), risk=sampled)
    if kind == "search":
        return Answer(search=SearchResult.from_fields(f.child("result")), risk=sampled)
    return Answer(joint=JointImagination.from_fields(f.child("result")), risk=sampled)


def decode(data: object) -> ImagineReply:
    """Parse and check a reply; anything else raises :class:`ReplyError`."""
    f = Fields(data, "reply", ReplyError)
    f.reject_unknown(_REPLY_KEYS)
    episode = f.optional_number("episode")
    if episode is not None and not episode.is_integer():
        raise f.fail("episode", f"expected a whole number, got {episode!r}")
    return ImagineReply(
        None if episode is None else int(episode),
        f.number("stamp"),
        f.optional_number("written_at"),
        f.number("compute_ms", non_negative=True),
        tuple(decode_answer(a) for a in f.children("results")),
    )
