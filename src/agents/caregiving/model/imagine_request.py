"""The simulator's "imagine" items as typed values, with their wire forms.

* :class:`PersonItem`: one person's walk alone (Algorithm 1);
* :class:`JointItem`: a robot move imagined in time with the walks it concerns (Algorithm 2);
* Algorithm 2's whole move search is :class:`agents.caregiving.model.move_search.SearchItem`.

Agents build these and send ``to_wire()``; the simulator parses them back
(:func:`agents.caregiving.model.service.item_from_wire`) and a search inside it
hands its joint items over as they are, without a wire round trip. Each item
may ask for the collision risk sampled under perception's uncertainty
(:class:`~agents.caregiving.model.uncertainty.Uncertainty`, whose wire form is here too).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .fields import Fields
from .joint import walk_from_fields, walk_to_wire
from .robot_moves import RobotMove
from .uncertainty import Uncertainty
from .world_model import Passing, Walk

#: Seconds a joint item may ask the robot to go on with its current move before the new one.
MAX_DELAY = 5.0


def uncertainty_to_wire(u: Uncertainty) -> dict[str, Any]:
    """``{"size_error", "sigma": {name: metres}, "samples", "seed"}``."""
    return {"size_error": u.size_error, "sigma": dict(u.sigma), "samples": u.samples, "seed": u.seed}


def uncertainty_from_fields(u: Fields) -> Uncertainty:
    """Parse an item's ``uncertainty`` map."""
    sigma = u.child("sigma", {})
    return Uncertainty(
        u.number("size_error", 0.0, non_negative=True, at_most=0.9),
        {k: sigma.number(k, non_negative=True) for k in sigma.keys()},
        int(u.number("samples", 64, positive=True, at_most=4096)),
        int(u.number("seed", 0)),
    )


def optional_uncertainty(f: Fields) -> Uncertainty | None:
    """An item's ``uncertainty``, if it asks for one."""
    u = f.optional_child("uncertainty")
    return uncertainty_from_fields(u) if u is not None else None


@dataclass(frozen=True)
class PersonItem:
    """Imagine one person's walk to a target at a gaze, knowing of some objects already."""

    walk: Walk
    uncertainty: Uncertainty | None = None

    def to_wire(self) -> dict[str, Any]:
        """``{"kind": "person", "person", "target", "gaze", "known", "uncertainty"?}``."""
        out = {"kind": "person", **walk_to_wire(self.walk)}
        if self.uncertainty is not None:
            out["uncertainty"] = uncertainty_to_wire(self.uncertainty)
        return out

    @classmethod
    def from_fields(cls, f: Fields) -> PersonItem:
        """Parse :meth:`to_wire` output."""
        walk = walk_from_fields(f)
        if walk.toward is not None:
            raise f.fail("toward", "Algorithm 1 imagines walks to targets: give a target")
        return cls(walk, optional_uncertainty(f))


@dataclass(frozen=True)
class JointItem:
    """Imagine ``move`` in time with ``walks``, after ``delay`` seconds more of the ``current`` move (if any).

    A ``lead`` (a search's head start) is driven for ``lead_for`` seconds between the two.

    With ``until_first_fall`` the imagination ends when the first person falls (a search needs no more
    to refuse the move): the others' walks are then reported as still ``walking``. ``falling`` names the
    people whose fall into a given object happens anyway (``{person: object}``): that fall neither ends
    the imagination nor stops the risk from being sampled for the others. ``anyway`` holds bystanders'
    sampled risks with the robot as it is (``{person: probability}``): the risk sampled leaves out a walk
    whose risk the move does not raise. ``passing`` names people imagined passing what they are believed to
    walk into (see :class:`~agents.caregiving.model.world_model.Passing`), to tell what a false alarm meets.
    """

    walks: tuple[Walk, ...]
    move: RobotMove | None
    current: RobotMove | None = None
    delay: float = 0.0
    uncertainty: Uncertainty | None = None
    until_first_fall: bool = False
    falling: Mapping[str, str] = field(default_factory=dict)
    lead: RobotMove | None = None
    lead_for: float = 0.0
    anyway: Mapping[str, float] = field(default_factory=dict)
    passing: Mapping[str, Passing] = field(default_factory=dict)

    def to_wire(self) -> dict[str, Any]:
        """``{"kind": "joint", "walks", "move", "current", "delay", "until_first_fall", "falling", "lead",
        "lead_for", "anyway", "passing", "uncertainty"?}``."""
        out: dict[str, Any] = {
            "kind": "joint",
            "walks": [walk_to_wire(w) for w in self.walks],
            "move": self.move.to_wire() if self.move else None,
            "current": self.current.to_wire() if self.current else None,
            "delay": self.delay,
            "until_first_fall": self.until_first_fall,
            "falling": dict(self.falling),
            "lead": self.lead.to_wire() if self.lead else None,
            "lead_for": self.lead_for,
            "anyway": dict(self.anyway),
            "passing": {
                person: {"object": p.obstacle, "allowance": p.allowance if p.allowance < math.inf else None}
                for person, p in self.passing.items()
            },
        }
        if self.uncertainty is not None:
            out["uncertainty"] = uncertainty_to_wire(self.uncertainty)
        return out

    @classmethod
    def from_fields(cls, f: Fields) -> JointItem:
        """Parse :meth:`to_wire` output; at least one walk."""
        uncertainty = optional_uncertainty(f)
        walks = tuple(walk_from_fields(w) for w in f.children("walks"))
        if not walks:
            raise f.fail("walks", "expected at least one walk")
        people = {w.person for w in walks}
        return cls(
            walks,
            RobotMove.optional_from(f, "move"),
            RobotMove.optional_from(f, "current"),
            f.number("delay", 0.0, non_negative=True, at_most=MAX_DELAY),
            uncertainty,
            f.boolean("until_first_fall", False),
            falling_from_fields(f.child("falling", {}), people),
            RobotMove.optional_from(f, "lead"),
            f.number("lead_for", 0.0, non_negative=True, at_most=MAX_DELAY),
            risks_from_fields(f.child("anyway", {}), people),
            passing_from_fields(f.child("passing", {}), people),
        )


def falling_from_fields(f: Fields, people: set[str]) -> dict[str, str]:
    """``{person: object}`` for some of ``people``."""
    return {_one_of(f, person, people): f.string(person) for person in f.keys()}


def passing_from_fields(f: Fields, people: set[str]) -> dict[str, Passing]:
    """``{person: {object, allowance}}`` for some of ``people``; a null allowance is an infinite one."""
    passing = {}
    for person in f.keys():
        entry = f.child(_one_of(f, person, people))
        allowance = entry.number("allowance", non_negative=True) if entry.has("allowance") else math.inf
        passing[person] = Passing(entry.string("object"), allowance)
    return passing


def risks_from_fields(f: Fields, people: set[str]) -> dict[str, float]:
    """``{person: probability}`` for some of ``people``."""
    return {_one_of(f, person, people): f.number(person, non_negative=True, at_most=1.0) for person in f.keys()}


def _one_of(f: Fields, person: str, people: set[str]) -> str:
    if person not in people:
        raise f.fail(person, f"expected one of {sorted(people)}")
    return person
