"""Which risky intentions Algorithm 2 searches: landed ones at once, unsaved ones again after the retry."""

from __future__ import annotations

from agents.caregiving.search_queue import SearchQueue

ALICE, BOB = (1, 10), (2, 20)


def test_a_landed_intention_is_taken_once() -> None:
    q = SearchQueue(retry=0.1)
    assert not q.waiting
    q.land(ALICE)
    assert q.waiting and q.take() == {ALICE}
    assert not q.waiting and q.take() == set()


def test_a_danger_no_move_removed_is_searched_again_after_the_retry_while_it_stays_risky() -> None:
    q = SearchQueue(retry=0.1)
    q.land(ALICE)
    q.take()
    q.failed(ALICE, now=2.0, candidates=True)
    assert q.waiting and q.take() == {ALICE}  # looked at again at every update of W...
    assert not q.due(ALICE, 2.05)  # ...but not searched within the retry
    assert q.due(ALICE, 2.1)
    q.still_risky({ALICE})
    assert q.take() == {ALICE}
    q.still_risky(set())  # no longer risky in W: forgotten
    assert not q.waiting


def test_a_danger_with_no_candidate_in_reach_waits_for_its_next_update() -> None:
    q = SearchQueue(retry=0.1)
    q.failed(ALICE, now=1.0, candidates=False)
    assert not q.waiting
    q.land(ALICE)  # the intention agent rewrites the edge
    assert q.take() == {ALICE}
    assert not q.due(ALICE, 1.05) and q.due(ALICE, 1.5)


def test_a_saved_danger_is_not_searched_again_and_others_are_kept() -> None:
    q = SearchQueue(retry=0.1)
    q.failed(ALICE, now=1.0, candidates=True)
    q.failed(BOB, now=1.0, candidates=True)
    q.saved(ALICE)
    assert q.take() == {BOB}


def test_a_new_trial_forgets_everything() -> None:
    q = SearchQueue(retry=0.1)
    q.land(BOB)
    q.failed(ALICE, now=1.0, candidates=True)
    q.clear()
    assert not q.waiting and q.due(ALICE, 1.0)
