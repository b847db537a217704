"""``wm experiment``: the command-line face of :mod:`bridges.experiment.experiment` (imports it lazily).

A ``wm.commands`` plugin (entry point in pyproject.toml): :func:`add_command` and :func:`main`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def add_command(commands: Any) -> None:
    """Add ``experiment`` to the ``wm`` subcommands."""
    p = commands.add_parser("experiment", help="Experiment 1 of the caregiving paper over the full multi-process stack")
    p.add_argument("scenario", help="scenario file or shipped scenario name, e.g. paper_experiment1")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--trials", type=int, default=180, help="randomised trials (default: %(default)s)")
    which.add_argument(
        "--only",
        type=_indices,
        metavar="K[,K...]",
        help="run only these trials of the seed's sequence (trial K is the same trial, sensor noise included, "
        "as in a run of more than K trials), e.g. to re-run the ones an earlier run lost",
    )
    p.add_argument("--seed", type=int, default=2024, help="seed of the trial sampler (default: %(default)s)")
    p.add_argument(
        "--rate",
        type=float,
        default=2.0,
        help="simulated seconds per wall second in the world bridge (default: %(default)s)",
    )
    p.add_argument("--json", type=Path, help="write the results here")
    p.add_argument("--figures", type=Path, help="write the Fig. 3 style trial figure and the reaction histogram here")
    p.add_argument("--logs", type=Path, help="directory for the processes' logs (default: a temporary one)")
    p.add_argument(
        "--record-searches",
        action="store_true",
        help="the simulator records each batch of robot moves it serves, with its scene, under LOGS/searches, "
        "to be served again offline (bench/bench_replay_searches.py)",
    )
    p.add_argument(
        "--min-track",
        type=float,
        default=0.0,
        help="seconds a person is in W before Algorithm 1 guesses their walks (default: %(default)s, from the "
        "first frame perception writes them)",
    )
    p.add_argument(
        "--compare",
        type=Path,
        help="an earlier run's JSON: the trial figure then shows a trial saved now that collided there",
    )


def _indices(text: str) -> list[int]:
    try:
        indices = [int(k) for k in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected trial numbers separated by commas, got {text!r}") from None
    if min(indices) < 0:
        raise argparse.ArgumentTypeError(f"expected trial numbers of 0 or more, got {text!r}")
    return indices


def main(args: argparse.Namespace) -> int:
    """Run the experiment; errors are one line on stderr and exit status 1."""
    try:
        from agents.caregiving.model.errors import ScenarioError

        from .experiment import experiment
        from .launch import LaunchError
        from .trials import TrialError
    except ModuleNotFoundError as exc:
        print(
            f"wm experiment: error: {exc}; the experiment needs the caregiving extra: pip install 'cortex-wm[caregiving]'",
            file=sys.stderr,
        )
        return 1

    if args.trials < 1:
        print("wm experiment: error: --trials must be at least 1", file=sys.stderr)
        return 1
    try:
        experiment(
            args.scenario,
            args.trials,
            args.seed,
            rate=args.rate,
            json_out=args.json,
            figures=args.figures,
            logdir=args.logs,
            compare=args.compare,
            only=args.only,
            record_searches=args.record_searches,
            min_track=args.min_track,
        )
    except (ScenarioError, LaunchError, TrialError) as exc:
        print(f"wm experiment: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    return 0
