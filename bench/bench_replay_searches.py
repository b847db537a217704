"""Serve recorded batches of robot moves again in this process, and compare them with how they were served live.

``wm experiment --record-searches`` (or the simulator's ``--record DIR``) writes every batch of robot moves
the simulator served, with the scene it was served against
(:mod:`agents.caregiving.model.recorded_batch`). This bench serves each one again, alone and idle, with
the numpy rollout and no helper process (a head start it finds is taken, as live, and dropped),
``--passes`` times, and reports:

* whether each answer is the one sent live (the same moves judged, the same verdicts, the same choice and
  head start): a search's answer is a function of its request, so any difference is a bug;
* the live serving thread's CPU time beside the replay's wall time (the best of the passes, each pass
  starting with no walk planned, as a live search on a new belief does), for the
  batches that judged one candidate and those that judged several (live, a helper process may have judged
  some of those);
* for the batches whose search sent a head start, how long after the batch began it went out (the best of
  the passes): what the robot waits, at rest, before it moves at all;
* for the searches of generated candidates, how much later than it did each was imagined to end (its
  slots times the ``judging`` it was asked with, less the live serving thread's time): the search imagines
  its k-th candidate setting off ``judging * k`` after the first, so a search that ends well before that
  sends a move that sets off earlier than it was imagined to.

    python bench/bench_replay_searches.py DIR [--passes N] [--json PATH]
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import benchlib
from agents.caregiving.model.imagine import planner_for
from agents.caregiving.model.imagine_reply import Answer
from agents.caregiving.model.recorded_batch import RecordedBatch, read_batches


def judged(answers: tuple[Answer, ...]) -> int:
    """Candidates the batch's searches judged (a joint item is one)."""
    return sum(a.search.judged if a.search is not None else 1 for a in answers)


def replay(batch: RecordedBatch, passes: int) -> tuple[tuple[Answer, ...], float, float | None]:
    """The batch's answers served again, the best wall time of ``passes`` (ms), and the best time to its head
    start (ms; None when it sent none)."""
    best, leads, answers = float("inf"), [], ()
    sent: list[float] = []
    for _ in range(passes):
        planner_for(batch.scene.bounds).forget_plans()
        sent.clear()
        started = time.perf_counter()
        answers = batch.serve_again(head_start=lambda lead: sent.append(time.perf_counter()))
        best = min(best, (time.perf_counter() - started) * 1e3)
        if sent:
            leads.append((sent[0] - started) * 1e3)
    return answers, best, min(leads, default=None)


def group(rows: list[tuple[float, float]]) -> dict[str, Any]:
    """Live thread CPU and replay wall, summed, with their ratio."""
    live, again = sum(r[0] for r in rows), sum(r[1] for r in rows)
    return {
        "batches": len(rows),
        "live_thread_ms": round(live, 1),
        "replay_ms": round(again, 1),
        "live_per_replay": round(live / again, 3) if again else None,
    }


def main() -> None:
    p = benchlib.parser("bench_replay_searches", __doc__.splitlines()[0])
    p.add_argument("directory", type=Path, help="where the batches were recorded")
    p.add_argument("--passes", type=int, default=2, help="times each batch is served again (default: %(default)s)")
    args = p.parse_args()
    batches = read_batches(args.directory)
    same, different = 0, []
    one: list[tuple[float, float]] = []
    several: list[tuple[float, float]] = []
    leads: list[float] = []
    imagined_later: list[float] = []
    for batch in batches:
        answers, ms, lead_ms = replay(batch, args.passes)
        if lead_ms is not None:
            leads.append(lead_ms)
        if answers == batch.reply.results:
            same += 1
        else:
            different.append(batch.number)
        (one if judged(batch.reply.results) <= 1 else several).append((batch.thread_ms, ms))
        item, found = batch.items[0], batch.reply.results[0].search
        if item.get("kind") == "search" and item.get("moves") is None and found is not None and found.judged:
            imagined_later.append(item["judging"] * 1e3 * found.judged - batch.thread_ms)
    figures = {
        "batches": len(batches),
        "same_answers": same,
        "different": different,
        "one_candidate": group(one),
        "several_candidates": group(several),
        "head_starts": len(leads),
        "head_start_ms": benchlib.percentiles(leads) if leads else None,
        "imagined_end_after_served_ms": benchlib.percentiles(imagined_later) if imagined_later else None,
        "ended_over_50_ms_early": sum(later > 50.0 for later in imagined_later),
    }
    benchlib.print_table(f"recorded batches of {args.directory}, served again", list(figures.items()))
    benchlib.write_json(args.json, {"directory": str(args.directory), "passes": args.passes, **figures})


if __name__ == "__main__":
    main()
