"""Algorithm 1: guess each person's intentions, imagine them, and mark the risky ones in W.

``python -m agents.caregiving.intention --graph G --connect EP [--scenario S]``

Whenever a person moves in W: for each person not fallen (someone lying where
they fell walks nowhere; their guesses are deleted), from the first frame
perception writes them (a track it has confirmed), the targets
are the target objects inside their horizontal field of view; the vertical gaze
range is split exactly into the classes that see the same objects
(:func:`agents.caregiving.model.visibility.gaze_classes`), which covers every sampled gaze.
Algorithm 1 is incremental: a (target, gaze class) walk is imagined again only
when its inputs moved beyond a tolerance (:mod:`agents.caregiving.imagination_cache`);
the others are reused, their times brought forward by their age. Each person's
walks to imagine go in one request (the simulator samples perception's
uncertainty around each), all people at once, and each person's intentions are
written as soon as their reply lands.

Objects a person sees in every gaze class are surely seen, and so is the robot:
they are marked ``knows`` person -> object (or robot) in W and the person is
imagined to remember them (plan around them) even once they are out of view.
The robot is remembered where it was last surely seen, kept at every frame
(:func:`~agents.caregiving.person_intentions.remember_robot`).

A walking person's heading tells where they are going: a target whose imagined
path starts more than ``--heading-gate-deg`` away from it is not their intention.
Someone tracked too briefly to tell standing from walking is taken to walk
(:meth:`agents.caregiving.model.guesses.Walking.walks`): in their first frames a
walker's fitted speed may read near nought, which would let every target in view
be guessed.
An intention is risky when the nominal walk collides or the sampled collision
probability reaches ``--risk-threshold``. The gate and this fold of each target's
gaze classes are :mod:`agents.caregiving.model.guesses`. Each surviving intention is written as
``has_intention`` person -> target (risky, path, collision point and object,
time to collision, gaze, probability); risky ones also get a ``collision`` edge
person -> object. Edges are updated in place, rewritten only when their meaning
changes (or every ``--refresh`` simulated seconds), and deleted when they stop holding
(these writes are :mod:`agents.caregiving.person_intentions`).
"""

from __future__ import annotations

import argparse
import asyncio
import math
from collections.abc import Awaitable

from agents.caregiving import keys
from agents.caregiving.model import imagine_reply
from agents.caregiving.model.guesses import Guess, guesses, heading_error
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.imagine_request import PersonItem
from agents.caregiving.model.scene import Pose
from agents.caregiving.model.uncertainty import Uncertainty
from agents.caregiving.model.visibility import candidate_targets, gaze_classes
from agents.caregiving.model.world_model import Walk
from wm import Event

from ..runtime import Agent, main, on
from .context import Context, read_context
from .imagination_cache import ImaginationCache, Key, footing
from .names import PERSON
from .person_intentions import GuessWriter, remember, remember_robot
from .risk_options import add_risk_arguments, add_walking_arguments, size_error, walking


class Intention(Agent):
    """Guesses and enacts people's intentions (Algorithm 1)."""

    name = "intention"

    @classmethod
    def add_arguments(cls, parser: argparse.ArgumentParser) -> None:
        add_risk_arguments(parser)
        add_walking_arguments(parser)
        parser.add_argument(
            "--min-track",
            type=float,
            default=0.0,
            help="seconds a person is in W before guessing (default: %(default)s, from perception's confirmed track on)",
        )
        parser.add_argument("--refresh", type=float, default=0.5, help="simulated seconds between unchanged rewrites")
        parser.add_argument(
            "--period",
            type=float,
            default=0.1,
            help="simulated seconds between evaluations at most (default: %(default)s)",
        )
        parser.add_argument(
            "--move-tol",
            type=float,
            default=0.1,
            help="metres a person or nearby body moves before its imaginations are redone",
        )
        parser.add_argument(
            "--max-age", type=float, default=3.0, help="simulated seconds an unchanged imagination is reused at most"
        )

    async def setup(self) -> None:
        a = self.args
        self.size_error = size_error(a)
        self.walking = walking(a)
        self.first_seen: dict[int, float] = {}
        self.writer = GuessWriter(a.refresh)
        self.evaluations = 0
        self.last_time = -1.0
        self.episode: int | None = None
        self.cache = ImaginationCache(move_tol=a.move_tol, max_age=a.max_age)
        self.log.info("guessing", size_error=self.size_error, samples=a.samples, threshold=a.risk_threshold)

    @on(type=PERSON, kind=["node_added", "node_updated"], coalesce=True)
    async def evaluate(self, _events: list[Event]) -> None:
        """One pass of Algorithm 1: every person tracked long enough, each in its own request, written as it lands."""
        ctx = read_context(self.g)
        if ctx is None:
            return
        with self.g.batch():
            robot_at = {p.name: remember_robot(self.g, ctx, p.name) for p in ctx.scene.people}
        if 0.0 <= ctx.scene.time - self.last_time < self.args.period:
            return
        self.last_time = ctx.scene.time
        if ctx.episode != self.episode:
            self.cache.clear()
            self.episode = ctx.episode
        people = []
        for p in ctx.scene.people:
            first = self.first_seen.setdefault(ctx.ids[p.name], ctx.scene.time)
            if ctx.scene.time - first >= self.args.min_track and p.name not in ctx.fallen:
                people.append(p.name)
        if ctx.fallen:
            self.writer.write(self.g, ctx, sorted(ctx.fallen), [])  # the fallen walk nowhere: their guesses end
        work = [self._evaluate_person(ctx, name, robot_at[name]) for name in people]
        self.cache.sweep()
        await asyncio.gather(*work)
        if people:
            self.evaluations += 1
            self.log.debug("evaluated", people=len(people), hits=self.cache.hits, misses=self.cache.misses)

    def _evaluate_person(self, ctx: Context, person: str, robot_at: Pose | None) -> Awaitable[None]:
        """Look up ``person``'s imaginations in the cache now, ``robot_at`` where they remember the robot; the
        returned awaitable imagines the rest and writes."""
        a = self.args
        uncertainty = Uncertainty(self.size_error, ctx.sigma, a.samples)
        p = ctx.scene.person(person)
        classes = gaze_classes(p, ctx.scene.bodies_around(person))
        known = remember(self.g, ctx, person, classes)
        now = footing(ctx.scene, person, ctx.sigma)
        items: list[PersonItem] = []
        answers: list[tuple[Answer, float] | None] = []
        pending: list[tuple[int, Key]] = []  # (index in items, cache key) of what must be imagined
        for t in candidate_targets(p, ctx.scene.obstacles):
            for c in classes:
                key = (person, t.name, c.visible | frozenset(known), robot_at)
                cached = self.cache.lookup(key, now)
                if cached is None:
                    pending.append((len(items), key))
                items.append(PersonItem(Walk(person, t.name, c.gaze, tuple(known), robot_at), uncertainty))
                answers.append(cached)

        async def finish() -> None:
            if pending:
                reply = await self.ask(
                    keys.imagine(a.graph),
                    {"items": [items[i].to_wire() for i, _ in pending]},
                    decode=imagine_reply.decode,
                )
                walks = ctx.walks(person, self.walking)
                for (i, key), res in zip(pending, reply.results, strict=True):
                    self.cache.store(key, now, res, aside=walks and self._aside(res, p.heading))
                    answers[i] = res, 0.0
            found = self._guesses(ctx, items, [x for x in answers if x is not None])
            self.writer.write(self.g, ctx, [person], found)

        return finish()

    def _aside(self, answer: Answer, heading: float) -> bool:
        """Whether an imagined walk sets off so far from the heading (twice the gate) that it is plainly not taken."""
        r = answer.imagination
        path = r.path if r is not None and r.reachable else ()
        return bool(path) and heading_error(path, heading) > self.walking.aside

    def _guesses(self, ctx: Context, items: list[PersonItem], results: list[tuple[Answer, float]]) -> list[Guess]:
        headings = {p.name: p.heading for p in ctx.scene.people if ctx.walks(p.name, self.walking)}
        found = guesses(
            [item.walk for item in items],
            results,
            headings,
            math.radians(self.args.heading_gate_deg),
            self.args.risk_threshold,
        )
        for guess in found:
            self.log.debug(
                "guess",
                episode=ctx.episode,
                at=round(ctx.scene.time, 2),
                person=guess.person,
                target=guess.target,
                risky=guess.risky,
                probability=round(guess.probability, 3),
                nominal=guess.nominal,
            )
        return found


if __name__ == "__main__":
    main(Intention)
