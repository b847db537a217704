"""Reaction times of a recorded run, and a plot of them as a standalone SVG.

A reaction is the time from a risky intention appearing in W (a
``has_intention`` edge whose ``risky`` becomes true) to the robot's action in
W (the next ``intention`` node added), both as the recorder saw them on its
``/wm/changes`` channel. A risky intention with no action after it counts as
missed.

``wm reactions FILE`` prints them: a ``wm.commands`` plugin (:func:`add_command`, :func:`main`).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.caregiving.names import ACTION_NODE, RISKY_EDGE


@dataclass(frozen=True)
class Reaction:
    """One risky intention (who, towards what, when) and the action that answered it, if any."""

    person: str
    target: str
    risky_at_ns: int
    action: str | None = None
    reaction_ms: float | None = None


def reactions(path: str | Path) -> list[Reaction]:
    """Every risky onset in the recording, paired with the first action added after it."""
    from wm.monitoring.recording_file import CHANGES, iter_messages  # here, so that `wm --help` need not load MCAP

    risky: set[tuple[int | None, int | None]] = set()
    pending: list[Reaction] = []
    done: list[Reaction] = []
    for _, t_ns, data in iter_messages(path, [CHANGES]):
        change = json.loads(data)
        if (
            change["type"] == RISKY_EDGE
            and change["kind"] in ("edge_added", "edge_updated")
            and "risky" in change["attrs"]
        ):
            key = (change["src"], change["dst"])
            if change["attrs"]["risky"] and key not in risky:
                risky.add(key)
                pending.append(
                    Reaction(change["src_name"] or str(change["src"]), change["dst_name"] or str(change["dst"]), t_ns)
                )
            elif not change["attrs"]["risky"]:
                risky.discard(key)
        elif change["type"] == ACTION_NODE and change["kind"] == "node_added":
            done += [
                Reaction(r.person, r.target, r.risky_at_ns, change["name"], (t_ns - r.risky_at_ns) / 1e6)
                for r in pending
            ]
            pending = []
    return sorted(done + pending, key=lambda r: r.risky_at_ns)


def summary(found: list[Reaction]) -> dict[str, float | int]:
    """Count, missed, mean and standard deviation (ms) of the reaction times."""
    times = [r.reaction_ms for r in found if r.reaction_ms is not None]
    return {
        "risky": len(found),
        "missed": len(found) - len(times),
        "reaction_ms_mean": statistics.fmean(times) if times else float("nan"),
        "reaction_ms_sd": statistics.stdev(times) if len(times) > 1 else 0.0,
    }


def plot_svg(found: list[Reaction], title: str = "Reaction times", bins: int = 12) -> str:
    """A histogram of the reaction times, with the mean marked, as an SVG document."""
    width, height, left, bottom, top = 640, 360, 56, 44, 36
    times = [r.reaction_ms for r in found if r.reaction_ms is not None]
    stats = summary(found)
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="12">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
        f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="15">{title}</text>',
    ]
    if times:
        lo, hi = min(times), max(times)
        span = (hi - lo) or 1.0
        counts = [0] * bins
        for t in times:
            counts[min(int((t - lo) / span * bins), bins - 1)] += 1
        plot_w, plot_h = width - left - 20, height - top - bottom
        bar_w, peak = plot_w / bins, max(counts)
        for i, count in enumerate(counts):
            h = plot_h * count / peak
            parts.append(
                f'<rect x="{left + i * bar_w:.1f}" y="{top + plot_h - h:.1f}" width="{bar_w - 2:.1f}" height="{h:.1f}" fill="#1565c0"/>'
            )
        for i in range(0, bins + 1, max(bins // 4, 1)):
            parts.append(
                f'<text x="{left + i * bar_w:.1f}" y="{top + plot_h + 16}" text-anchor="middle">{lo + span * i / bins:.1f}</text>'
            )
        mean_x = left + (stats["reaction_ms_mean"] - lo) / span * plot_w
        parts += [
            f'<line x1="{mean_x:.1f}" y1="{top}" x2="{mean_x:.1f}" y2="{top + plot_h}" stroke="#d50000" stroke-dasharray="5 3"/>',
            f'<line x1="{left}" y1="{top + plot_h}" x2="{left + plot_w}" y2="{top + plot_h}" stroke="#263238"/>',
            f'<text x="{left + plot_w / 2}" y="{height - 8}" text-anchor="middle">reaction time, ms (risky intention in W → robot action in W)</text>',
            f'<text x="{left - 8}" y="{top + 10}" text-anchor="end">{peak}</text>',
        ]
    legend = f"n={stats['risky']}, missed {stats['missed']}, mean {stats['reaction_ms_mean']:.1f} ms, sd {stats['reaction_ms_sd']:.1f} ms"
    parts += [f'<text x="{width - 10}" y="{top - 6}" text-anchor="end" fill="#d50000">{legend}</text>', "</svg>"]
    return "\n".join(parts)


def add_command(commands: Any) -> None:
    """Add ``reactions`` to the ``wm`` subcommands."""
    p = commands.add_parser("reactions", help="reaction times of a recorded caregiving run, optionally plotted as SVG")
    p.add_argument("file")
    p.add_argument("--svg", help="write a histogram here")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def main(args: argparse.Namespace) -> int:
    """``wm reactions FILE``: reaction times of a recording (offline: no graph, no network)."""
    try:
        found = reactions(args.file)
    except (OSError, ValueError) as exc:
        print(f"wm reactions: error: cannot read {args.file}: {exc}", file=sys.stderr)
        return 1
    stats = summary(found)
    if args.json:
        print(json.dumps(stats))
    else:
        for r in found:
            answer = f"{r.action} after {r.reaction_ms:.1f} ms" if r.reaction_ms is not None else "no action"
            print(f"{r.person} -> {r.target}: {answer}")
        print(
            f"{stats['risky']} risky, {stats['missed']} missed, mean {stats['reaction_ms_mean']:.1f} ms, "
            f"sd {stats['reaction_ms_sd']:.1f} ms"
        )
    if args.svg:
        Path(args.svg).write_text(plot_svg(found, title=f"Reaction times: {Path(args.file).name}"))
    return 0
