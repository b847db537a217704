"""Algorithm 2's response protocol: the searches it asks for, in order, and what it decides from their results.

The protocol is pure, so most cases feed it search results made here and check each :class:`Ask` it yields;
the last runs it to its end on a recorded danger with the real move search, in process.
"""

from dataclasses import replace
from functools import partial

import pytest
from recorded_cases import DELAY, EXACT, JUDGING, THRESHOLD, recorded_case

from agents.caregiving.model.candidates import Danger
from agents.caregiving.model.errors import RequestError
from agents.caregiving.model.fields import Fields
from agents.caregiving.model.move_search import search
from agents.caregiving.model.response import (
    Ask,
    Asked,
    JudgingTime,
    Keep,
    NoMove,
    Policy,
    Responding,
    Response,
    Send,
    UnderWay,
    as_good,
    drive,
    judged_with_newcomers,
    respond,
    set_off_sooner,
)
from agents.caregiving.model.robot_moves import RobotMove
from agents.caregiving.model.search_spec import SearchSpec
from agents.caregiving.model.service import serve_one
from agents.caregiving.model.verdict import Fall, SearchResult, Verdict
from bridges.experiment.perfect_belief import saved_in_truth

POLICY = Policy(threshold=0.2, samples=64, robot="robot")
UNDER_WAY = RobotMove("ball", 1.0, 0.0, 0.0)
NEW = RobotMove("ball", 0.5, 0.5, 1.57)


def danger(person: str, ttc: float) -> Danger:
    return Danger(person, "couch", ((0.0, 0.0), (2.0, 0.0)), (1.5, 0.0), "ball", ttc)


def spec(*dangers: Danger) -> SearchSpec:
    return SearchSpec(dangers, {d.person: (0.1,) for d in dangers}, {})


def safe(move: RobotMove | None, risk: float = 0.0) -> Verdict:
    return Verdict(move, True, risk, 1.0, "everyone imagined walks clear")


def falls(move: RobotMove | None, into: str, walk_set: int = 0) -> Verdict:
    return Verdict(move, False, 1.0, 1.0, f"walks into {into}", (Fall(walk_set, "ann", into, (1.0, 0.0)),))


def found(*verdicts: Verdict, chosen: int | None = None) -> SearchResult:
    return SearchResult(verdicts[chosen] if chosen is not None else None, verdicts, judged=len(verdicts))


class Script:
    """Drives the protocol with set results, one per ask, and keeps every ask."""

    def __init__(self, *answers: Asked) -> None:
        self.answers = list(answers)
        self.asks: list[Ask] = []

    def __call__(self, ask: Ask) -> Asked:
        self.asks.append(ask)
        return self.answers.pop(0)

    def run(self, responding: Responding) -> Response:
        response = drive(responding, self)
        assert not self.answers, "the protocol asked for fewer searches than expected"
        return response


def test_at_rest_a_likely_danger_gets_one_search_with_a_head_start() -> None:
    chosen = safe(NEW)
    script = Script(Asked(found(falls(UNDER_WAY, "ball"), chosen, chosen=1)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 0.9}, None, POLICY))
    assert response == Send(chosen)
    (ask,) = script.asks
    assert ask.head_start and ask.moves is None and ask.idle_risk == 0.9


def test_an_unlikely_danger_gets_no_head_start() -> None:
    script = Script(Asked(found(safe(NEW), chosen=0)))
    script.run(respond(spec(danger("ann", 2.0), danger("bo", 3.0)), {"ann": 0.9, "bo": 0.3}, None, POLICY))
    (ask,) = script.asks
    assert not ask.head_start and ask.idle_risk == 0.9


def test_a_move_under_way_that_still_holds_is_kept_without_a_search() -> None:
    again = safe(UNDER_WAY, risk=0.1)
    script = Script(Asked(found(again)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, False), POLICY))
    assert response == Keep(again)
    (ask,) = script.asks
    assert ask.moves == (UNDER_WAY,) and ask.idle_risk == 1.0


def test_a_move_under_way_that_fails_once_gets_one_more_look() -> None:
    again = falls(UNDER_WAY, "ball")
    script = Script(Asked(found(again)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, False), POLICY))
    assert response == Keep(again, doubted=True)


def test_a_move_under_way_that_fails_again_is_replaced_by_a_better_one() -> None:
    again, better = falls(UNDER_WAY, "ball"), safe(NEW)
    script = Script(Asked(found(again)), Asked(found(better, chosen=0)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, True), POLICY))
    assert response == Send(better, again)
    assert not script.asks[1].head_start and script.asks[1].moves is None  # no head start with a move under way


def test_a_new_move_not_clearly_better_leaves_the_move_under_way() -> None:
    again = safe(UNDER_WAY, risk=0.25)  # clear but above the threshold: it does not hold
    near = safe(NEW, risk=0.24)  # within the sampling error of 0.25 over 64 samples
    script = Script(Asked(found(again)), Asked(found(near, chosen=0)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, True), POLICY))
    assert response == Keep(again, best_new=near)


def test_a_move_under_way_that_trips_someone_is_braked_when_no_move_is_found() -> None:
    """Braking is judged with the danger's own fall let happen: its imagination goes on past that fall, to
    whoever braking would walk into the robot after it."""
    again, braking = falls(UNDER_WAY, "robot"), safe(None)
    script = Script(Asked(found(again)), Asked(found(falls(NEW, "ball"))), Asked(found(braking)))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, False), POLICY))
    assert response == Send(braking, again, braking=True)
    assert script.asks[2].moves == (None,)
    assert script.asks[2].spec == spec(danger("ann", 2.0)).letting_dangers_fall()
    assert script.asks[2].spec.falling == {"ann": "ball"}


def test_braking_that_ranks_no_better_is_not_sent() -> None:
    again = falls(UNDER_WAY, "robot")
    script = Script(Asked(found(again)), Asked(found()), Asked(found(falls(None, "robot"))))
    response = script.run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, UnderWay(UNDER_WAY, False), POLICY))
    assert response == NoMove()


def test_when_no_move_saves_everyone_each_danger_is_searched_alone_most_urgent_first() -> None:
    ann, bo = danger("ann", 3.0), danger("bo", 1.5)
    rescue = safe(NEW)
    script = Script(Asked(found(falls(NEW, "ball"))), Asked(found(falls(NEW, "ball"))), Asked(found(rescue, chosen=0)))
    seen_at = {"ann": (1.0, 2.0, 0.0), "bo": (3.0, 1.0, 1.5)}
    response = script.run(respond(replace(spec(ann, bo), robot_at=seen_at), {"ann": 1.0, "bo": 1.0}, None, POLICY))
    assert response == Send(rescue, unsaved=("bo",))
    assert [a.spec.dangers for a in script.asks[1:]] == [(bo,), (ann,)]
    # Searched alone, the other endangered person still walks, on the walk found risky, their own fall let happen:
    # no move there saves them, but none may trip them another way, or walk them into the robot. They remember
    # the robot where they did, and each spec is one the simulator takes off the wire.
    for ask, other in zip(script.asks[1:], (ann, bo), strict=True):
        (walk,) = ask.spec.bystanders
        assert (walk.person, walk.target, walk.gaze, walk.robot_at) == (
            other.person,
            other.target,
            0.1,
            seen_at[other.person],
        )
        (searched,) = ask.spec.dangers
        assert ask.spec.robot_at == {searched.person: seen_at[searched.person]}
        assert ask.spec.falling == {other.person: other.obstacle}
        assert all(walk in walks for walks in ask.spec.walk_sets())
        assert SearchSpec.from_fields(Fields(ask.spec.to_wire(), "spec", RequestError)) == ask.spec


def test_a_head_start_with_no_move_chosen_ends_in_the_braking_the_search_judged() -> None:
    halt = safe(None)
    result = SearchResult(None, (falls(NEW, "ball"),), lead=safe(NEW), halt=halt, judged=2, sets_off=0.3)
    response = Script(Asked(result, led=True)).run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, None, POLICY))
    assert response == NoMove(halt, sets_off=0.3)


def test_a_head_start_is_the_move_under_way_in_the_searches_alone_and_drives_on_when_they_find_nothing() -> None:
    """Braking was judged at the end of the search that sent the head start; the searches alone come after it,
    while the robot drives on, so that braking is not sent."""
    ann, bo = danger("ann", 3.0), danger("bo", 1.5)
    joint = SearchResult(None, (falls(NEW, "ball"),), lead=safe(UNDER_WAY), halt=safe(None), judged=2)
    script = Script(Asked(joint, led=True), Asked(found(falls(NEW, "ball"))), Asked(found(falls(NEW, "ball"))))
    response = script.run(respond(spec(ann, bo), {"ann": 1.0, "bo": 1.0}, None, POLICY))
    assert response == NoMove()
    assert [a.spec.current for a in script.asks] == [None, UNDER_WAY, UNDER_WAY]


@pytest.mark.parametrize("led", [False, True])
def test_a_refused_search_finds_no_move(led: bool) -> None:
    response = Script(Asked(None, led=led)).run(respond(spec(danger("ann", 2.0)), {"ann": 1.0}, None, POLICY))
    assert response == NoMove()


def test_on_a_recorded_danger_the_response_sends_the_searchs_move_and_it_saves_the_person() -> None:
    """The paper's room at seed 2024, trial 50, as the live run first saw it: the protocol, driven by the real
    search in process, sends the move a plain search chooses, and that move saves the person in the truth."""
    trial, planner, scene, spec_now = recorded_case("paper_experiment1", 2024, 50, 0.55)
    imagine = partial(serve_one, scene)

    def run(ask: Ask) -> Asked:
        item = ask.item(ask.spec.delay, EXACT, THRESHOLD, 24, JUDGING)
        return Asked(item.run(scene, imagine, None, (lambda _lead: None) if ask.head_start else None))

    response = drive(respond(spec_now, {d.person: 1.0 for d in spec_now.dangers}, None, POLICY), run)
    plain = search(scene, spec_now, imagine, EXACT, THRESHOLD, 24, judging=JUDGING, head_start=lambda _lead: None)
    assert isinstance(response, Send) and plain.chosen is not None
    assert response.chosen == plain.chosen and not response.unsaved
    assert saved_in_truth(trial, 0.55, planner, DELAY, JUDGING, plain)


def test_a_move_judged_again_to_set_off_sooner_goes_out_with_its_new_verdict_when_it_still_saves() -> None:
    held = Send(safe(NEW, risk=0.1), sets_off=0.6)
    sooner = SearchResult(safe(NEW, risk=0.05), (safe(NEW, risk=0.05),), judged=1, sets_off=0.1)
    now = spec(danger("ann", 2.0))
    script = Script(Asked(sooner))
    assert drive(set_off_sooner(held, now, 0.9, POLICY), script) == Send(sooner.chosen, sets_off=0.1)
    (ask,) = script.asks
    assert ask.spec is now and ask.moves == (NEW,) and ask.idle_risk == 0.9 and not ask.head_start


@pytest.mark.parametrize(
    "again",
    [
        falls(NEW, "ball"),  # refused now
        Verdict(NEW, True, 0.3, 1.0, "everyone imagined walks clear"),  # clear and halving the risk, but not safe
    ],
    ids=["refused", "no_longer_safe"],
)
def test_a_move_that_no_longer_does_what_it_was_chosen_for_sooner_stays_held(again: Verdict) -> None:
    held = Send(safe(NEW, risk=0.1), sets_off=0.6)
    chosen = again if again.clear else None
    judged = SearchResult(chosen, (again,), judged=1, sets_off=0.1 if chosen else None)
    assert drive(set_off_sooner(held, spec(danger("ann", 2.0)), 1.0, POLICY), Script(Asked(judged))) is held
    assert drive(set_off_sooner(held, spec(danger("ann", 2.0)), 1.0, POLICY), Script(Asked(None))) is held
    assert as_good(held, judged, POLICY) is None  # the test it fails
    assert as_good(held, None, POLICY) is None


def test_a_move_chosen_before_someone_came_into_w_is_not_sent_only_when_it_harms_them() -> None:
    """Judged once more with a newcomer the search never imagined: a walk of theirs into the robot keeps the move
    from going out; a refusal over someone the search did imagine does not (one frame's belief against
    another's), and the move goes out as it was; a move still as good goes out as judged now."""
    held = Send(safe(NEW, risk=0.1), sets_off=0.3)
    now = spec(danger("ann", 2.0))

    def refused_over(person: str) -> Asked:
        fall = Fall(0, person, "robot", (1.0, 1.0))
        return Asked(
            SearchResult(None, (Verdict(NEW, False, 1.0, 1.0, f"{person} walks into robot", (fall,)),), judged=1)
        )

    newcomers = frozenset({"bob"})
    assert drive(judged_with_newcomers(held, now, 1.0, POLICY, newcomers), Script(refused_over("bob"))) is None
    assert drive(judged_with_newcomers(held, now, 1.0, POLICY, newcomers), Script(refused_over("cy"))) is held
    still = SearchResult(safe(NEW, risk=0.1), (safe(NEW, risk=0.1),), judged=1, sets_off=0.0)
    sent = drive(judged_with_newcomers(held, now, 1.0, POLICY, newcomers), Script(Asked(still)))
    assert sent == Send(still.chosen, sets_off=0.0)


def test_a_first_search_timed_too_slow_sends_its_move_sooner_and_it_still_saves_the_person() -> None:
    """On the recorded danger, a search imagining 30 ms a candidate (the estimate before any search is timed)
    chooses a move it imagines setting off late; judged again to set off after one judgement at this machine's
    8 ms, the same move is still chosen, sets off sooner, and saves the person in the truth."""
    trial, planner, scene, spec_now = recorded_case("paper_experiment1", 2024, 50, 0.55)
    imagine = partial(serve_one, scene)
    untimed = search(scene, spec_now, imagine, EXACT, THRESHOLD, 24, judging=0.03)
    assert untimed.chosen is not None and untimed.sets_off is not None
    sooner: list[SearchResult] = []

    def run(ask: Ask) -> Asked:
        sooner.append(ask.item(DELAY, EXACT, THRESHOLD, 24, 0.008).run(scene, imagine, None))
        return Asked(sooner[-1])

    sent = drive(set_off_sooner(Send(untimed.chosen, sets_off=untimed.sets_off), spec_now, 1.0, POLICY), run)
    assert sent.chosen.move == untimed.chosen.move and sent.chosen is not untimed.chosen
    assert sent.sets_off == pytest.approx(DELAY + 0.008) and sent.sets_off < untimed.sets_off
    assert saved_in_truth(trial, 0.55, planner, DELAY, 0.008, sooner[0])


def test_the_searches_of_generated_candidates_time_a_candidate_by_their_sums() -> None:
    searched = Ask(spec(danger("ada", 2.0)), 1.0)
    again = Ask(spec(danger("ada", 2.0)), 1.0, moves=(UNDER_WAY,))
    judging = JudgingTime(untimed=0.03, weight=0.5)
    judging.timed(again, SearchResult(None, (), judged=1), compute_ms=90.0)  # one whole imagination
    assert judging.seconds == pytest.approx(0.03)
    judging.timed(searched, SearchResult(None, (), judged=1), compute_ms=60.0)  # a clear first candidate
    assert judging.seconds == pytest.approx(0.06)
    judging.timed(searched, SearchResult(None, (), judged=10), compute_ms=100.0)  # most refused at a fall
    assert judging.seconds == pytest.approx((0.5 * 60.0 + 100.0) / (0.5 * 1 + 10) / 1e3)  # not (60 + 10) / 2 ms
    before = judging.seconds
    judging.timed(searched, SearchResult(None, (), judged=0), compute_ms=5.0)  # refused before judging any
    assert judging.seconds == before
