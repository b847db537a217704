"""Command-line options of the agents that judge risk under sensor noise (intention and action)."""

from __future__ import annotations

import argparse

from agents.caregiving.model.guesses import HEADING_GATE_DEG, WALKING_SPEED, Walking, aside_of
from agents.caregiving.model.scenario import load_scenario

DEFAULT_SIZE_ERROR = 0.2


def add_risk_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", help="take the sensors' size error from this scenario")
    parser.add_argument(
        "--size-error", type=float, help=f"bound of the object size bias (default {DEFAULT_SIZE_ERROR})"
    )
    parser.add_argument("--samples", type=int, default=64, help="sampled worlds per imagined walk")
    parser.add_argument(
        "--risk-threshold",
        type=float,
        default=0.2,
        help="collision probability deemed risky (see docs/caregiving.md, precision)",
    )


def add_walking_arguments(parser: argparse.ArgumentParser) -> None:
    """When a person counts as walking, and how far off their heading a walk of theirs may set off: Algorithm 1
    gates its guesses with them, and Algorithm 2 imagines bystanders by them, so both agents take the same."""
    parser.add_argument(
        "--heading-gate-deg",
        type=float,
        default=HEADING_GATE_DEG,
        help="a walking person's heading must match the path's start within this",
    )
    parser.add_argument("--moving-speed", type=float, default=WALKING_SPEED, help="m/s above which a person walks")


def walking(args: argparse.Namespace) -> Walking:
    """The options :func:`add_walking_arguments` added, as a :class:`Walking`."""
    return Walking(args.moving_speed, aside_of(args.heading_gate_deg))


def size_error(args: argparse.Namespace) -> float:
    """The size bias to sample: given, else the scenario's sensors', else the default."""
    if args.size_error is not None:
        return float(args.size_error)
    spec = load_scenario(args.scenario) if args.scenario else None
    return spec.sensors.size_error if spec and spec.sensors.enabled else DEFAULT_SIZE_ERROR
