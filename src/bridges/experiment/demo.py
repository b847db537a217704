"""``make demo``: one risky trial end to end across processes, narrated, then a short Experiment 1.

``python -m bridges.experiment.demo [--out DIR] [--trials N] [--rate R]``
"""

from __future__ import annotations

import argparse
import asyncio
import tempfile
from pathlib import Path

from rich.console import Console

from agents.caregiving.model.scenario import load_scenario

from .experiment import Scored, metrics, prevention_line, run_trials, table, with_oracle
from .figures import draw_trial
from .launch import LAUNCH_FILE, Stack

SCENARIO = "paper_experiment1"
#: A trial of seed 7 in which the person cannot see the ball and the robot can get there in time.
RISKY = (7, 6)
#: Simulated seconds per wall-clock second.
RATE = 3.0


def demo_stack(logdir: Path, rate: float = RATE) -> Stack:
    """The demo's stack (graph ``demo``, scenario :data:`SCENARIO`), not started yet."""
    return Stack("demo", SCENARIO, logdir, rate=rate)


def risky_trial(stack: Stack, console: Console) -> Scored:
    """Run the demo's risky trial (:data:`RISKY`) on a started :func:`demo_stack` and score it."""
    return asyncio.run(run_trials(load_scenario(SCENARIO), stack, RISKY[0], [RISKY[1]], console, stack.graph))[0]


def narrate(s: Scored, console: Console) -> None:
    """A few lines on what W showed and what really happened."""
    r = s.record
    console.print(
        f"[bold]Trial {r.index} of seed {RISKY[0]}[/bold]: ground truth with the robot idle: "
        f"{'the person trips' if s.truly_risky else 'safe'}."
    )
    if r.risky is None:
        console.print("No risky intention arose.")
        return
    console.print(
        f"intention agent: has_intention marked risky, collision predicted in "
        f"{r.risky.get('time_to_collision', 0):.2f} s (probability {r.risky.get('probability', 0):.2f})."
    )
    if r.action is None:
        console.print("action agent: no move could remove the danger in time.")
    else:
        x, y, _ = r.action["final_pose"]
        console.print(
            f"action agent: robot intention move_to at ({x:.2f}, {y:.2f}) written "
            f"{r.reaction_ms:.1f} ms after the risky intention ({r.e2e_ms:.1f} ms after the perception "
            f"write that showed the danger)."
        )
    if r.collided:
        c = r.outcome["collisions"][0]
        console.print(f"world: the person touched {c['obstacle']} at t={c['time']:.2f} s.")
    else:
        clearance = min(v for v in r.outcome.get("min_clearance", {}).values() if v is not None)
        console.print(
            f"world: the person saw the robot, walked around, and reached the couch "
            f"(closest approach {100 * clearance:.0f} cm)."
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=Path("build/demo"), help="where the figure goes")
    parser.add_argument("--trials", type=int, default=30)
    parser.add_argument("--rate", type=float, default=RATE)
    args = parser.parse_args()
    console = Console()
    scenario = load_scenario(SCENARIO)
    logs = Path(tempfile.mkdtemp(prefix="wm-demo-"))
    with demo_stack(logs, args.rate) as stack:
        console.print(f"stack ({LAUNCH_FILE.name}): {', '.join(stack.names)} on {stack.endpoint}")
        one = risky_trial(stack, console)
        narrate(one, console)
        if one.record.snapshot is not None:
            path = draw_trial(one.record, args.out / "risky_trial.png", "Risky trial: W at the robot's decision")
            console.print(f"figure: {path}")
        scored = asyncio.run(run_trials(scenario, stack, 2024, list(range(args.trials)), console, stack.graph))
    result = metrics(with_oracle(scenario, 2024, scored, console))
    console.print(table(result))
    console.print(prevention_line(result))


if __name__ == "__main__":
    main()
