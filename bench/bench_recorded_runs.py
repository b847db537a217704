"""Every recorded live run of ``wm experiment``, summed room by room: what the stack did in each kind of room.

It takes one run of each room and seed in ``docs/results`` (shipped and held out), the first by name, as
``bench_move_search.every_room`` picks them: the plain ``ROOM_seedN.json`` where there is one, which is the
first run at that seed, with the code of its day. Per room it sums the trials, the truly risky ones, recall,
the trials some move could save (the physical oracle) and those prevented, the people some move could save
and those saved (runs that score people), the collisions the robot caused in trials safe with it idle and
the people it tripped in trials where someone else fell. It reads the runs' JSONs only, and runs in a second.

    python bench/bench_recorded_runs.py [--json PATH]
"""

from __future__ import annotations

import json
from collections import Counter
from typing import Any

import benchlib
from bench_move_search import RECORDED, every_room, room_of

#: The counts summed per room, as each run's JSON names them (``None`` or absent counts 0).
COUNTS = (
    "trials",
    "truly_risky",
    "tp",
    "fn",
    "oracle_saveable",
    "prevented_saveable",
    "people_saveable",
    "people_saved_saveable",
    "robot_caused_collisions",
    "robot_tripped_people",
)


def scored(recorded: dict[str, Any]) -> bool:
    """Whether a recorded run was scored against the physical oracle."""
    return "oracle_saveable" in recorded


def by_room(runs: list[str]) -> dict[str, Counter[str]]:
    """The :data:`COUNTS` of ``runs`` summed by room, with ``seeds`` the number of runs summed."""
    rooms: dict[str, Counter[str]] = {}
    for run in runs:
        recorded = json.loads((RECORDED / f"{run}.json").read_text())
        room = rooms.setdefault(room_of(recorded), Counter())
        room["seeds"] += 1
        room.update({k: int(recorded.get(k) or 0) for k in COUNTS})
    return rooms


def share(part: int, whole: int) -> str:
    return f"{part} of {whole} ({100 * part / whole:.0f} %)" if whole else "—"


def main() -> None:
    args = benchlib.parser("bench_recorded_runs", __doc__.splitlines()[0]).parse_args()
    rooms = by_room(every_room(scored))
    total: Counter[str] = Counter()
    print(
        "| Room | Seeds | Truly risky | Recall | Prevented, of saveable | People saved, of saveable | Caused | Tripped |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, c in sorted(rooms.items(), key=lambda kv: (-kv[1]["oracle_saveable"], kv[0])):
        total.update(c)
        recall = f"{c['tp'] / (c['tp'] + c['fn']):.3f}" if c["tp"] + c["fn"] else "—"
        print(
            f"| {name} | {c['seeds']} | {c['truly_risky']} | {recall} | "
            f"{share(c['prevented_saveable'], c['oracle_saveable'])} | "
            f"{share(c['people_saved_saveable'], c['people_saveable'])} | "
            f"{c['robot_caused_collisions']} | {c['robot_tripped_people']} |"
        )
    print(
        f"all {len(rooms)} rooms, {total['seeds']} runs: prevented "
        f"{share(total['prevented_saveable'], total['oracle_saveable'])}; recall "
        f"{total['tp'] / (total['tp'] + total['fn']):.4f}; robot-caused collisions {total['robot_caused_collisions']}"
    )
    benchlib.write_json(args.json, {"rooms": {k: dict(v) for k, v in sorted(rooms.items())}, "total": dict(total)})


if __name__ == "__main__":
    main()
