"""A module-scoped caregiving stack (world bridge + five agents, real Zenoh on loopback) and a trial runner."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from pathlib import Path

import pytest

from bridges.experiment.launch import Stack
from bridges.experiment.trials import TrialRecord, open_harness

GRAPH = "stacktest"
#: The scenario files the stack tests run.
SCENARIOS = Path(__file__).parent / "scenarios"


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    """The stack in real time, stopped by PID at the end of the module."""
    with Stack(GRAPH, "paper_experiment1", tmp_path_factory.mktemp("stack-logs"), rate=1.0) as s:
        yield s


def recording_stack(factory: pytest.TempPathFactory, scenario: str, rate: float) -> Iterator[Stack]:
    """A stack of ``scenario`` at ``rate`` that records its searches under its logs, stopped by PID at the end."""
    logs = factory.mktemp("recording-stack-logs")
    with Stack(GRAPH, scenario, logs, rate=rate, record=logs / "searches") as s:
        yield s


def run_trial(stack: Stack, scenario: str, seed: int = 0, index: int | None = None) -> TrialRecord:
    """Run one trial of ``scenario`` on the stack and return what W showed and what happened."""

    async def go() -> TrialRecord:
        async with open_harness(stack.endpoint, GRAPH, name="test-harness") as harness:
            return await harness.run(seed, index, timeout=60.0, scenario=scenario)

    stack.check()
    return asyncio.run(go())
