"""Algorithm 2's response to the dangers of one moment, as a protocol of pure steps.

:func:`respond` decides what the robot does about the dangers Algorithm 1 has just
flagged: keep the move under way, give it one more look, send a new move, or find
none. It never imagines anything itself. Each search it needs is yielded as an
:class:`Ask`; whoever drives it (the action agent, over Zenoh, or a bench calling
:func:`~agents.caregiving.model.service.serve_one` in process, with :func:`drive`)
runs that search and sends the result back as an :class:`Asked`. The generator's
return value is the :class:`Response`.

The steps, in order:

* a move under way is judged again from the robot's current state first; it is
  kept while it :func:`~agents.caregiving.model.move_choice.holds`, and kept for
  one more look while it does not :func:`~agents.caregiving.model.move_choice.gives_up`;
* otherwise one search protects every endangered person, the candidates of all
  their dangers interleaved. A robot at rest does not stand idle while it judges:
  when every danger is at least even odds
  (:data:`~agents.caregiving.model.move_search.HEAD_START_RISK`), the first
  candidate is judged first and, if it harms nobody (it trips nobody, and whoever
  falls with it falls with the robot idle too, even had they just missed that fall),
  sent at once as a head start; every other candidate is then judged as a switch
  from it. A head start lasts as long as its search: when none is chosen, the robot
  brakes, or, when braking there would trip someone, drives on with it until a later
  search replaces it. For a single danger, a head start that harms only someone
  who just misses their fall is sent if braking it at the search's latest end
  harms nobody, and is braked whenever its search ends without a move;
* when no single move keeps everyone safe, each danger is searched alone, most
  urgent first (:meth:`~agents.caregiving.model.search_spec.SearchSpec.alone`: the
  others walk on beside them, their own falls let happen), and the first move found
  is sent with the people it leaves unsaved. A head start sent meanwhile is the move
  under way in those searches, and when they find nothing it drives on: braking was
  judged only at the end of the search that sent it;
* a new move replaces the one under way only when it
  :func:`~agents.caregiving.model.move_choice.replaces` it;
* when none is found: a head start ends in braking (when the search found braking
  harmless; no sooner than the moment it was judged at), and a move under way that
  walks someone into the robot or leaves them stuck is braked if braking, judged
  with the dangers' own falls let happen (so that whoever it trips after them is
  seen), ranks clearly above carrying on.

No search chooses a move whose imagination shows a fall that would not happen
without it (:class:`~agents.caregiving.model.move_choice.NoWorse`): the robot never
causes a collision its imagination can see.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Mapping
from dataclasses import dataclass, replace
from typing import TypeVar

from .move_choice import gives_up, holds, replaces, standing
from .move_search import HEAD_START_RISK, SearchItem
from .robot_moves import RobotMove
from .search_spec import SearchSpec
from .uncertainty import Uncertainty
from .verdict import SearchResult, Verdict


@dataclass(frozen=True)
class Ask:
    """One search to run: the generated candidates (``moves`` None), or just ``moves`` (``None`` in it: braking).

    ``idle_risk`` is the danger's probability with the robot idle; ``head_start`` asks for the first
    candidate to be sent while the search judges on.
    """

    spec: SearchSpec
    idle_risk: float
    moves: tuple[RobotMove | None, ...] | None = None
    head_start: bool = False

    def item(
        self, delay: float, uncertainty: Uncertainty, threshold: float, max_moves: int, judging: float
    ) -> SearchItem:
        """The search item that runs this ask: the robot starting ``delay`` seconds after the scene, ``judging``
        seconds later per judgement, at most ``max_moves`` generated candidates (given moves: just those)."""
        return SearchItem(
            replace(self.spec, delay=delay),
            uncertainty,
            threshold,
            len(self.moves) if self.moves else max_moves,
            self.idle_risk,
            judging,
            self.moves,
            self.head_start,
        )


@dataclass
class JudgingTime:
    """The running estimate of the wall seconds a generated candidate takes to judge, which sets when each
    candidate of the next search is imagined to start (:class:`~agents.caregiving.model.move_search.SearchItem`'s
    ``judging``).

    It is the compute time of the past searches of generated candidates over the candidates they judged,
    both summed with the older searches' share decaying by ``1 - weight`` a search. Summed, not averaged per
    search: a search's cost is not a fixed sum per candidate (a clear candidate costs a whole imagination
    and its sampled risk, most are refused at their first fall, and a search with bystanders first imagines
    the robot as it is), and the searches that judge many candidates, whose late candidates the estimate
    times the furthest ahead, should set it. The move under way judged again does not count at all. Averaged
    per search and with those counted, in a room of three people, the estimate came to three times a
    candidate's cost, and the robot set off on a move up to a second before it was imagined to.
    """

    untimed: float = 0.03  # the estimate until a search has been timed
    weight: float = 0.3
    _ms: float = 0.0
    _judged: float = 0.0

    @property
    def seconds(self) -> float:
        """The estimate now."""
        return self._ms / self._judged / 1e3 if self._judged else self.untimed

    def timed(self, ask: Ask, found: SearchResult, compute_ms: float) -> None:
        """Take in the simulator's compute time for ``ask``, which ``found`` is the result of."""
        if ask.moves is not None or not found.judged:
            return
        keep = 1.0 - self.weight
        self._ms = keep * self._ms + compute_ms
        self._judged = keep * self._judged + found.judged


@dataclass(frozen=True)
class Asked:
    """What came of an :class:`Ask`: the search (``None`` when the simulator refused it), and whether a head
    start it sent on the way was written as the robot's move."""

    found: SearchResult | None
    led: bool = False


@dataclass(frozen=True)
class UnderWay:
    """The robot's move under way: its target pose (``None``: braking), and whether it is on its second look
    (it failed the look before, or it is a head start, which lasts only as long as its search)."""

    move: RobotMove | None
    second_look: bool


@dataclass(frozen=True)
class Keep:
    """Keep the move under way. ``doubted``: it failed this look and gets one more; ``best_new``: the move a
    search found that does not rank clearly above it."""

    under_way: Verdict
    doubted: bool = False
    best_new: Verdict | None = None


@dataclass(frozen=True)
class Send:
    """Send ``chosen``, superseding the move under way (``under_way`` its verdict now, if there is one).

    ``unsaved`` names the people no single move keeps safe; ``braking`` marks a stop of the move under way.
    ``sets_off`` is when its search imagined the robot setting off on it (see :class:`SearchResult`).
    """

    chosen: Verdict
    under_way: Verdict | None = None
    unsaved: tuple[str, ...] = ()
    braking: bool = False
    sets_off: float | None = None


@dataclass(frozen=True)
class NoMove:
    """No move removes the danger. ``halt``: braking that ends the head start this response sent, if the search
    found it harmless (``None``: the head start drives on until a later search replaces it); ``sets_off``, when
    the search imagined the robot braking, as :attr:`Send.sets_off`: braked sooner, it stops short of where it
    was judged to."""

    halt: Verdict | None = None
    sets_off: float | None = None


#: What :func:`respond` decides.
Response = Keep | Send | NoMove
#: The protocol: searches out, their results in, a response at the end.
Responding = Generator[Ask, Asked, Response]


@dataclass(frozen=True)
class Policy:
    """The thresholds the response is judged by: the risk a move must stay under, the sampled worlds behind a
    risk (its sampling error), and the robot's name (walking into it is a fall the robot caused)."""

    threshold: float
    samples: int
    robot: str | None


def respond(
    spec: SearchSpec, idle_risks: Mapping[str, float], under_way: UnderWay | None, policy: Policy
) -> Responding:
    """The response to the dangers of ``spec``; ``idle_risks`` gives each endangered person's probability of
    falling with the robot idle. Every candidate search's verdicts are in :attr:`Asked.found` as they come."""
    again: Verdict | None = None
    if under_way is not None:
        judged = (yield Ask(spec, 1.0, (under_way.move,))).found
        again = judged.verdicts[0] if judged is not None and judged.verdicts else None
    if again is not None:
        if holds(again, policy.threshold, policy.robot):
            return Keep(again)
        if not gives_up(again, under_way is not None and under_way.second_look, policy.robot):
            return Keep(again, doubted=True)
    likely = min(idle_risks.values()) >= HEAD_START_RISK
    asked = yield Ask(spec, max(idle_risks.values()), head_start=under_way is None and likely)
    found = asked.found
    chosen = found.chosen if found is not None else None
    unsaved: tuple[str, ...] = ()
    led = found if asked.led else None  # the search, when it sent a head start
    searched_alone = chosen is None and len(spec.dangers) > 1
    if searched_alone:
        # A head start sent by the search above is under way while the searches alone judge.
        lead = led.lead if led is not None else None
        driving = replace(spec, current=lead.move) if lead is not None else spec
        for danger in sorted(spec.dangers, key=lambda d: d.time_to_collision):
            found = (yield Ask(driving.alone(danger), idle_risks[danger.person])).found
            chosen = found.chosen if found is not None else None
            if chosen is not None:
                unsaved = tuple(sorted(p for p in idle_risks if p != danger.person))
                break
    if chosen is None:
        if led is not None:
            # Braking was judged at the end of the search that sent the head start; after the searches alone, the
            # robot has driven it on further, to where braking was never judged. Driven on, it harms nobody.
            return NoMove() if searched_alone else NoMove(led.halt, led.sets_off)
        if again is not None and again.move is not None and again.trips(policy.robot):
            # Judged going on past the dangers' own falls: braking that walks someone into the robot after them
            # is then seen.
            stopping = (yield Ask(spec.letting_dangers_fall(), 1.0, (None,))).found
            braking = stopping.verdicts[0] if stopping is not None and stopping.verdicts else None
            if braking is not None and replaces(braking, again, policy.samples, policy.robot):
                return Send(braking, again, braking=True, sets_off=stopping.sets_off if stopping else None)
        return NoMove()
    if again is not None and not replaces(chosen, again, policy.samples, policy.robot):
        return Keep(again, best_new=chosen)
    return Send(chosen, again, unsaved, sets_off=found.sets_off if found is not None else None)


def as_good(send: Send, found: SearchResult | None, policy: Policy) -> Send | None:
    """``send`` with the verdict and set-off time of ``found``, its move judged again, when it is still chosen
    (:func:`~agents.caregiving.model.move_choice.choose`), safe if it was safe, and of no worse a
    :func:`~agents.caregiving.model.move_choice.standing`; otherwise ``None``."""
    again = found.chosen if found is not None else None
    if found is None or again is None or found.sets_off is None:
        return None
    if send.chosen.safe(policy.threshold) and not again.safe(policy.threshold):
        return None
    if standing(again, policy.robot)[0] > standing(send.chosen, policy.robot)[0]:
        return None
    return replace(send, chosen=again, sets_off=found.sets_off)


def judged_with_newcomers(
    send: Send, spec: SearchSpec, idle_risk: float, policy: Policy, newcomers: frozenset[str]
) -> Generator[Ask, Asked, Send | None]:
    """``send``'s move judged again on ``spec``, which holds ``newcomers``, people the search that chose it never
    imagined. ``None`` when it harms one of them: walks them into the robot, leaves them stuck, or brings a fall
    the robot as it is does not. Otherwise ``send`` as judged now when it is still :func:`as_good`, or as it was:
    a refusal over someone the search did imagine is one frame's belief against another's, and the looks that
    follow judge it as they judge any move under way."""
    found = (yield Ask(spec, idle_risk, (send.chosen.move,))).found
    verdict = found.verdicts[0] if found is not None and found.verdicts else None
    if verdict is not None and any(
        f.person in newcomers and (f.trips(policy.robot) or f.made_worse) for f in verdict.falls
    ):
        return None
    return as_good(send, found, policy) or send


def set_off_sooner(send: Send, spec: SearchSpec, idle_risk: float, policy: Policy) -> Generator[Ask, Asked, Send]:
    """``send``'s move judged again to set off as soon as one judgement allows, for a search that ended well
    before the moment it imagined the move setting off (its estimate of a candidate's cost was too high, as it is
    before any search has been timed): it goes out sooner when it is still :func:`as_good`; otherwise ``send``
    stands, to be held as it was.

    ``spec`` is the search's, with the robot's move under way now as its ``current`` (a head start sent on the
    way, if one was).
    """
    found = (yield Ask(spec, idle_risk, (send.chosen.move,))).found
    return as_good(send, found, policy) or send


T = TypeVar("T")


def drive(responding: Generator[Ask, Asked, T], run: Callable[[Ask], Asked]) -> T:
    """Run a protocol (:func:`respond`, :func:`set_off_sooner`) to its end, each search with ``run`` (in process:
    benches and tests)."""
    try:
        ask = next(responding)
        while True:
            ask = responding.send(run(ask))
    except StopIteration as done:
        ended: T = done.value
        return ended
