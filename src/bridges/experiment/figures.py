"""Figures of Experiment 1: one trial drawn like the paper's Fig. 3, and the reaction-time histogram.

The trial figure shows W as the robot saw it when it decided: the room, the
person and their field-of-view cone, every intention's imagined path (risky
ones red), the predicted collision point, the robot at its start and at its
imagined final pose, and, dotted, what really happened afterwards.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon, Wedge

from agents.caregiving.model.geometry import Box, Circle, corners
from agents.caregiving.model.scene import Scene

from .trials import TrialRecord, finite

if TYPE_CHECKING:
    from .experiment import Scored

COLOURS = {"target": "#3a9d3a", "obstacle": "#d62728", "wall": "#555555", "other": "#8c8c8c"}


def _draw_shape(ax: Any, shape: Circle | Box, **style: Any) -> None:
    if isinstance(shape, Circle):
        ax.add_patch(CirclePatch((shape.x, shape.y), shape.r, **style))
    else:
        ax.add_patch(Polygon(corners(shape), closed=True, **style))


def draw_trial(record: TrialRecord, path: Path, title: str = "") -> Path:
    """Draw one trial's decision snapshot (see the module documentation)."""
    snap = record.snapshot
    if snap is None:
        raise ValueError("this trial has no snapshot (no risky intention arose)")
    scene = Scene.from_wire(snap.scene)
    fig, ax = plt.subplots(figsize=(8, 6.2))
    x0, y0, x1, y1 = scene.bounds
    for o in scene.obstacles:
        colour = COLOURS["wall"] if o.kind == "wall" else COLOURS["target"] if o.target else COLOURS["obstacle"]
        _draw_shape(ax, o.shape, facecolor=colour, alpha=0.55 if o.kind != "wall" else 0.9, edgecolor="black", lw=0.6)
        if o.kind != "wall":
            ax.annotate(o.kind, (o.shape.x, o.shape.y), ha="center", va="center", fontsize=8)
    for p in scene.people:
        ax.add_patch(
            Wedge(
                (p.x, p.y),
                2.5,
                math.degrees(p.heading - p.hfov / 2),
                math.degrees(p.heading + p.hfov / 2),
                facecolor="#9be39b",
                alpha=0.25,
                edgecolor="none",
            )
        )
        ax.add_patch(CirclePatch((p.x, p.y), p.radius, facecolor="#f2d024", edgecolor="black", lw=0.8, zorder=4))
    for it in snap.intentions:
        flat = it.get("path") or ()
        xs, ys = flat[0::2], flat[1::2]
        risky = bool(it.get("risky"))
        ax.plot(
            xs,
            ys,
            color="#d62728" if risky else "#2a7fd4",
            ls="--" if risky else "-",
            lw=1.6,
            label=f"to {it.get('target')} ({'risky' if risky else 'safe'})",
            zorder=3,
        )
        if risky and it.get("collision_point"):
            cx, cy = it["collision_point"]
            ax.plot([cx], [cy], marker="X", color="black", ms=11, zorder=5, label="predicted collision")
    r = scene.robot
    if r is not None:
        _draw_shape(ax, r.body().shape, facecolor="#b22222", edgecolor="black", alpha=0.8, label="robot (start)")
    action = snap.action or record.action
    if action is not None and r is not None:
        fx, fy, fh = action["final_pose"]
        _draw_shape(
            ax,
            Box(fx, fy, r.length / 2, r.width / 2, fh),
            facecolor="#90ee90",
            edgecolor="black",
            alpha=0.8,
            label="robot (imagined)",
        )
    for name, track in record.outcome.get("tracks", {}).items():
        xs = [t[1] for t in track]
        ys = [t[2] for t in track]
        ax.plot(
            xs,
            ys,
            ls=":",
            lw=1.2,
            color="#b22222" if name == (r.name if r else "") else "#a07800",
            label=f"{name}: what happened",
        )
    for c in record.outcome.get("collisions", []):
        ax.plot([c["point"][0]], [c["point"][1]], marker="*", color="red", ms=14, zorder=6, label="real collision")
    ax.set_xlim(x0 - 0.2, x1 + 0.2)
    ax.set_ylim(y0 - 0.2, y1 + 0.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), loc="upper left", fontsize=7, framealpha=0.85)
    ax.set_title(title or "W at the robot's decision")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def draw_reactions(records: list[TrialRecord], path: Path) -> Path:
    """Histogram of reaction times, the paper's definition and end to end."""
    reaction = finite([r.reaction_ms for r in records])
    e2e = finite([r.e2e_ms for r in records])
    fig, ax = plt.subplots(figsize=(7, 4))
    top = max(reaction + e2e + [1.0])
    bins = [top * i / 30 for i in range(31)]
    ax.hist(reaction, bins=bins, alpha=0.7, label=f"risky intention -> action (n={len(reaction)})")
    ax.hist(e2e, bins=bins, alpha=0.5, label=f"perception write -> action (n={len(e2e)})")
    ax.set_xlabel("milliseconds")
    ax.set_ylabel("trials")
    ax.legend()
    ax.set_title("Reaction time (paper: 747 +/- 310 ms)")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def write_all(scored: list[Scored], directory: Path, lost_before: set[int] | None = None) -> list[Path]:
    """The Fig. 3 of the first truly risky trial the robot saved (one in ``lost_before`` if any), and the histogram."""
    out = []
    drawable = [s for s in scored if s.record.snapshot is not None]
    saved = [s for s in drawable if s.truly_risky and s.record.action is not None and not s.record.collided]
    chosen = next((s for s in saved if s.record.index in (lost_before or set())), next(iter(saved), None))
    chosen = chosen or next((s for s in drawable if s.record.action is not None), None)
    chosen = chosen or next(iter(drawable), None)
    if chosen is not None:
        out.append(
            draw_trial(
                chosen.record, directory / "fig3_trial.png", f"Trial {chosen.record.index}: W at the robot's decision"
            )
        )
    out.append(draw_reactions([s.record for s in scored], directory / "reaction_times.png"))
    return out
