"""Serve recorded batches of robot moves again with two source trees, taking turns, and compare their wall time.

A change to the imagination that should judge the same moves with the same verdicts, only faster, is measured
here. Each ``--code NAME=SRC`` names a ``src`` directory (the project's, or another version's:
``git archive REV src | tar -x -C DIR``). For each directory of batches recorded by ``wm experiment
--record-searches``, each code serves every batch once, in a process of its own, with the numpy rollout and no
helper process. The codes take turns for ``--rounds`` rounds, so that the machine's drift falls on both alike.
It prints, per directory and round, each code's seconds and how many of its answers are the ones sent live,
and the first code's seconds over each other code's (above 1: the other is faster).

    python bench/bench_replay_two_codes.py DIR [DIR ...] --code before=/tmp/old/src --code after=src
        [--rounds N] [--json PATH]
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import benchlib


def serve(directory: Path) -> None:
    """Serve every batch of ``directory`` once with the code on this process's path; print what came of it."""
    from agents.caregiving.model.recorded_batch import read_batches
    from bench_replay_searches import replay

    same, ms = 0, 0.0
    batches = read_batches(directory)
    for batch in batches:
        answers, served_ms, _ = replay(batch, 1)
        ms += served_ms
        same += answers == batch.reply.results
    print(json.dumps({"batches": len(batches), "same_answers": same, "seconds": round(ms / 1e3, 3)}))


def served_by(src: Path, directory: Path) -> dict[str, Any]:
    """What :func:`serve` reports, run in a child process with ``src`` first on its path."""
    env = {**os.environ, "PYTHONPATH": str(src.resolve())}
    done = subprocess.run(
        [sys.executable, __file__, "--serve", str(directory)], env=env, capture_output=True, text=True, check=True
    )
    report: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return report


def code(spec: str) -> tuple[str, Path]:
    """``NAME=SRC`` as a name and an existing directory."""
    name, sep, src = spec.partition("=")
    if not sep or not name or not Path(src).is_dir():
        raise SystemExit(f"--code wants NAME=SRC with SRC a directory, got {spec!r}")
    return name, Path(src)


def main() -> None:
    if sys.argv[1:2] == ["--serve"]:
        serve(Path(sys.argv[2]))
        return
    p = benchlib.parser("bench_replay_two_codes", __doc__.splitlines()[0])
    p.add_argument("directories", type=Path, nargs="+", help="where batches were recorded")
    p.add_argument("--code", type=code, action="append", required=True, help="NAME=SRC, at least twice")
    p.add_argument("--rounds", type=int, default=2, help="turns each code takes per directory (default: %(default)s)")
    args = p.parse_args()
    codes: list[tuple[str, Path]] = args.code
    if len(codes) < 2:
        raise SystemExit("give --code at least twice")
    rows: list[dict[str, Any]] = []
    for directory in args.directories:
        for round_ in range(1, args.rounds + 1):
            reports = {name: served_by(src, directory) for name, src in codes}
            first = codes[0][0]
            ratios = {
                f"{first}/{name}": round(reports[first]["seconds"] / reports[name]["seconds"], 3)
                for name, _ in codes[1:]
            }
            rows.append({"directory": str(directory), "round": round_, "served": reports, "ratios": ratios})
            benchlib.print_table(
                f"{directory}, round {round_}",
                [
                    ("seconds", {name: r["seconds"] for name, r in reports.items()}),
                    (
                        "same answers as live",
                        {name: f"{r['same_answers']} of {r['batches']}" for name, r in reports.items()},
                    ),
                    ("ratios", ratios),
                ],
            )
    benchlib.write_json(args.json, {"codes": {n: str(s) for n, s in codes}, "rounds": args.rounds, "rows": rows})


if __name__ == "__main__":
    main()
