"""Algorithm 2's move search: judge the candidates in time, likeliest first, and choose the move to send.

The candidates come from :mod:`agents.caregiving.model.candidates`, each judged by the joint
imagination in time (:mod:`agents.caregiving.model.judging`). :func:`search` judges them one at a
time, each with its robot starting later by the time the search has spent, and stops at the first
safe one, or where :mod:`agents.caregiving.model.move_choice` settles for less: a move that saves
everyone at the gaze found risky and makes nothing worse at the others, or, a few candidates past a
clear one that lowers the risk, the least risky clear one. A
:class:`~agents.caregiving.model.search_spec.SearchSpec` travels to the simulator in a
:class:`SearchItem`, and the :class:`~agents.caregiving.model.verdict.SearchResult` comes back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from itertools import chain, islice
from typing import TYPE_CHECKING, Any

from .candidates import Danger, candidates
from .fields import Fields
from .imagine import imagine_person
from .imagine_reply import Answer
from .imagine_request import MAX_DELAY, uncertainty_from_fields, uncertainty_to_wire
from .judging import Imagine, as_it_is, driven_on, judge_lead, judge_move, sharing_as_it_is
from .move_choice import SETTLE_AFTER_CLEAR, NoWorse, Settles, choose
from .robot_moves import RobotMove
from .scene import Scene
from .search_spec import SearchSpec
from .uncertainty import Uncertainty
from .verdict import SearchResult, Verdict
from .visibility import first_of

if TYPE_CHECKING:
    from .judge_ahead import JudgeAhead

#: Candidate moves one search may judge at most.
MAX_MOVES = 256
#: Candidate moves the action agent's searches judge at most by default. Past the 24th come the crossings and
#: the other objects' stand-offs, which save some people no earlier candidate does; few streams run past 32
#: (see *A longer search* in docs/caregiving-results.md).
DEFAULT_MAX_MOVES = 32
#: Candidates lent to the helper process at a time (see :mod:`agents.caregiving.model.judge_ahead`).
AHEAD_DEPTH = 2
#: A head start is asked for only when every danger is at least this likely with the robot idle: it is judged
#: harmless given that the person falls anyway, a bet on the likelier world only from one half up.
HEAD_START_RISK = 0.5


def search(
    scene: Scene,
    spec: SearchSpec,
    imagine: Imagine,
    uncertainty: Uncertainty,
    threshold: float,
    max_moves: int,
    idle_risk: float = 1.0,
    judging: float = 0.0,
    moves: Sequence[RobotMove | None] | None = None,
    ahead: JudgeAhead | None = None,
    settle_after_clear: int = SETTLE_AFTER_CLEAR,
    head_start: Callable[[Verdict], None] | None = None,
) -> SearchResult:
    """Algorithm 2's search: judge the candidates one at a time, likeliest first, and stop at the first safe one.

    It stops also at a move that saves everyone at the gaze found risky and makes nothing worse at the others
    (:class:`NoWorse`), and ``settle_after_clear`` candidates past the first clear move that halves
    ``idle_risk`` (:class:`Settles`): judging on for a move safe at every gaze would send any move later.
    When its candidates hold none of these, a single danger is searched once more as its person meets it at
    another gaze class (:func:`at_another_gaze`), that class first: at most half as many candidates again,
    judged on after the others.

    Each candidate is imagined with the robot starting ``judging`` seconds later than the one before, since
    the move is sent only once the search has judged it: the k-th candidate (from 1) after
    ``spec.delay + judging * k``. The result holds every verdict and the move to send (see :func:`choose`).
    A bystander's fall that happens with the robot as it is (:func:`as_it_is`, imagined before any
    candidate, but after a head start that no such fall could refuse is sent) refuses no move; the chosen
    move's reason names it. So does a bystander's sampled risk then, which refuses only a move that raises it.
    ``moves`` replaces the generated candidates (to judge the move under way again, for instance; ``None``
    among them judges braking to a stop from the robot's current state). With
    ``ahead``, a helper process judges candidates meanwhile (same verdicts, less wall time).

    With ``head_start``, a robot at rest need not stand idle while the search judges: before anything else, the
    first candidate is judged as a head start (:func:`judge_lead`), and when it is :meth:`NoWorse.harmless` and
    another candidate is left to judge, it is handed to ``head_start`` to be sent at once; so is one of a single
    danger that harms only someone who just misses their fall, if braking it at the latest the search can end (its
    second pass included) harms nobody (:meth:`_Judging.harmless_braked`: braking is then judged first, and the head
    start waits for it). Every candidate is then judged as a switch from it, the robot driving it from its command
    until the candidate's; the first one, the same move driven on, is read off the head start's own imagination
    (:func:`driven_on`) when it can be, and takes no judgement. The head start's judgement takes the first slot,
    sent or not (and braking's the second, when judged). The result's ``lead`` is that verdict. A head start lasts
    as long as the search: when no candidate is chosen, braking at the search's end is judged the same way, and the
    result's ``halt`` is that verdict if it is harmless too, or the head start was sent to be braked (the robot then
    brakes, no sooner than the result's ``sets_off``, the moment braking was judged at; otherwise it drives the
    head start on, which harms nobody). The result's ``judged`` counts the slots the
    search took, and ``lead_sets_off`` when the head start set off.
    """
    imagine = sharing_as_it_is(imagine)
    verdicts: list[Verdict] = []
    generated = candidates(scene, spec.dangers, verdicts, spec.delay, judging)
    pool: Iterator[RobotMove | None] = islice(generated if moves is None else iter(moves), max_moves)
    no_worse = NoWorse(spec, imagine, uncertainty, threshold, scene.robot_name)
    settles = Settles(no_worse, idle_risk, settle_after_clear)
    judging_ = _Judging(scene, spec, imagine, uncertainty, judging, ahead, no_worse, max_moves)
    no_worse.prepare = judging_.know_as_it_is
    if head_start is not None and moves is None and spec.current is None:
        judging_.send_lead = head_start
    judging_.in_order(pool, threshold, verdicts, settles)
    chosen = choose(verdicts, threshold, idle_risk)
    elsewhere: SearchSpec | None = None
    if chosen is None and moves is None and not (settles.by_no_worse or settles.by_count):
        elsewhere = at_another_gaze(scene, judging_.spec)
        if elsewhere is not None:
            settles = judging_.in_another_pass(elsewhere, verdicts, threshold, idle_risk, settle_after_clear)
            chosen = choose(verdicts, threshold, idle_risk)
    spec = judging_.spec
    if chosen is not None and settles.by_count and not chosen.safe(threshold):
        chosen = _noted(verdicts, chosen, f"no safe move within {settle_after_clear} candidates past a clear one")
    if chosen is None and settles.by_no_worse:
        last = verdicts[-1]
        chosen = verdicts[-1] = replace(
            last, reason=f"clear at the gaze found risky; at another, {last.reason}, as with the robot as it is"
        )
    if chosen is not None and elsewhere is not None:
        (danger,) = elsewhere.dangers
        gaze = math.degrees(elsewhere.gazes[danger.person][0])
        met = f"{danger.person} walks into {danger.obstacle}"
        chosen = _noted(verdicts, chosen, f"none at the gaze found first; searched at {gaze:.0f} deg, where {met}")
    if chosen is not None and spec.falls_anyway:
        anyway = ", ".join(f"{w.person} into {hit}" for w, hit in spec.falls_anyway)
        chosen = _noted(verdicts, chosen, f"falls with the robot as it is too: {anyway}")
    if chosen is not None and spec.risks_anyway:
        risks = ", ".join(f"{w.person} {risk:.2f}" for w, risk in spec.risks_anyway)
        chosen = _noted(verdicts, chosen, f"sampled risk with the robot as it is too: {risks}")
    slots = len(verdicts) + judging_.lead_judged + judging_.braking_judged - (judging_.read_off is not None)
    sets_off = None
    if chosen is not None:
        sets_off = judging_.spec_at(next(k for k, v in enumerate(verdicts, start=1) if v is chosen)).sets_off
    if judging_.lead is None:
        return SearchResult(chosen, tuple(verdicts), judged=slots, sets_off=sets_off)
    halt = None
    if chosen is None:
        braking, _ = judging_.judged_as_lead(lambda: judging_.spec_at(len(verdicts) + 1), None)
        halt = braking if judging_.must_brake or judging_.no_worse.harmless(braking) else None
        slots += 1
        sets_off = judging_.spec_at(len(verdicts) + 1).sets_off if halt is not None else None
    return SearchResult(chosen, tuple(verdicts), judging_.lead, halt, slots, sets_off, judging_.lead_sent().delay)


def at_another_gaze(scene: Scene, spec: SearchSpec) -> SearchSpec | None:
    """A single danger's spec as its person meets it at another of their gaze classes (the first, in the spec's
    order, where their walk collides with something else), that class first; ``None`` when there is none.

    Which way someone walks can hang on how far ahead they look: at one gaze they never see a low table and
    walk into it, at another they see it, go round, and trip on a tray beyond. When no move saves them from
    the danger found first, one that saves them at another gaze, and leaves them no worse off at the first
    (:class:`NoWorse`), is better than none; the first search's candidates were made for the other obstacle.
    """
    if len(spec.dangers) != 1:
        return None
    (danger,) = spec.dangers
    gazes = spec.gazes[danger.person]
    known = spec.known.get(danger.person, ())
    for k in range(1, len(gazes)):
        met = Danger.of(imagine_person(scene, danger.person, danger.target, gazes[k], known=known))
        if met is not None and met.obstacle != danger.obstacle:
            return replace(spec, dangers=(met,), gazes={**spec.gazes, danger.person: first_of(gazes, k)})
    return None


def _noted(verdicts: list[Verdict], chosen: Verdict, note: str) -> Verdict:
    """``chosen``, one of ``verdicts``, with ``note`` added to its reason, there too."""
    k = next(k for k, v in enumerate(verdicts) if v is chosen)
    verdicts[k] = replace(chosen, reason=f"{chosen.reason}; {note}")
    return verdicts[k]


@dataclass(eq=False)  # compared by identity: it tags the moves it lends the helper
class _Judging:
    """Judges a search's candidates, the k-th (from 1) with the robot starting ``judging * k`` seconds later
    (one judgement more after a head start's).

    Alone, each candidate is judged in turn. With ``ahead``, once the first candidate has failed, the
    helper is lent the next candidates not yet handed out, :data:`AHEAD_DEPTH` at a time, while this
    process judges the others; the verdicts are gathered in candidate order, so the search sees what it
    would see alone. After a head start is sent, the first candidate's verdict is read off the head start's
    (:func:`driven_on`: a harmless head start imagined everyone, and nobody got stuck), so the helper is lent
    the candidates after the second at once when it fails.
    """

    scene: Scene
    spec: SearchSpec  # with its falls_anyway and risks_anyway once know_as_it_is has run
    imagine: Imagine
    uncertainty: Uncertainty
    judging: float
    ahead: JudgeAhead | None
    no_worse: NoWorse  # tells a harmless head start, and shares the spec
    max_moves: int  # candidates the search judges at most: with the head start's, its longest time in judgements
    send_lead: Callable[[Verdict], None] | None = None  # sends a head start, until one is decided on
    knows_as_it_is: bool = False
    lead: Verdict | None = None  # the head start sent
    lead_judged: bool = False  # whether a head start was judged (sent or not): it took the first slot
    read_off: Verdict | None = None  # the first candidate's verdict, read off the head start's (see driven_on)
    braking_judged: bool = False  # whether braking was judged for a head start (see harmless_braked): a slot more
    passed: int = 0  # the verdicts of an earlier pass, before this pass's first candidate

    def spec_at(self, k: int) -> SearchSpec:
        """The spec the k-th candidate (of this pass) is judged with: the robot switching to it once the
        judgements before it, and its own, are done.

        After a head start is sent, the robot drives it from its command until the switch.
        """
        k += self.passed
        if self.lead is None:
            opening = self.lead_judged + self.braking_judged  # a head start judged and not sent took its slots
            return replace(self.spec, delay=self.spec.delay + self.judging * (k + opening))
        judgements = k - (self.read_off is not None)  # the k-th's and those before it; one read off takes none
        return replace(self.lead_sent(), lead=self.lead.move, lead_for=self.judging * judgements)

    def lead_sent(self) -> SearchSpec:
        """The spec with the robot starting when a head start is sent: after its own judgement (and braking's, when
        that was judged first)."""
        return replace(self.spec, delay=self.spec.delay + self.judging * (1 + self.braking_judged))

    def know_as_it_is(self) -> bool:
        """Imagine the robot as it is into the spec (:func:`as_it_is`), once; whether a bystander falls or runs a
        sampled risk then.

        Only when a verdict needs it (:meth:`settled`): most searches meet no fall it could excuse, and it
        imagines everyone to the end of their walk.
        """
        if not self.knows_as_it_is:
            self.knows_as_it_is = True
            self.spec = as_it_is(self.spec, self.imagine, self.scene, self.uncertainty)
            self.no_worse.spec = self.spec
        return bool(self.spec.falls_anyway or self.spec.risks_anyway)

    def opened_with_head_start(
        self,
        positions: Iterator[tuple[int, RobotMove | None]],
        verdicts: list[Verdict],
    ) -> Iterator[tuple[int, RobotMove | None]]:
        """Judge the first candidate as a head start, and send it if it is harmless and another candidate follows;
        the candidates left to judge.

        The first candidate's verdict, read off the head start's (:func:`driven_on`), goes into ``verdicts`` before
        the second is asked for, so that the candidates can follow from it (its swerves come next). The head
        start is judged before :func:`as_it_is` is imagined, which only excuses falls and risks: a head start
        clear without it is clear with it, on the same imaginations (no risk is sampled), and goes out one
        imagination sooner. One that is not clear is judged again if some bystander does fall anyway.
        """
        send, self.send_lead = self.send_lead, None
        if send is None:
            return positions
        opening = next(positions, None)
        if opening is None:
            return positions
        first = opening[1]
        self.lead_judged = True
        lead, answers = self.judged_as_lead(self.lead_sent, first)
        if not self.no_worse.harmless(lead) and not self.harmless_braked(lead, first):
            return chain([opening], positions)
        knew = self.knows_as_it_is
        read_off = driven_on(self.scene, self.lead_sent(), first, answers, self.imagine, self.uncertainty)
        if read_off is not None and self.excusable(read_off, knew) and self.know_as_it_is():
            read_off = driven_on(self.scene, self.lead_sent(), first, answers, self.imagine, self.uncertainty)
        verdicts += [self.no_worse.worsened(read_off)] if read_off is not None else []
        second = next(positions, None)
        if second is None:  # a head start is for a search that judges on past its first candidate
            del verdicts[:]
            return iter([opening])
        self.lead, self.read_off = lead, read_off
        send(lead)
        return chain([second] if read_off is not None else [opening, second], positions)

    @property
    def must_brake(self) -> bool:
        """Whether the head start sent is harmless only braked when the search ends without a move: braking was
        judged for it (:meth:`harmless_braked`), and found harmless."""
        return self.lead is not None and self.braking_judged

    def harmless_braked(self, lead: Verdict, move: RobotMove | None) -> bool:
        """Whether a head start refused only for falls it brings where someone just misses theirs
        (:attr:`~agents.caregiving.model.verdict.Fall.made_worse`) harms nobody braked at the latest the search
        can end.

        Driven to its end, such a head start walks someone into what they would just miss; braked once the search
        has judged every candidate, it may leave the robot short of their way, and it still sets the robot off
        while the search looks for a move that saves them. It is sent only where one search decides (a single
        danger: no searches alone follow, with it driven on), and braked whenever that search ends without a move.
        """
        if len(self.spec.dangers) != 1 or not self.no_worse.harmless(lead, made_worse_too=True):
            return False
        self.braking_judged = True
        latest = replace(self.lead_sent(), lead=move, lead_for=self.judging * (self.max_moves + self.another + 1))
        braking, _ = self.judged_as_lead(lambda: latest, None)
        return self.no_worse.harmless(braking)

    def judged_as_lead(self, at: Callable[[], SearchSpec], move: RobotMove | None) -> tuple[Verdict, list[Answer]]:
        """:func:`judge_lead` of ``move`` (``None``: braking) with the spec ``at()`` gives; one refused before who
        falls anyway was known is judged again once it is, if someone does (only the walk sets whose imagination
        ended in a fall now excused are imagined anew). The robot as it is only ever excuses falls, so one clear
        without it is clear with it, on the same imaginations."""
        knew = self.knows_as_it_is
        robot = self.scene.robot_name
        verdict, answers = judge_lead(at(), move, self.imagine, self.uncertainty, robot)
        if not knew and not verdict.clear and self.know_as_it_is():
            verdict, answers = judge_lead(at(), move, self.imagine, self.uncertainty, robot, answers)
        return verdict, answers

    def excusable(self, verdict: Verdict, knew: bool) -> bool:
        """Whether ``verdict``, judged without knowing who falls anyway (``knew`` false), was refused for
        something that knowing it could excuse: a bystander's fall into something other than the robot, or a
        bystander's sampled risk."""
        if knew:
            return False
        endangered = {d.person for d in self.spec.dangers} | set(self.spec.falling)
        robot = self.scene.robot_name
        return any(f.obstacle is not None and f.obstacle != robot and f.person not in endangered for f in verdict.falls)

    def settled(self, k: int, move: RobotMove | None, verdict: Verdict, knew: bool) -> Verdict:
        """The k-th candidate's verdict as a search that knew who falls anyway from the start gives it.

        One judged without knowing differs only where a bystander's fall or sampled risk refused it (a fall
        that happens anyway neither ends an imagination nor counts in the sampled risk): then the robot as it
        is is imagined, and if someone does fall anyway, the candidate is judged again. Either way, it is held to
        :meth:`NoWorse.worsened`.
        """
        if self.excusable(verdict, knew) and self.know_as_it_is():
            verdict = self.judged_at(k, move)
        return self.no_worse.worsened(verdict)

    def judged_at(self, k: int, move: RobotMove | None) -> Verdict:
        """:func:`judge_move` of ``move`` as the k-th candidate, with the spec as the search knows it now."""
        return judge_move(self.spec_at(k), move, self.imagine, self.uncertainty, self.scene.robot_name)

    def in_order(
        self,
        moves: Iterator[RobotMove | None],
        threshold: float,
        verdicts: list[Verdict],
        settles: Callable[[Verdict], bool],
    ) -> None:
        """Fill ``verdicts`` in candidate order, up to the first safe one or one that ``settles`` the search.

        ``moves`` may read ``verdicts`` as they come in.
        """
        positions = self.opened_with_head_start(enumerate(moves, start=1), verdicts)
        if verdicts and (verdicts[0].safe(threshold) or settles(verdicts[0])):
            return
        judged: dict[int, Verdict] = {}
        # The candidates the helper is judging, by position, and whether who falls anyway was known when lent.
        lent: dict[int, tuple[RobotMove | None, bool]] = {}

        def exchange(wait: bool = False) -> None:
            """Take the helper's verdicts, then lend it the next candidates up to :data:`AHEAD_DEPTH`.

            Nothing more is lent before the first candidate has failed: most searches end with it, and a
            helper judging the next ones meanwhile would only take the second core from the rest of the stack.
            """
            ahead = self.ahead
            if ahead is None:
                return
            for (owner, k), verdict in ahead.answers(wait):
                if owner is self:
                    move, knew = lent.pop(k)
                    judged[k] = self.settled(k, move, verdict, knew) if verdict else self.judge(k, move)
            while verdicts and ahead.outstanding < AHEAD_DEPTH:
                k, move = next(positions, (0, None))
                if k == 0:
                    return
                if not ahead.lend((self, k), self.scene, self.spec_at(k), move, self.uncertainty):
                    judged[k] = self.judge(k, move)
                    return
                lent[k] = (move, self.knows_as_it_is)

        def gather() -> bool:
            """Move the judged prefix into ``verdicts``; True once it ends with one that settles the search."""
            while (k := len(verdicts) + 1) in judged:
                verdicts.append(judged.pop(k))
                if verdicts[-1].safe(threshold) or settles(verdicts[-1]):
                    return True
            return False

        mine = next(positions, None)  # the next candidate this process judges: always the first not lent
        exchange()  # after a head start whose verdict was read off, the helper sets to work at once
        while mine is not None:
            judged[mine[0]] = self.judge(*mine)
            exchange()
            if gather():
                return
            mine = next(positions, None)
            exchange()
        while lent:
            exchange(wait=True)
            if gather():
                return
        gather()

    @property
    def another(self) -> int:
        """The candidates a pass at another gaze class judges at most (:func:`at_another_gaze`): half the search's,
        for a single danger with more than one class."""
        single = len(self.spec.dangers) == 1 and len(self.spec.gazes[self.spec.dangers[0].person]) > 1
        return self.max_moves // 2 if single else 0

    def in_another_pass(
        self, spec: SearchSpec, verdicts: list[Verdict], threshold: float, idle_risk: float, after_clear: int
    ) -> Settles:
        """Judge on with ``spec`` (:func:`at_another_gaze`): its own candidates, at most half the search's, after
        the ``verdicts`` so far (which this pass's are added to); what settles this pass."""
        self.spec = replace(spec, falls_anyway=self.spec.falls_anyway, risks_anyway=self.spec.risks_anyway)
        self.no_worse = replace(self.no_worse, spec=self.spec, _idle={})
        self.passed = len(verdicts)
        mine: list[Verdict] = []
        start = self.spec.delay + self.judging * (self.passed + self.lead_judged + self.braking_judged)
        pool = islice(candidates(self.scene, self.spec.dangers, mine, start, self.judging), self.another)
        settles = Settles(self.no_worse, idle_risk, after_clear)
        self.in_order(pool, threshold, mine, settles)
        verdicts += mine
        self.passed = 0
        return settles

    def judge(self, k: int, move: RobotMove | None) -> Verdict:
        knew = self.knows_as_it_is
        return self.settled(k, move, self.judged_at(k, move), knew)


@dataclass(frozen=True)
class SearchItem:
    """Run the whole search for ``spec`` in the simulator (judging ``moves`` instead of the candidates, if given).

    A ``None`` among ``moves`` (null on the wire) is the robot braking to a stop. With ``head_start``, the
    asker takes a head start while the search judges on (see :func:`search`), sent by the simulator as it is found.
    """

    spec: SearchSpec
    uncertainty: Uncertainty
    threshold: float
    max_moves: int
    idle_risk: float = 1.0
    judging: float = 0.0
    moves: tuple[RobotMove | None, ...] | None = None
    head_start: bool = False

    def to_wire(self) -> dict[str, Any]:
        """``{"kind": "search", "spec", "uncertainty", "threshold", "max_moves", "idle_risk", "judging",
        "head_start", "moves"?}``."""
        out: dict[str, Any] = {
            "kind": "search",
            "spec": self.spec.to_wire(),
            "uncertainty": uncertainty_to_wire(self.uncertainty),
            "threshold": self.threshold,
            "max_moves": self.max_moves,
            "idle_risk": self.idle_risk,
            "judging": self.judging,
            "head_start": self.head_start,
        }
        if self.moves is not None:
            out["moves"] = [m.to_wire() if m is not None else None for m in self.moves]
        return out

    @classmethod
    def from_fields(cls, f: Fields) -> SearchItem:
        """Parse :meth:`to_wire` output: every field is checked before the first candidate is imagined."""
        uncertainty = uncertainty_from_fields(f.child("uncertainty"))
        return cls(
            SearchSpec.from_fields(f.child("spec")),
            uncertainty,
            f.number("threshold", positive=True, at_most=1.0),
            int(f.number("max_moves", positive=True, at_most=MAX_MOVES)),
            f.number("idle_risk", 1.0, non_negative=True, at_most=1.0),
            f.number("judging", 0.0, non_negative=True, at_most=MAX_DELAY),
            tuple(RobotMove.from_fields(m) if m is not None else None for m in f.children_or_null("moves"))
            if f.has("moves")
            else None,
            f.boolean("head_start", False),
        )

    def run(
        self,
        scene: Scene,
        imagine: Imagine,
        ahead: JudgeAhead | None = None,
        head_start: Callable[[Verdict], None] | None = None,
    ) -> SearchResult:
        """:func:`search` with this item's parameters; a head start goes to ``head_start`` if the item asks for one."""
        return search(
            scene,
            self.spec,
            imagine,
            self.uncertainty,
            self.threshold,
            self.max_moves,
            self.idle_risk,
            self.judging,
            self.moves,
            ahead,
            head_start=head_start if self.head_start else None,
        )
